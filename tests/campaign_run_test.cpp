// Running campaigns: every job once, results independent of the number of workers, a rerun that
// skips what is done and finishes what is not, and failures kept to the job that failed.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "slamkit/campaign/campaign.hpp"
#include "slamkit/core/error.hpp"
#include "test_data.hpp"

namespace slamkit::campaign {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test_data::read_json;

const json kSmall = json::parse(R"({
  "name": "small",
  "outputs": "metrics",
  "datasets": [{"spec": "scenario:default", "seeds": [1, 2], "settings": {"loops": 1}}],
  "filters": [{"name": "ekf"}, {"name": "fej", "settings": {"ekf_variant": "fej"}}]
})");

class CampaignRun : public ::testing::Test {
 protected:
  void SetUp() override {
    work_ = fs::temp_directory_path() / ("slamkit_campaign_run_" + std::to_string(getpid()));
    fs::remove_all(work_);
  }
  void TearDown() override { fs::remove_all(work_); }
  static CampaignSpec small() { return parse_campaign_spec(kSmall, "small.json", "."); }
  fs::path work_;
};

TEST_F(CampaignRun, RunsEveryJobOnceWhateverTheWorkersAndSkipsThemWhenRerun) {
  const CampaignSpec spec = small();
  CampaignOptions two;
  two.workers = 2;
  const CampaignResult first = run_campaign(spec, (work_ / "a").string(), two);
  EXPECT_EQ(first.tally.total, 4u);
  EXPECT_EQ(first.tally.run, 4u);
  EXPECT_TRUE(first.failures.empty());
  EXPECT_TRUE(fs::exists(work_ / "a" / "campaign.json"));
  for (const Job& job : spec.jobs) {
    const fs::path folder = work_ / "a" / job.folder;
    EXPECT_TRUE(job_done(folder.string())) << folder;
    EXPECT_FALSE(fs::exists(folder / "trajectory.tum")) << "outputs: metrics keeps run.json and metrics.json only";
    EXPECT_EQ(read_json(folder / "run.json").at("campaign").at("configuration"), job.configuration);
  }

  const CampaignResult again = run_campaign(spec, (work_ / "a").string(), two);
  EXPECT_EQ(again.tally.already_done, 4u);
  EXPECT_EQ(again.tally.run, 0u);

  CampaignOptions one;
  one.workers = 1;
  run_campaign(spec, (work_ / "b").string(), one);
  for (const Job& job : spec.jobs)
    EXPECT_EQ(read_json(work_ / "a" / job.folder / "metrics.json").at("ate_rmse_m"),
              read_json(work_ / "b" / job.folder / "metrics.json").at("ate_rmse_m"))
        << job.folder;
}

TEST_F(CampaignRun, APartialRunIsRunAgainAndOnlyIt) {
  const CampaignSpec spec = small();
  const std::string dir = (work_ / "c").string();
  run_campaign(spec, dir);
  const fs::path stopped = fs::path(dir) / spec.jobs[1].folder / "run.json";
  json run = read_json(stopped);
  run["partial"] = true;
  test_data::write_text(stopped, run.dump());
  EXPECT_FALSE(job_done(stopped.parent_path().string()));
  const CampaignResult rerun = run_campaign(spec, dir);
  EXPECT_EQ(rerun.tally.run, 1u);
  EXPECT_EQ(rerun.tally.already_done, 3u);
  EXPECT_FALSE(read_json(stopped).at("partial").get<bool>());
}

TEST_F(CampaignRun, AFolderOfAnotherCampaignIsRefused) {
  const std::string dir = (work_ / "d").string();
  run_campaign(small(), dir);
  json other = kSmall;
  other["datasets"][0]["seeds"] = json::array({3});
  EXPECT_THROW(run_campaign(parse_campaign_spec(other, "other.json", "."), dir), InputError);
  fs::create_directories(work_ / "e");
  test_data::write_text(work_ / "e" / "notes.txt", "mine");
  EXPECT_THROW(run_campaign(small(), (work_ / "e").string()), InputError);
}

TEST_F(CampaignRun, AFailingJobFailsAloneAndIsListed) {
  json spec = kSmall;
  spec["filters"][1] = json::parse(R"({"name": "grid", "settings": {"filter": "scan-matching"}})");
  const CampaignSpec expanded = parse_campaign_spec(spec, "mixed.json", ".");
  const std::string dir = (work_ / "f").string();
  const CampaignResult result = run_campaign(expanded, dir);
  EXPECT_EQ(result.tally.run, 2u);
  EXPECT_EQ(result.tally.failed, 2u);
  ASSERT_EQ(result.failures.size(), 2u);
  EXPECT_NE(result.failures[0].error.find("scan-matching"), std::string::npos) << result.failures[0].error;
  EXPECT_EQ(read_json(fs::path(dir) / "failures.json").size(), 2u);
}

TEST_F(CampaignRun, AMemoryBudgetLimitsTheJobsAtOnceAndRefusesARunOverIt) {
  json spec = kSmall;
  spec["memory_per_run_mb"] = 6000;
  const CampaignSpec budgeted = parse_campaign_spec(spec, "budget.json", ".");
  EXPECT_EQ(default_workers(budgeted, 8, 24e9), 4u);  // the memory holds four runs of 6 GB
  EXPECT_EQ(default_workers(budgeted, 2, 24e9), 2u);  // the cores two
  EXPECT_EQ(default_workers(budgeted, 8, 4e9), 1u);   // one at least, which its own check then weighs
  spec["threads_per_run"] = 3;
  EXPECT_EQ(default_workers(parse_campaign_spec(spec, "budget.json", "."), 8, 1e12), 2u);
  EXPECT_EQ(default_workers(small(), 2, 1e9), 2u);  // without a budget, a job per core

  // A one-lap EKF over the default world's 100 landmarks needs a few megabytes; 10 kB is refused.
  spec = kSmall;
  spec["memory_per_run_mb"] = 0.01;
  const CampaignResult result = run_campaign(parse_campaign_spec(spec, "tiny.json", "."), (work_ / "m").string());
  EXPECT_EQ(result.tally.failed, 4u);
  ASSERT_FALSE(result.failures.empty());
  EXPECT_NE(result.failures[0].error.find("more than the 9.31e-06 GiB each run may use (a campaign's memory_per_run_mb)"),
            std::string::npos)
      << result.failures[0].error;
}

TEST_F(CampaignRun, AStopFlagStartsNoMoreJobs) {
  std::atomic<bool> stop{true};
  CampaignOptions options;
  options.stop = &stop;
  const CampaignResult result = run_campaign(small(), (work_ / "g").string(), options);
  EXPECT_EQ(result.tally.finished(), 0u);
}

}  // namespace
}  // namespace slamkit::campaign
