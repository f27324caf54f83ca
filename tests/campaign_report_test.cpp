// The report over run folders (campaign/report.hpp): the t quantile of its confidence intervals, its
// numbers on hand-written metrics, how it groups runs into configurations and labels them, what it
// counts of runs that did not finish, the errors it names, and, on real runs of two seeds, the N-run
// NEES test and the files it writes.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <sstream>

#include "slamkit/campaign/report.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/run_folder.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"

namespace slamkit::campaign {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test_data::read_json;
using test_data::read_text;
using test_data::write_text;

TEST(CampaignReportTQuantile, MatchesTablesAndClosedForms) {
  // Tables of t(0.975, dof), as printed to three decimals.
  EXPECT_NEAR(student_t_quantile(0.975, 1), 12.706, 5e-4);
  EXPECT_NEAR(student_t_quantile(0.975, 4), 2.776, 5e-4);
  EXPECT_NEAR(student_t_quantile(0.975, 9), 2.262, 5e-4);
  EXPECT_NEAR(student_t_quantile(0.975, 29), 2.045, 5e-4);
  EXPECT_NEAR(student_t_quantile(0.975, 1000), 1.962, 5e-4);
  // Closed forms: Cauchy for one dof, t = (2p - 1) / sqrt(2p(1 - p)) for two.
  for (const double p : {0.6, 0.9, 0.975, 0.999, 1e-6}) {
    EXPECT_NEAR(student_t_quantile(p, 1), std::tan(std::numbers::pi * (p - 0.5)),
                1e-10 * std::abs(std::tan(std::numbers::pi * (p - 0.5))));
    const double two = (2 * p - 1) / std::sqrt(2 * p * (1 - p));
    EXPECT_NEAR(student_t_quantile(p, 2), two, 1e-10 * std::abs(two));
  }
  EXPECT_EQ(student_t_quantile(0.5, 7), 0.0);
  EXPECT_DOUBLE_EQ(student_t_quantile(0.025, 9), -student_t_quantile(0.975, 9));
  EXPECT_NEAR(student_t_quantile(0.975, 1e7), 1.959964, 1e-5);  // the normal's
  EXPECT_THROW(student_t_quantile(0.0, 3), std::invalid_argument);
  EXPECT_THROW(student_t_quantile(1.0, 3), std::invalid_argument);
  EXPECT_THROW(student_t_quantile(0.5, 0), std::invalid_argument);
  EXPECT_THROW(student_t_quantile(std::nan(""), 3), std::invalid_argument);
}

/// Fake run folders (run.json and metrics.json, which is all a report without the NEES test reads)
/// in a temporary folder of the test's own.
class CampaignReportFolders : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / fmt::format("slamkit_campaign_report_{}_{}", ::getpid(),
                                                    ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  /// A run of `filter` (settings with `seed` and `settings`) on a simulator log of seed `seed`.
  static json sim_run(const std::string& filter, int seed, const json& settings = json::object()) {
    json s = {{"filter", filter}, {"seed", seed}, {"ekf_variant", "full"}, {"association", {{"method", "known"}}}};
    s.update(settings);
    return {{"filter", filter},
            {"dataset", fmt::format("sim:/data/sim-{}", seed)},
            {"settings", s},
            {"dataset_settings_contents", nullptr},
            {"simulator", {{"format", "slamkit-sim"}, {"simulator", {{"seed", seed}, {"clutter_rate", 0}}}}},
            {"partial", false},
            {"diverged_at_s", nullptr}};
  }

  fs::path write_run(const std::string& name, const json& run, const json& metrics) const {
    const fs::path dir = root_ / name;
    fs::create_directories(dir);
    write_text(dir / "run.json", run.dump(2));
    write_text(dir / "metrics.json", metrics.dump(2));
    return dir;
  }

  static ReportOptions no_nees() {
    ReportOptions options;
    options.nees_test = false;
    return options;
  }

  static const MetricSummary& summary(const ReportConfiguration& config, const std::string& metric) {
    for (const MetricSummary& s : config.metrics)
      if (s.metric == metric) return s;
    throw std::invalid_argument("no summary of " + metric);
  }

  fs::path root_;
};

TEST_F(CampaignReportFolders, SummarisesEachMetricWithTheConfidenceIntervalOfItsMean) {
  const double ate[] = {1, 2, 3, 4, 10};
  for (int i = 0; i < 5; ++i) {
    json metrics = {{"ate_rmse_m", ate[i]}, {"map_rmse_m", i == 2 ? json(nullptr) : json(0.5 * i)}};
    if (i < 4) metrics["loop_closed"] = i != 1;
    write_run(fmt::format("runs/seed-{}", i + 1), sim_run("ekf", i + 1), metrics);
  }
  const Report report = collect_report({root_.string()}, no_nees());
  ASSERT_EQ(report.configurations.size(), 1u);
  const ReportConfiguration& config = report.configurations[0];
  EXPECT_EQ(config.label, "ekf");
  EXPECT_EQ(config.runs.size(), 5u);
  const MetricSummary& s = summary(config, "ate_rmse_m");
  EXPECT_EQ(s.n, 5u);
  EXPECT_DOUBLE_EQ(s.mean, 4.0);
  EXPECT_DOUBLE_EQ(s.median, 3.0);
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 10.0);
  // Sample standard deviation sqrt(50 / 4); t(0.975, 4) = 2.7764451051977987.
  const double half = 2.7764451051977987 * std::sqrt(50.0 / 4.0) / std::sqrt(5.0);
  ASSERT_TRUE(s.ci95.has_value());
  EXPECT_NEAR(s.ci95->lo, 4.0 - half, 1e-9);
  EXPECT_NEAR(s.ci95->hi, 4.0 + half, 1e-9);
  // A null value is not measured: four runs, 0, 0.5, 1.5, 2 (an even count's median is the mean of two).
  const MetricSummary& map = summary(config, "map_rmse_m");
  EXPECT_EQ(map.n, 4u);
  EXPECT_DOUBLE_EQ(map.median, 1.0);
  EXPECT_DOUBLE_EQ(map.mean, 1.0);
  const MetricSummary& loop = summary(config, "loop_closed");
  EXPECT_EQ(loop.yes, 3u);
  EXPECT_EQ(loop.yes_no, 4u);
  EXPECT_EQ(summary(config, "wall_time_s").n, 0u);
  EXPECT_FALSE(summary(config, "wall_time_s").ci95.has_value());
  EXPECT_EQ(config.nees.skipped, "not asked for");

