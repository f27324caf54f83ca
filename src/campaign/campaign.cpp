#include "slamkit/campaign/campaign.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/atomic_folder.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/memory_budget.hpp"

namespace slamkit::campaign {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kCampaignFile = "campaign.json";
constexpr const char* kFailuresFile = "failures.json";

json campaign_record(const CampaignSpec& spec) {
  json jobs = json::array();
  for (const Job& job : spec.jobs) jobs.push_back({{"folder", job.folder}, {"configuration", job.configuration}});
  return {{"name", spec.name}, {"spec", spec.source}, {"jobs", std::move(jobs)}};
}

JobOutcome run_job(const CampaignSpec& spec, std::size_t index, const std::string& dir, const std::atomic<bool>* stop) {
  const Job& job = spec.jobs[index];
  JobOutcome outcome;
  outcome.index = index;
  const std::string folder = (fs::path(dir) / job.folder).string();
  {  // under the folder's lock, whose release also clears the lock file a writer killed at its end left
    const FolderLock lock(folder);
    if (job_done(folder)) {
      outcome.status = JobStatus::kAlreadyDone;
      return outcome;
    }
  }
  const auto start = std::chrono::steady_clock::now();
  try {
    ExecuteOptions options;
    options.provenance = {{"campaign", job.description}};
    options.stop = stop;
    options.outputs = spec.outputs;
    options.memory_budget_bytes = spec.memory_per_run_bytes;
    const RunRecord record = execute(job.spec, folder, options);
    outcome.status = record.run.diverged_at_s ? JobStatus::kDiverged
                     : record.run.partial     ? JobStatus::kStopped
                                              : JobStatus::kRun;
  } catch (const std::exception& e) {  // one job's bad data or settings do not end the others
    outcome.status = JobStatus::kFailed;
    outcome.error = e.what();
  }
  outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return outcome;
}

void count(CampaignTally& tally, JobStatus status) {
  switch (status) {
    case JobStatus::kRun:
      ++tally.run;
      break;
    case JobStatus::kAlreadyDone:
      ++tally.already_done;
      break;
    case JobStatus::kDiverged:
      ++tally.diverged;
      break;
    case JobStatus::kStopped:
      ++tally.stopped;
      break;
    case JobStatus::kFailed:
      ++tally.failed;
      break;
  }
}

}  // namespace

std::size_t default_workers(const CampaignSpec& spec, unsigned cores, double memory_bytes) {
  std::size_t workers = std::max(1u, cores) / std::max(1u, spec.threads_per_run);
  if (spec.memory_per_run_bytes > 0.0 && memory_bytes > 0.0)  // an unknown memory bounds nothing
    workers = std::min(workers, static_cast<std::size_t>(memory_bytes / spec.memory_per_run_bytes));
  return std::max<std::size_t>(1, workers);
}

bool job_done(const std::string& folder) {
  const fs::path run_json = fs::path(folder) / "run.json";
  if (!fs::exists(run_json) || !fs::exists(fs::path(folder) / "metrics.json")) return false;
  try {
    return !read_json_file(run_json.string()).value("partial", true);
  } catch (const std::exception&) {  // unreadable: not a whole run, so the job runs again
    return false;
  }
}

std::unique_ptr<FolderLock> claim_campaign_folder(const CampaignSpec& spec, const std::string& dir) {
  auto lock = std::make_unique<FolderLock>(dir);
  fs::create_directories(dir);
  const std::string path = (fs::path(dir) / kCampaignFile).string();
  if (fs::exists(path)) {
    if (read_json_file(path).value("spec", json()) != spec.source)
      throw InputError(path, 0,
                       "this folder holds a campaign of another spec; give another --out, or remove the folder to "
                       "start again");
    return lock;
  }
  if (!fs::is_empty(dir))
    throw InputError(dir, 0, "not empty and holds no campaign.json; expected a new folder or a campaign's folder");
  write_file_atomically(path, campaign_record(spec).dump(1) + "\n");
  return lock;
}

namespace {

/// The queue of one process: its threads take turns on a counter.
class LocalQueue : public JobQueue {
 public:
  explicit LocalQueue(std::size_t jobs) : jobs_(jobs) {}
  std::optional<std::size_t> next() override {
    if (next_ >= jobs_) return std::nullopt;
    return next_++;
  }

 private:
  std::size_t jobs_, next_ = 0;
};

}  // namespace

CampaignResult run_jobs(const CampaignSpec& spec, const std::string& dir, const CampaignOptions& options) {
  LocalQueue local(spec.jobs.size());
  JobQueue& queue = options.queue != nullptr ? *options.queue : local;
  CampaignResult result;
  result.tally.total = spec.jobs.size();
  std::mutex queue_mutex, result_mutex;
  const auto worker = [&] {
    for (;;) {
      if (options.stop != nullptr && options.stop->load()) return;
      std::optional<std::size_t> index;
      {
        const std::lock_guard guard(queue_mutex);
        index = queue.next();
      }
      if (!index) return;
      const JobOutcome outcome = run_job(spec, *index, dir, options.stop);
      const std::lock_guard guard(result_mutex);
      count(result.tally, outcome.status);
      if (outcome.status == JobStatus::kFailed) result.failures.push_back(outcome);
      if (options.on_job) options.on_job(spec.jobs[*index], outcome, result.tally);
    }
  };
  const std::size_t workers = std::min<std::size_t>(
      options.workers == 0 ? default_workers(spec, std::thread::hardware_concurrency(), physical_memory_bytes())
                           : options.workers,
      std::max<std::size_t>(1, spec.jobs.size()));
  {
    std::vector<std::jthread> threads;
    for (std::size_t i = 1; i < workers; ++i) threads.emplace_back(worker);
    worker();
  }
  std::sort(result.failures.begin(), result.failures.end(),
            [](const JobOutcome& a, const JobOutcome& b) { return a.index < b.index; });
  return result;
}

void write_failures(const CampaignSpec& spec, const std::string& dir, const std::vector<JobOutcome>& failures) {
  json list = json::array();
  for (const JobOutcome& f : failures) list.push_back({{"folder", spec.jobs[f.index].folder}, {"error", f.error}});
  const std::string path = (fs::path(dir) / kFailuresFile).string();
  if (list.empty())
    fs::remove(path);
  else
    write_file_atomically(path, list.dump(1) + "\n");
}

CampaignResult run_campaign(const CampaignSpec& spec, const std::string& dir, const CampaignOptions& options) {
  const auto lock = claim_campaign_folder(spec, dir);
  CampaignResult result = run_jobs(spec, dir, options);
  write_failures(spec, dir, result.failures);
  return result;
}

}  // namespace slamkit::campaign
