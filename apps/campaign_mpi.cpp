#include "campaign_mpi.hpp"

#include <fmt/format.h>
#include <mpi.h>

#include <algorithm>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "slamkit/core/error.hpp"

namespace slamkit::cli {
namespace {

using nlohmann::json;

/// MPI from construction to destruction, with threads allowed to call it one at a time (the
/// campaign's workers take turns on the queue).
class MpiSession {
 public:
  MpiSession() {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided);
    if (provided < MPI_THREAD_SERIALIZED) {
      MPI_Finalize();
      throw InputError("this MPI library cannot be called from the campaign's worker threads (MPI_THREAD_SERIALIZED)");
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  ~MpiSession() { MPI_Finalize(); }
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }

 private:
  int rank_ = 0, size_ = 1;
};

/// The job counter, a long on rank 0 that every rank increments atomically (MPI_Fetch_and_op).
class MpiQueue : public campaign::JobQueue {
 public:
  MpiQueue(const MpiSession& mpi, std::size_t jobs) : jobs_(static_cast<long>(jobs)) {
    const MPI_Aint bytes = mpi.rank() == 0 ? sizeof(long) : 0;
    MPI_Win_allocate(bytes, sizeof(long), MPI_INFO_NULL, MPI_COMM_WORLD, &counter_, &window_);
    if (mpi.rank() == 0) {
      MPI_Win_lock(MPI_LOCK_EXCLUSIVE, 0, 0, window_);
      *counter_ = 0;
      MPI_Win_unlock(0, window_);
    }
    MPI_Barrier(MPI_COMM_WORLD);  // no rank takes a job before the counter is set
  }
  ~MpiQueue() override { MPI_Win_free(&window_); }
  MpiQueue(const MpiQueue&) = delete;
  MpiQueue& operator=(const MpiQueue&) = delete;

  std::optional<std::size_t> next() override {
    const long one = 1;
    long taken = 0;
    MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, window_);
    MPI_Fetch_and_op(&one, &taken, MPI_LONG, 0, 0, MPI_SUM, window_);
    MPI_Win_unlock(0, window_);
    if (taken >= jobs_) return std::nullopt;
    return static_cast<std::size_t>(taken);
  }

 private:
  long jobs_;
  long* counter_ = nullptr;
  MPI_Win window_{};
};

/// `text` from rank 0 to every rank.
std::string broadcast(const MpiSession& mpi, std::string text) {
  unsigned long size = text.size();
  MPI_Bcast(&size, 1, MPI_UNSIGNED_LONG, 0, MPI_COMM_WORLD);
  if (mpi.rank() != 0) text.resize(size);
  MPI_Bcast(text.data(), static_cast<int>(size), MPI_CHAR, 0, MPI_COMM_WORLD);
  return text;
}

/// Every rank's `text`, on rank 0 (empty elsewhere).
std::vector<std::string> gather(const MpiSession& mpi, const std::string& text) {
  const int size = static_cast<int>(text.size());
  std::vector<int> sizes(static_cast<std::size_t>(mpi.size()));
  MPI_Gather(&size, 1, MPI_INT, sizes.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::vector<int> offsets(sizes.size());
  std::string all;
  if (mpi.rank() == 0) {
    int total = 0;
    for (std::size_t i = 0; i < sizes.size(); ++i) {
      offsets[i] = total;
      total += sizes[i];
    }
    all.resize(static_cast<std::size_t>(total));
  }
  MPI_Gatherv(text.data(), size, MPI_CHAR, all.data(), sizes.data(), offsets.data(), MPI_CHAR, 0, MPI_COMM_WORLD);
  std::vector<std::string> texts;
  if (mpi.rank() == 0)
    for (std::size_t i = 0; i < sizes.size(); ++i)
      texts.push_back(all.substr(static_cast<std::size_t>(offsets[i]), static_cast<std::size_t>(sizes[i])));
  return texts;
}

json to_json(const campaign::CampaignResult& r) {
  json failures = json::array();
  for (const campaign::JobOutcome& f : r.failures) failures.push_back({{"index", f.index}, {"error", f.error}});
  const campaign::CampaignTally& t = r.tally;
  return {{"tally", {t.run, t.already_done, t.diverged, t.stopped, t.failed}}, {"failures", failures}};
}

void add(campaign::CampaignResult& total, const json& rank) {
  const json& t = rank.at("tally");
  total.tally.run += t[0].get<std::size_t>();
  total.tally.already_done += t[1].get<std::size_t>();
  total.tally.diverged += t[2].get<std::size_t>();
  total.tally.stopped += t[3].get<std::size_t>();
  total.tally.failed += t[4].get<std::size_t>();
  for (const json& f : rank.at("failures")) {
    campaign::JobOutcome outcome;
    outcome.index = f.at("index").get<std::size_t>();
    outcome.status = campaign::JobStatus::kFailed;
    outcome.error = f.at("error").get<std::string>();
    total.failures.push_back(std::move(outcome));
  }
}

}  // namespace

int run_campaign_mpi(const campaign::CampaignSpec& spec, const std::string& dir, campaign::CampaignOptions options,
                     const std::function<int(const MpiCampaign&)>& finish) {
  const MpiSession mpi;
  std::unique_ptr<FolderLock> lock;
  std::string refusal;
  if (mpi.rank() == 0) try {
      lock = campaign::claim_campaign_folder(spec, dir);
    } catch (const std::exception& e) {
      refusal = e.what();
    }
  refusal = broadcast(mpi, refusal);
  if (!refusal.empty()) throw InputError(refusal);

  campaign::CampaignResult mine;
  {
    MpiQueue queue(mpi, spec.jobs.size());
    options.queue = &queue;
    if (options.workers == 0) options.workers = 1;  // a rank per core is the MPI way
    mine = campaign::run_jobs(spec, dir, options);
    MPI_Barrier(MPI_COMM_WORLD);  // the window is freed only once every rank has stopped taking jobs
  }
  const std::vector<std::string> ranks = gather(mpi, to_json(mine).dump());
  std::string status;
  if (mpi.rank() == 0) {
    MpiCampaign all{true, mpi.size(), {}};
    all.result.tally.total = spec.jobs.size();
    for (const std::string& rank : ranks) add(all.result, json::parse(rank));
    std::sort(all.result.failures.begin(), all.result.failures.end(),  // each rank's are in order, not all
              [](const campaign::JobOutcome& a, const campaign::JobOutcome& b) { return a.index < b.index; });
    try {  // every rank waits for the status: rank 0 must send one whatever happens
      campaign::write_failures(spec, dir, all.result.failures);
      status = std::to_string(finish(all));
    } catch (const std::exception& e) {
      fmt::print(stderr, "slamkit: error: {}\n", e.what());
      status = "1";
    }
  }
  return std::stoi(broadcast(mpi, status));
}

}  // namespace slamkit::cli