  const std::vector<std::string> files = write_report(report, (root_ / "report").string());
  EXPECT_EQ(files.front(), (root_ / "report" / "report.md").string());
  const std::string csv = read_text(root_ / "report" / "summary.csv");
  const std::string row = "\nekf,ate_rmse_m,5,4,3,1,10,";
  const std::size_t at = csv.find(row);
  ASSERT_NE(at, std::string::npos) << csv;
  std::istringstream ci(csv.substr(at + row.size()));
  double lo = 0, hi = 0;
  char comma = 0;
  ci >> lo >> comma >> hi;
  EXPECT_NEAR(lo, 4.0 - half, 1e-12);
  EXPECT_NEAR(hi, 4.0 + half, 1e-12);
  EXPECT_NE(csv.find("\nekf,loop_closed,4,0.75,,,,,\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\nekf,wall_time_s,0,,,,,,\n"), std::string::npos) << csv;
  const std::string md = read_text(root_ / "report" / "report.md");
  EXPECT_NE(md.find("| ekf | 5 | 4 | 3 | 1 \u2013 10 | [-0.3899, 8.390] |"), std::string::npos) << md;
  EXPECT_NE(md.find("| ekf | 3 of 4 |"), std::string::npos) << md;
  // Metrics-only folders: no trajectories to draw, only the box plot.
  EXPECT_TRUE(fs::exists(root_ / "report" / "ate_boxplot.svg"));
  EXPECT_FALSE(fs::exists(root_ / "report" / "errors.svg"));
}

