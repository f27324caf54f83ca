#pragma once
// Runs a campaign's jobs (campaign/spec.hpp) into a campaign folder, one job per worker thread:
//   DIR/campaign.json           the spec and its jobs (a rerun must bring the same spec)
//   DIR/runs/<configuration>/<seeds>/   each job's run folder (pipeline/execute.hpp)
//   DIR/failures.json           the jobs that failed in the last pass, with their errors
// A job whose folder holds a whole run (run.json and metrics.json, not partial) is done and is
// skipped, so a campaign stopped or killed half-way is finished by running it again: each run folder
// is replaced as a whole or not at all, a job killed while it ran is run again, and since every
// result is a job's folder, nothing is counted twice.
#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "slamkit/campaign/spec.hpp"
#include "slamkit/core/atomic_folder.hpp"

namespace slamkit::campaign {

enum class JobStatus {
  kRun,          // run now, to the end
  kAlreadyDone,  // found done in the folder
  kDiverged,     // run now; the filter diverged (its folder says where): a result, not a failure
  kStopped,      // the stop flag ended it: its folder is partial and the next pass runs it again
  kFailed,       // an error (bad data, settings the dataset cannot take, ...), in `error`
};

struct JobOutcome {
  std::size_t index = 0;  // into CampaignSpec::jobs
  JobStatus status = JobStatus::kRun;
  std::string error;
  double seconds = 0.0;
};

struct CampaignTally {
  std::size_t total = 0, run = 0, already_done = 0, diverged = 0, stopped = 0, failed = 0;
  std::size_t finished() const { return run + already_done + diverged + stopped + failed; }
};

/// Where workers get their next job from: by default a counter shared by the threads of one process;
/// the command line's MPI back end shares one between the ranks of an MPI job, so that every rank
/// takes the next job not yet taken as it frees up. Called by one worker at a time.
class JobQueue {
 public:
  virtual ~JobQueue() = default;
  /// The index of the next job to run, or none when every job has been handed out.
  virtual std::optional<std::size_t> next() = 0;
};

struct CampaignOptions {
  /// Jobs run at once, each on a thread of its own (0: default_workers). A job's filter threads are
  /// the spec's threads_per_run.
  unsigned workers = 0;
  /// When set, no job is started, and running ones end as partial (JobStatus::kStopped).
  const std::atomic<bool>* stop = nullptr;
  /// Told of each job as it ends, one call at a time, with the tally so far.
  std::function<void(const Job&, const JobOutcome&, const CampaignTally&)> on_job;
  /// Shared with other processes; nullptr for this process's own.
  JobQueue* queue = nullptr;
};

struct CampaignResult {
  CampaignTally tally;
  std::vector<JobOutcome> failures;  // in job order
};

/// The jobs a machine with `cores` cores and `memory_bytes` of memory runs at once: as many as
/// threads_per_run lets the cores hold and memory_per_run_mb the memory (where it is known, > 0), at
/// least one. CampaignOptions::workers (--jobs) overrides it.
std::size_t default_workers(const CampaignSpec& spec, unsigned cores, double memory_bytes);

/// True if `folder` holds a whole run: run.json (not partial) and metrics.json.
bool job_done(const std::string& folder);

/// Runs every job of `spec` not yet done into `dir` (created): claim_campaign_folder, run_jobs,
/// write_failures. Throws InputError if `dir` holds a different campaign or another process is
/// running a campaign in it; a job's own error fails that job only.
CampaignResult run_campaign(const CampaignSpec& spec, const std::string& dir, const CampaignOptions& options = {});

/// The steps of run_campaign, for a campaign whose workers are spread over processes: one of them
/// claims the folder and writes the failures of all, every one runs jobs.
/// Takes `dir`'s lock (held while the result lives) and records the campaign there, or checks that
/// the one recorded is this one: two specs in one folder would mix their runs in one report.
std::unique_ptr<FolderLock> claim_campaign_folder(const CampaignSpec& spec, const std::string& dir);
/// Runs jobs taken from the queue until it is empty or the stop flag is set; the tally and failures
/// are this process's.
CampaignResult run_jobs(const CampaignSpec& spec, const std::string& dir, const CampaignOptions& options = {});
/// DIR/failures.json for `failures`, given in job order (removed where there are none).
void write_failures(const CampaignSpec& spec, const std::string& dir, const std::vector<JobOutcome>& failures);

}  // namespace slamkit::campaign