TEST_F(CampaignReportFolders, GroupsRunsThatDifferOnlyInTheirSeeds) {
  // Two EKF variants and FastSLAM (whose own seed follows the log's), three seeds each, in folders
  // whose numbers sort by value.
  for (const int seed : {2, 10, 1}) {
    write_run(fmt::format("full/seed-{}", seed), sim_run("ekf", seed), {{"ate_rmse_m", 0.1 * seed}});
    write_run(fmt::format("fej/seed-{}", seed), sim_run("ekf", seed, {{"ekf_variant", "fej"}}), {{"ate_rmse_m", 1}});
    write_run(fmt::format("zfastslam/seed-{}", seed), sim_run("fastslam2", seed), {{"ate_rmse_m", 1}});
  }
  const Report report = collect_report({root_.string()}, no_nees());
  ASSERT_EQ(report.configurations.size(), 3u);
  EXPECT_EQ(report.configurations[0].label, "ekf ekf_variant=fej");
  EXPECT_EQ(report.configurations[1].label, "ekf ekf_variant=full");
  EXPECT_EQ(report.configurations[2].label, "fastslam2");
  EXPECT_EQ(report.configurations[1].slug, "ekf-ekf_variant-full");
  for (const ReportConfiguration& config : report.configurations) EXPECT_EQ(config.runs.size(), 3u);
  std::vector<std::string> order;
  for (const std::size_t r : report.configurations[1].runs) order.push_back(fs::path(report.runs[r].dir).filename());
  EXPECT_EQ(order, (std::vector<std::string>{"seed-1", "seed-2", "seed-10"}));

  // A log simulated with other parameters is another dataset, and the labels say which.
  json cluttered = sim_run("ekf", 1);
  cluttered["simulator"]["simulator"]["clutter_rate"] = 2;
  write_run("cluttered/seed-1", cluttered, {{"ate_rmse_m", 1}});
  const Report two_datasets = collect_report({(root_ / "full").string(), (root_ / "cluttered").string()}, no_nees());
  ASSERT_EQ(two_datasets.configurations.size(), 2u);  // in folder order, wherever the paths were given
  EXPECT_EQ(two_datasets.configurations[0].label, "ekf | sim simulator.clutter_rate=2");
  EXPECT_EQ(two_datasets.configurations[1].label, "ekf | sim simulator.clutter_rate=0");

  // A folder given twice, and inside another one given, is one run.
  const Report once = collect_report({(root_ / "full").string(), (root_ / "full" / "seed-1").string()}, no_nees());
  EXPECT_EQ(once.runs.size(), 3u);
}

TEST_F(CampaignReportFolders, SimulatedSpecsGroupWithoutTheirLastSeed) {
  for (const int seed : {1, 2}) {
    json run = sim_run("ekf", seed);
    run.erase("simulator");
    run["dataset"] = fmt::format("family:sparse:7:{}", seed);
    write_run(fmt::format("family/{}", seed), run, {{"ate_rmse_m", 1}});
    run["dataset"] = fmt::format("scenario:default:{}", seed);
    write_run(fmt::format("scenario/{}", seed), run, {{"ate_rmse_m", 1}});
  }
  const Report report = collect_report({root_.string()}, no_nees());
  ASSERT_EQ(report.configurations.size(), 2u);
  EXPECT_EQ(report.configurations[0].label, "ekf | family:sparse:7");
  EXPECT_EQ(report.configurations[1].label, "ekf | scenario:default");
}

TEST_F(CampaignReportFolders, HonoursTheCampaignsConfiguration) {
  for (const int seed : {1, 2}) {
    json run = sim_run("ekf", seed, {{"ekf_variant", seed == 1 ? "fej" : "full"}});
    run["campaign"] = {{"campaign", "test"}, {"configuration", "fej | family:sparse"}, {"seed", seed}};
    write_run(fmt::format("campaign/{}", seed), run, {{"ate_rmse_m", 1}});
  }
  write_run("single", sim_run("ekf", 3), {{"ate_rmse_m", 1}});
  const Report report = collect_report({root_.string()}, no_nees());
  ASSERT_EQ(report.configurations.size(), 2u);
  EXPECT_EQ(report.configurations[0].label, "fej | family:sparse");
  EXPECT_EQ(report.configurations[0].runs.size(), 2u);
  EXPECT_EQ(report.configurations[1].label, "ekf");
}

TEST_F(CampaignReportFolders, CountsAndListsRunsThatDidNotFinish) {
  json partial = sim_run("ekf", 1), diverged = sim_run("ekf", 2);
  partial["partial"] = true;
  diverged["partial"] = true;
  diverged["diverged_at_s"] = 12.5;
  write_run("a", partial, {{"ate_rmse_m", 1}});
  write_run("b", diverged, {{"ate_rmse_m", nullptr}});
  write_run("c", sim_run("ekf", 3), {{"ate_rmse_m", 2}});
  const Report report = collect_report({root_.string()}, no_nees());
  ASSERT_EQ(report.configurations.size(), 1u);
  EXPECT_EQ(report.configurations[0].runs.size(), 3u);
  EXPECT_EQ(report.configurations[0].partial, 2u);
  EXPECT_EQ(report.configurations[0].diverged, 1u);
  EXPECT_EQ(report.configurations[0].metrics[0].n, 2u);
  write_report(report, (root_ / "report").string());
  const std::string md = read_text(root_ / "report" / "report.md");
  EXPECT_NE(md.find(fmt::format("- `{}` (ekf): diverged at t = 12.50 s", (root_ / "b").string())), std::string::npos)
      << md;
  EXPECT_NE(md.find(fmt::format("- `{}` (ekf): partial", (root_ / "a").string())), std::string::npos) << md;
  const std::string runs = read_text(root_ / "report" / "runs.csv");
  EXPECT_NE(runs.find(fmt::format("{},ekf,ekf,sim:/data/sim-2,true,12.5,,", (root_ / "b").string())), std::string::npos)
      << runs;
}

TEST_F(CampaignReportFolders, NamesAMissingPathAFolderWithoutRunsAndAMalformedFile) {
  const std::string missing = (root_ / "missing").string();
  test_data::input_error_at([&] { collect_report({missing}); }, missing, 0);
  fs::create_directories(root_ / "empty" / "sub");
  test_data::input_error_at([&] { collect_report({(root_ / "empty").string()}); }, (root_ / "empty").string(), 0);

  const fs::path dir = write_run("bad", sim_run("ekf", 1), json::object());
  write_text(dir / "metrics.json", "{\"ate_rmse_m\": 1,\n oops}");
  test_data::input_error_at([&] { collect_report({root_.string()}, no_nees()); }, (dir / "metrics.json").string(), 2);
  write_text(dir / "metrics.json", "[1, 2]");
  test_data::input_error_at([&] { collect_report({root_.string()}, no_nees()); }, (dir / "metrics.json").string(), 0);
  write_text(dir / "metrics.json", "{}");
  write_text(dir / "run.json", json{{"filter", "ekf"}}.dump());
  const std::string message =
      test_data::input_error_at([&] { collect_report({root_.string()}, no_nees()); }, (dir / "run.json").string(), 0);
  EXPECT_NE(message.find("'dataset'"), std::string::npos) << message;

  // An existing folder that is not a report is not replaced.
  write_text(dir / "run.json", sim_run("ekf", 1).dump());
  const Report report = collect_report({root_.string()}, no_nees());
  EXPECT_THROW(write_report(report, dir.string()), InputError);
  EXPECT_TRUE(fs::exists(dir / "run.json"));
}

TEST_F(CampaignReportFolders, TestsTheAveragedNeesOfRealRunsAndWritesEveryFile) {
  // Two seeds of one lap of the loop-closure world, run by the EKF as `slamkit run` would.
  for (const std::uint64_t seed : {1, 2}) {
    Scenario s = scenario("loop-closure");
    s.config.seed = seed;
    const std::string log = (root_ / fmt::format("sim-{}", seed)).string();
    write_sim_log(log, simulate(s.world, s.config), s.config, s.world);
    const Dataset data = load_dataset("sim:" + log);
    FilterConfig config;
    RunResult run = run_filter(*make_filter(config, data), data);
    run.provenance = {{"settings", to_json(config)}, {"dataset_settings_contents", nullptr}};
    add_dataset_provenance(run.provenance, data.spec, data);
    write_run_folder((root_ / "runs" / "ekf" / fmt::format("seed-{}", seed)).string(), run, data);
  }
  // The same runs as two configurations of their own: one whose folders keep their metrics only,
  // and one whose dataset has gone.
  for (const char* seed : {"seed-1", "seed-2"}) {
    const fs::path from = root_ / "runs" / "ekf" / seed;
    for (const char* copy : {"metrics-only", "moved"}) {
      const fs::path to = root_ / "runs" / copy / seed;
      fs::create_directories(to);
      json run = read_json(from / "run.json");
      run["campaign"] = {{"configuration", copy}};
      if (std::string(copy) == "moved") {
        fs::copy(from, to, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
        run["dataset"] = "sim:" + (root_ / "gone").string();
      } else {
        fs::copy(from / "metrics.json", to / "metrics.json");
      }
      write_text(to / "run.json", run.dump(2));
    }
  }
  const Report report = collect_report({(root_ / "runs").string()});
  ASSERT_EQ(report.configurations.size(), 3u);
  const ReportConfiguration& ekf = report.configurations[0];
  EXPECT_EQ(ekf.label, "ekf");
  const NeesTest& test = ekf.nees;
  ASSERT_EQ(test.skipped, "");
  EXPECT_EQ(test.runs, 2u);
  EXPECT_GT(test.steps, 100u);
  EXPECT_EQ(test.steps, test.averaged.size());
  EXPECT_TRUE(std::isfinite(test.mean));
  EXPECT_GT(test.mean, 0.0);
  EXPECT_GE(test.inside_fraction, 0.0);
  EXPECT_LE(test.inside_fraction, 1.0);
  const eval::Interval band = eval::averaged_nees_interval(0.95, 3, 2);
  EXPECT_EQ(test.band.lo, band.lo);
  EXPECT_EQ(test.band.hi, band.hi);
  // Averaged over the same steps, the mean of the average is the mean of the runs' own means.
  EXPECT_NEAR(test.mean, summary(ekf, "nees_pose_mean").mean, 1e-6 * test.mean);
  EXPECT_EQ(report.configurations[1].label, "metrics-only");
  EXPECT_NE(report.configurations[1].nees.skipped.find("keeps its metrics only"), std::string::npos);
  EXPECT_EQ(report.configurations[2].label, "moved");
  EXPECT_NE(report.configurations[2].nees.skipped.find("no longer loads"), std::string::npos)
      << report.configurations[2].nees.skipped;

  const fs::path out = root_ / "report";
  const std::vector<std::string> files = write_report(report, out.string());
  for (const char* name : {"report.md", "summary.csv", "runs.csv", "report.json", "ate_boxplot.svg", "errors.svg",
                           "trajectories.svg", "nees_ekf.svg"}) {
    EXPECT_TRUE(fs::exists(out / name)) << name;
    EXPECT_NE(std::find(files.begin(), files.end(), (out / name).string()), files.end()) << name;
  }
  EXPECT_EQ(files.size(), 8u);
  for (const char* svg : {"ate_boxplot.svg", "errors.svg", "trajectories.svg", "nees_ekf.svg"}) {
    const std::string text = read_text(out / svg);
    EXPECT_NE(text.find("<svg"), std::string::npos) << svg;
    EXPECT_NE(text.find("</svg>"), std::string::npos) << svg;
  }
  const json contents = read_json(out / "report.json");
  EXPECT_EQ(contents.at("runs").size(), 6u);
  EXPECT_EQ(contents.at("configurations")[0].at("nees_test").at("runs"), 2);
  EXPECT_EQ(contents.at("configurations")[2].at("nees_test").count("skipped"), 1u);
  // Every CSV row has the header's columns.
  for (const char* csv : {"summary.csv", "runs.csv"}) {
    std::istringstream lines(read_text(out / csv));
    std::string line;
    std::getline(lines, line);
    const auto columns = std::count(line.begin(), line.end(), ',');
    std::size_t rows = 0;
    while (std::getline(lines, line)) {
      EXPECT_EQ(std::count(line.begin(), line.end(), ','), columns) << csv << ": " << line;
      ++rows;
    }
    EXPECT_EQ(rows, std::string(csv) == "runs.csv" ? 6u : 3u * report.metrics.size()) << csv;
  }

  // Writing again replaces the report as a whole.
  write_report(report, out.string());
  EXPECT_TRUE(fs::exists(out / "report.md"));
}

}  // namespace
}  // namespace slamkit::campaign
