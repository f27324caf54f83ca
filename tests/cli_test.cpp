// The slamkit command line, end to end: the demo pipeline, its outputs, and how it fails on bad input
// (one line on stderr naming the file, the line and what was expected; a non-zero exit code).
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

namespace fs = std::filesystem;

namespace {

struct Result {
  int exit_code = -1;
  std::string out;
  std::string err;
};

/// Runs the slamkit binary with `args` (shell-quoted by the caller), capturing stdout and stderr; in
/// the folder `cwd` if given.
Result slamkit(const std::string& args, const fs::path& work, const fs::path& cwd = {}) {
  const fs::path err_file = work / "stderr.txt";
  const std::string command = (cwd.empty() ? "" : "cd " + cwd.string() + " && ") + std::string(SLAMKIT_CLI) + " " +
                              args + " 2>" + err_file.string();
  Result r;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe) != nullptr) r.out += buffer.data();
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err_file);
  std::stringstream ss;
  ss << in.rdbuf();
  r.err = ss.str();
  return r;
}

std::size_t count_lines(const std::string& s) { return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n')); }

/// Replaces line `n` (1-based) of a file.
void replace_line(const fs::path& file, std::size_t n, const std::string& text) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  in.close();
  lines.at(n - 1) = text;
  std::ofstream out(file);
  for (const auto& line : lines) out << line << "\n";
}

class Cli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    work_ = new fs::path(fs::temp_directory_path() / ("slamkit_cli_test_" + std::to_string(getpid())));
    fs::remove_all(*work_);
    fs::create_directories(*work_);
    const Result sim = slamkit("simulate --seed 3 --out " + (*work_ / "sim").string(), *work_);
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
  }
  static void TearDownTestSuite() {
    fs::remove_all(*work_);
    delete work_;
  }
  /// A private copy of the simulated log to damage.
  fs::path copy_of_log(const std::string& name) const {
    const fs::path dir = *work_ / name;
    fs::remove_all(dir);
    fs::copy(*work_ / "sim", dir, fs::copy_options::recursive);
    return dir;
  }
  static fs::path* work_;
};
fs::path* Cli::work_ = nullptr;

}  // namespace

TEST_F(Cli, RunWritesResultsAndSlamBeatsDeadReckoning) {
  const fs::path out = *work_ / "ekf";
  const Result r = slamkit("run --filter ekf --data sim:" + (*work_ / "sim").string() + " --out " + out.string(), *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("ATE RMSE"), std::string::npos);
  for (const char* f : {"trajectory.tum", "pose_covariance.txt", "dead_reckoning.tum", "map.txt",
                        "landmark_std.txt", "run.json", "metrics.json", "map.svg", "landmark_std.svg"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  std::ifstream in(out / "metrics.json");
  const auto m = nlohmann::json::parse(in);
  for (const char* key : {"filter", "dataset", "steps", "observations", "landmarks", "wall_time_s", "ate_rmse_m",
                          "final_position_error_m", "map_rmse_m", "nees_pose_mean", "nees_pose_in_95_fraction"})
    EXPECT_TRUE(m.contains(key)) << key;
  EXPECT_EQ(m["filter"], "ekf");
  EXPECT_EQ(m["landmarks"], 100);
  EXPECT_LT(m["ate_rmse_m"].get<double>(), 0.25 * m["dead_reckoning_ate_rmse_m"].get<double>());
  EXPECT_LT(m["map_rmse_m"].get<double>(), 0.5);

  // evaluate recomputes the same numbers from the files alone.
  const Result e = slamkit("evaluate " + out.string(), *work_);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  std::ifstream in2(out / "metrics.json");
  const auto m2 = nlohmann::json::parse(in2);
  EXPECT_NEAR(m2["ate_rmse_m"].get<double>(), m["ate_rmse_m"].get<double>(), 1e-9);
  EXPECT_NEAR(m2["map_rmse_m"].get<double>(), m["map_rmse_m"].get<double>(), 1e-9);
  EXPECT_NEAR(m2["nees_pose_mean"].get<double>(), m["nees_pose_mean"].get<double>(), 1e-6);
}

// The UKF and the consistent EKF variants (the invariant one iterated too) run from the command
// line like the EKF, each leaving nees.svg; plot-nees draws their NEES averaged over runs.
TEST_F(Cli, UkfAndConsistentVariantsRunAndPlotNees) {
  const std::string data = " --data sim:" + (*work_ / "sim").string();
  std::string dirs;
  int run = 0;
  for (const char* filter : {"--filter ukf", "--filter ekf --ekf-variant fej", "--filter ekf --ekf-variant invariant",
                             "--filter ekf --ekf-variant invariant --ekf-update iterated"}) {
    const fs::path out = *work_ / ("consistent-" + std::to_string(++run));
    const Result r = slamkit("run " + std::string(filter) + data + " --out " + out.string(), *work_);
    ASSERT_EQ(r.exit_code, 0) << filter << ": " << r.err;
    EXPECT_TRUE(fs::exists(out / "nees.svg")) << filter;
    std::ifstream in(out / "metrics.json");
    const auto m = nlohmann::json::parse(in);
    EXPECT_EQ(m["filter"], std::string(filter).find("ukf") != std::string::npos ? "ukf" : "ekf");
    EXPECT_LT(m["ate_rmse_m"].get<double>(), 0.25 * m["dead_reckoning_ate_rmse_m"].get<double>()) << filter;
    dirs += " " + out.string();
  }
  const fs::path svg = *work_ / "nees_mc.svg";
  const Result p = slamkit("plot-nees" + dirs + " --out " + svg.string(), *work_);
  ASSERT_EQ(p.exit_code, 0) << p.err;
  std::ifstream in(svg);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("95% interval of the 4-run mean"), std::string::npos);
}

TEST_F(Cli, SameSeedSameLog) {
  const Result a = slamkit("simulate --seed 3 --out " + (*work_ / "again").string(), *work_);
  ASSERT_EQ(a.exit_code, 0);
  std::ifstream x(*work_ / "sim" / "events.txt"), y(*work_ / "again" / "events.txt");
  std::stringstream sx, sy;
  sx << x.rdbuf();
  sy << y.rdbuf();
  EXPECT_EQ(sx.str(), sy.str());
}

TEST_F(Cli, EveryCommandHasHelp) {
  for (const char* cmd : {"", "simulate", "make-world", "run", "evaluate"}) {
    const Result r = slamkit(std::string(cmd) + " --help", *work_);
    EXPECT_EQ(r.exit_code, 0) << cmd;
    EXPECT_NE(r.out.find("--help"), std::string::npos) << cmd;
  }
}

TEST_F(Cli, MissingDatasetIsOneLineError) {
  const Result r = slamkit("run --filter ekf --data sim:/nonexistent/log --out " + (*work_ / "x").string(), *work_);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(count_lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("/nonexistent/log"), std::string::npos) << r.err;
}

TEST_F(Cli, MalformedLineNamesFileAndLine) {
  const fs::path log = copy_of_log("malformed");
  replace_line(log / "events.txt", 40, "control 1.0 oops");
  const Result r = slamkit("run --filter ekf --data sim:" + log.string() + " --out " + (*work_ / "y").string(), *work_);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(count_lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("events.txt:40:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("expected"), std::string::npos) << r.err;
}

TEST_F(Cli, NanValueIsRejected) {
  const fs::path log = copy_of_log("nan");
  std::ifstream in(log / "events.txt");
  std::size_t n = 0, target = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    if (target == 0 && line.rfind("obs ", 0) == 0) target = n;
  }
  in.close();
  replace_line(log / "events.txt", target, "obs 0.2 5 nan 0.1");
  const Result r = slamkit("run --filter ekf --data sim:" + log.string() + " --out " + (*work_ / "z").string(), *work_);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(count_lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("events.txt:" + std::to_string(target) + ":"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("finite"), std::string::npos) << r.err;
}

TEST_F(Cli, UnknownOptionFilterAndDatasetKind) {
  const Result opt = slamkit("run --data sim:" + (*work_ / "sim").string() + " --out " + (*work_ / "w").string() +
                                 " --bogus 1",
                             *work_);
  EXPECT_EQ(opt.exit_code, 2);
  EXPECT_EQ(count_lines(opt.err), 1u) << opt.err;
  EXPECT_NE(opt.err.find("--bogus"), std::string::npos) << opt.err;
  EXPECT_NE(opt.err.find("slamkit run --help"), std::string::npos) << opt.err;
  const Result missing = slamkit("run --filter ekf", *work_);
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("--data is required"), std::string::npos) << missing.err;

  const Result filter = slamkit("run --filter nope --data sim:" + (*work_ / "sim").string() + " --out " +
                                    (*work_ / "w").string(), *work_);
  EXPECT_EQ(filter.exit_code, 2);
  EXPECT_NE(filter.err.find("unknown filter 'nope'"), std::string::npos) << filter.err;

  const Result kind = slamkit("run --data tape:/x --out " + (*work_ / "w").string(), *work_);
  EXPECT_NE(kind.exit_code, 0);
  EXPECT_NE(kind.err.find("unknown dataset kind 'tape'"), std::string::npos) << kind.err;

  const Result no_cmd = slamkit("", *work_);
  EXPECT_EQ(no_cmd.exit_code, 2);
}

TEST_F(Cli, EvaluateRejectsAFolderThatIsNotARun) {
  const Result r = slamkit("evaluate " + (*work_ / "sim").string(), *work_);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(count_lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("run.json"), std::string::npos) << r.err;
}

TEST_F(Cli, MakeWorldThenSimulateIt) {
  const fs::path world = *work_ / "big.world";
  const Result w = slamkit("make-world --landmarks 400 --width 300 --height 200 --out " + world.string(), *work_);
  ASSERT_EQ(w.exit_code, 0) << w.err;
  const Result s = slamkit("simulate --loops 1 --world " + world.string() + " --out " + (*work_ / "big").string(), *work_);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_NE(s.out.find("400 landmarks"), std::string::npos) << s.out;
}

TEST_F(Cli, UnknownAssociationOnALogWithoutIds) {
  const fs::path log = *work_ / "noids";
  const Result s = slamkit("simulate --scenario cluttered --out " + log.string(), *work_);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const Result known = slamkit("run --data sim:" + log.string() + " --out " + (*work_ / "k").string(), *work_);
  EXPECT_NE(known.exit_code, 0);
  EXPECT_EQ(count_lines(known.err), 1u) << known.err;
  EXPECT_NE(known.err.find("--assoc nn"), std::string::npos) << known.err;

  const fs::path out = *work_ / "jcbb";
  const Result r = slamkit("run --assoc jcbb --data sim:" + log.string() + " --out " + out.string(), *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(out / "metrics.json");
  const auto m = nlohmann::json::parse(in);
  EXPECT_EQ(m["association"], "jcbb");
  for (const char* key : {"association_correct", "association_wrong", "association_missed", "spurious_landmarks",
                          "landmarks_true_seen", "clutter_observations", "landmarks_removed"})
    EXPECT_TRUE(m.contains(key)) << key;
  EXPECT_EQ(m["landmarks_true_seen"], 100);
  EXPECT_TRUE(fs::exists(out / "associations.txt"));

  const Result e = slamkit("evaluate " + out.string(), *work_);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  std::ifstream in2(out / "metrics.json");
  const auto m2 = nlohmann::json::parse(in2);
  EXPECT_EQ(m2["association_correct"], m["association_correct"]);
  EXPECT_EQ(m2["spurious_landmarks"], m["spurious_landmarks"]);

  const Result bad = slamkit("run --assoc fuzzy --data sim:" + log.string() + " --out " + out.string(), *work_);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("unknown association 'fuzzy'"), std::string::npos) << bad.err;
}

TEST_F(Cli, FastSlamRunWritesParticlesAndItsStatistics) {
  const fs::path out = *work_ / "fastslam2";
  const Result r = slamkit("run --filter fastslam2 --particles 20 --resample residual --resample-when every:5 --data sim:" +
                               (*work_ / "sim").string() + " --out " + out.string(),
                           *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* f : {"trajectory.tum", "filtered.tum", "particles.txt", "map.svg"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  std::ifstream in(out / "metrics.json");
  const auto m = nlohmann::json::parse(in);
  EXPECT_EQ(m["filter"], "fastslam2");
  EXPECT_EQ(m["particles"], 20);
  EXPECT_TRUE(m.contains("ess_mean"));
  EXPECT_TRUE(m.contains("resamples"));
  EXPECT_LT(m["ate_rmse_m"].get<double>(), 0.5 * m["dead_reckoning_ate_rmse_m"].get<double>());
  const Result e = slamkit("evaluate " + out.string(), *work_);
  ASSERT_EQ(e.exit_code, 0) << e.err;

  const Result bad = slamkit("run --filter fastslam1 --resample-when sometimes --data sim:" + (*work_ / "sim").string() +
                                 " --out " + out.string(),
                             *work_);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(count_lines(bad.err), 1u) << bad.err;
  EXPECT_NE(bad.err.find("sometimes"), std::string::npos) << bad.err;
}

TEST_F(Cli, RunsTheShippedCourseExample) {
  const fs::path out = *work_ / "course";
  const Result r = slamkit("run --data course:" + (fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course").string() +
                               " --out " + out.string(),
                           *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(out / "metrics.json");
  const auto m = nlohmann::json::parse(in);
  EXPECT_EQ(m["landmarks"], 8);
  EXPECT_EQ(m["map_landmarks_paired"], 8);
  EXPECT_LT(m["map_rmse_m"].get<double>(), 0.5);
}

TEST_F(Cli, DatasetSettingsFileIsUsedAndChecked) {
  const fs::path course = fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course";
  const fs::path shipped = fs::path(SLAMKIT_SOURCE_DIR) / "config" / "course.json";
  const fs::path out = *work_ / "course-settings";
  const Result r = slamkit("run --data course:" + course.string() + " --data-config " + shipped.string() + " --out " +
                               out.string(),
                           *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(out / "run.json");
  EXPECT_EQ(nlohmann::json::parse(in)["dataset_settings"], shipped.string());

  const fs::path bad = *work_ / "bad-settings.json";
  std::ofstream(bad) << "{\"sigma_range_m\": 0.2, \"bogus\": 1}\n";
  const Result b = slamkit("run --data course:" + course.string() + " --data-config " + bad.string() + " --out " +
                               out.string(),
                           *work_);
  EXPECT_NE(b.exit_code, 0);
  EXPECT_EQ(count_lines(b.err), 1u) << b.err;
  EXPECT_NE(b.err.find("unknown key 'bogus'"), std::string::npos) << b.err;
}

// The shipped course with every noise a hundredth of the shipped one: the filter believes itself far
// more precise than it is, its known-identity gate rejects nearly every observation, and the run says
// that it lost itself (and why) instead of reporting odometry as SLAM.
TEST_F(Cli, ARunWhoseGateRejectsMostIdentifiedObservationsWarns) {
  const fs::path course = fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course";
  std::ifstream shipped(fs::path(SLAMKIT_SOURCE_DIR) / "config" / "course.json");
  nlohmann::json settings = nlohmann::json::parse(shipped);
  for (auto& [key, value] : settings.items())
    if (key.starts_with("sigma_") || key.starts_with("alpha_")) value = value.get<double>() / 100.0;
  const fs::path tight = *work_ / "course-overconfident.json";
  std::ofstream(tight) << settings.dump();
  const fs::path out = *work_ / "course-lost";
  const Result lost = slamkit("run --data course:" + course.string() + " --data-config " + tight.string() +
                                  " --out " + out.string() + " --quiet",
                              *work_);
  ASSERT_EQ(lost.exit_code, 0) << lost.err;
  EXPECT_EQ(count_lines(lost.err), 1u) << lost.err;
  EXPECT_NE(lost.err.find("warning: the filter lost itself"), std::string::npos) << lost.err;
  std::ifstream in(out / "metrics.json");
  const nlohmann::json metrics = nlohmann::json::parse(in);
  EXPECT_GT(metrics["known_id_rejected_fraction"].get<double>(), 0.5);
  EXPECT_TRUE(metrics.contains("known_id_lost_at_s"));
  EXPECT_TRUE(metrics.contains("known_id_rejected_fraction_tenth_10"));

  const Result fine = slamkit("run --data course:" + course.string() + " --out " + (*work_ / "course-fine").string() +
                                  " --quiet",
                              *work_);
  ASSERT_EQ(fine.exit_code, 0) << fine.err;
  EXPECT_EQ(fine.err, "");
}

TEST_F(Cli, CalibrateWritesMrclamSettingsThatRunReads) {
  // Where test_data::shared_dataset looks (its header's namespace would hide this file's slamkit()).
  const char* data = std::getenv("SLAMKIT_DATA");
  const fs::path dataset = (data != nullptr && *data != '\0' ? fs::path(data)
                                                              : fs::path(SLAMKIT_SOURCE_DIR) / ".." / "shared" / "datasets") /
                           "mrclam" / "MRCLAM_Dataset6";
  if (!fs::exists(dataset)) GTEST_SKIP() << "dataset not found at " << dataset.string();
  const fs::path settings = *work_ / "calibrated.json", report = *work_ / "calibration-report.json";
  const std::string robot4 = "mrclam:" + dataset.string() + ":robot4";
  const Result c =
      slamkit("calibrate --data " + robot4 + " --out " + settings.string() + " --report " + report.string(), *work_);
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_NE(c.out.find("command delay"), std::string::npos) << c.out;
  std::ifstream in(settings);
  const nlohmann::json written = nlohmann::json::parse(in);
  // Read with the shipped delay, robot 4 needs about as much more (0.22 s alone).
  EXPECT_NEAR(written["command_delay_s"].get<double>(), 0.22, 0.03);
  EXPECT_GT(written["sigma_range_m"].get<double>(), 0.2);
  EXPECT_EQ(written["fov_deg"], 70.0);  // kept from the settings the log was read with
  std::ifstream report_in(report);
  EXPECT_EQ(nlohmann::json::parse(report_in)["motion_by_horizon"].size(), 7u);
  const Result run = slamkit("run --data " + robot4 + " --data-config " + settings.string() + " --out " +
                                 (*work_ / "calibrated-run").string() + " --quiet",
                             *work_);
  EXPECT_EQ(run.exit_code, 0) << run.err;

  const Result wrong = slamkit("calibrate --data sim:" + (*work_ / "sim").string() + " --out " + settings.string(), *work_);
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_NE(wrong.err.find("expected --data mrclam:DIR:robotN"), std::string::npos) << wrong.err;
}

TEST_F(Cli, FilterSettingsAreUsageErrorsBeforeAnyDataIsRead) {
  // The dataset does not exist: an error about the settings shows they were checked first.
  const std::string rest = " --data sim:/nonexistent/log --out " + (*work_ / "never").string();
  const struct {
    const char* options;
    const char* message;
  } cases[] = {
      {"--filter ekff", "--filter: unknown filter 'ekff'; expected one of: ekf, ukf, fastslam1, fastslam2"},
      {"--filter ukf --ekf-variant fej", "EKF variant 'fej' applies to the filter 'ekf', not 'ukf'"},
      {"--assoc nearest", "--assoc: unknown association 'nearest'; expected one of: known, nn, jcbb"},
      {"--ekf-variant sparse", "--ekf-variant: unknown EKF variant 'sparse'; expected one of: full, compressed, fej, invariant"},
      {"--ekf-update both", "--ekf-update: unknown EKF update 'both'; expected one of: joint, sequential, iterated"},
      {"--filter ukf --ukf-noise both", "--ukf-noise: unknown UKF noise 'both'; expected one of: augmented, additive"},
      {"--resample best", "--resample: unknown resampling method 'best'; expected one of: multinomial"},
      {"--resample-when sometimes", "--resample-when: unknown resampling policy 'sometimes'; expected always"},
      {"--resample-when every:0", "K must be an integer >= 1"},
      {"--resample-when ess:2", "F must be a number in (0, 1]"},
      {"--particles 0", "--particles: expected an integer >= 1, found 0"},
      {"--particles 2.5", "--particles: expected an integer >= 1, found 2.5"},
      {"--pose-sample-fraction 0", "pose_sample_fraction must lie in (0, 1], found 0"},
      {"--threads -1", "--threads: expected an integer >= 0, found -1"},
      {"--seed -1", "--seed: expected an integer >= 0, found -1"},
      {"--accept-probability 1.5", "association setting accept_probability must be in (0, 1), found 1.5"},
      {"--new-landmark-probability 0.5", "new_landmark_probability must be in [accept_probability, 1) = [0.99, 1)"},
      {"--gate-known maybe", "--gate-known"},
      {"--confirm-after 0", "--confirm-after: expected an integer >= 1, found 0"},
      {"--confirmed-max-misses -1", "--confirmed-max-misses: expected an integer >= 0, found -1"},
  };
  for (const auto& c : cases) {
    const Result r = slamkit("run " + std::string(c.options) + rest, *work_);
    EXPECT_EQ(r.exit_code, 2) << c.options << ": " << r.err;
    EXPECT_EQ(count_lines(r.err), 1u) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("slamkit run --help"), std::string::npos) << r.err;
  }
  // With valid settings the same command fails on the data instead.
  const Result data = slamkit("run --filter fastslam1 --particles 5" + rest, *work_);
  EXPECT_EQ(data.exit_code, 1) << data.err;
  EXPECT_NE(data.err.find("/nonexistent/log"), std::string::npos) << data.err;
}

TEST_F(Cli, NumericRangesAreStatedInWords) {
  const struct {
    const char* command;
    const char* message;
  } cases[] = {
      {"simulate --loops 0 --out x", "--loops: expected an integer >= 1, found 0"},
      {"simulate --clutter -1 --out x", "--clutter: expected >= 0, found -1"},
      {"simulate --detection-prob 2 --out x", "--detection-prob: expected in [0, 1], found 2"},
      {"make-world --width 0 --out x", "--width: expected > 0, found 0"},
      {"make-world --landmarks 0 --out x", "--landmarks: expected an integer >= 1, found 0"},
  };
  for (const auto& c : cases) {
    const Result r = slamkit(c.command, *work_);
    EXPECT_EQ(r.exit_code, 2) << c.command << ": " << r.err;
    EXPECT_EQ(count_lines(r.err), 1u) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    EXPECT_LT(r.err.size(), 120u) << r.err;
  }
}

TEST_F(Cli, CompressedEkfTakesJointAndSequentialUpdates) {
  // The compressed EKF updates a scan jointly too (it used to warn that it ignored the setting).
  const std::string data = " --data sim:" + (*work_ / "sim").string() + " --out " + (*work_ / "compressed").string();
  for (const char* update : {"joint", "sequential"}) {
    const Result run = slamkit(std::string("run --ekf-variant compressed --ekf-update ") + update + data, *work_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(run.err, "") << update;
  }
}

TEST_F(Cli, SettingsFilesWithANumberBeyondADoubleNameTheFileAndLine) {
  const fs::path config = *work_ / "huge.json";
  std::ofstream(config) << "{\n  \"speed_mps\": 2,\n  \"wheelbase_m\": 1e400\n}\n";
  const Result sim = slamkit("simulate --config " + config.string() + " --out " + (*work_ / "huge").string(), *work_);
  EXPECT_EQ(sim.exit_code, 1);
  EXPECT_EQ(count_lines(sim.err), 1u) << sim.err;
  EXPECT_NE(sim.err.find(config.string() + ":3: "), std::string::npos) << sim.err;
  EXPECT_NE(sim.err.find("1e400"), std::string::npos) << sim.err;

  const fs::path settings = *work_ / "huge-course.json";
  std::ofstream(settings) << "{\"max_range_m\": -1e400}\n";
  const Result run = slamkit("run --data course:" + (fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course").string() +
                                 " --data-config " + settings.string() + " --out " + (*work_ / "never").string(),
                             *work_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(count_lines(run.err), 1u) << run.err;
  EXPECT_NE(run.err.find(settings.string() + ":1: "), std::string::npos) << run.err;
}

std::string read_file(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

nlohmann::json read_json(const fs::path& file) { return nlohmann::json::parse(read_file(file)); }

TEST_F(Cli, RunJsonRepeatsTheRunBitForBitFromAnotherFolder) {
  // A run given relative paths and a settings file, then repeated from elsewhere after the settings
  // file is gone: run.json alone (absolute data path, the settings' contents, every filter setting)
  // must give the same estimate and the same metrics.
  const fs::path first = *work_ / "repeat" / "first", second = *work_ / "repeat" / "second";
  fs::create_directories(first);
  fs::create_directories(second);
  fs::copy(fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course", first / "course", fs::copy_options::recursive);
  std::ofstream(first / "settings.json") << read_file(fs::path(SLAMKIT_SOURCE_DIR) / "config" / "course.json");
  const Result run = slamkit("run --filter fastslam2 --particles 15 --seed 5 --assoc nn --resample-when every:2 "
                             "--pose-sample-fraction 0.5 --data course:course --data-config settings.json --out r --quiet",
                             *work_, first);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, "");  // --quiet
  fs::remove(first / "settings.json");

  const nlohmann::json info = read_json(first / "r" / "run.json");
  EXPECT_EQ(info.at("dataset"), "course:" + fs::weakly_canonical(first / "course").string());
  EXPECT_EQ(info.at("dataset_settings"), fs::weakly_canonical(first / "settings.json").string());
  EXPECT_TRUE(info.at("dataset_settings_contents").is_object());
  EXPECT_EQ(info.at("settings").at("particles"), 15);
  EXPECT_EQ(info.at("settings").at("seed"), 5);
  EXPECT_EQ(info.at("settings").at("resample_when"), "every:2");
  EXPECT_EQ(info.at("settings").at("pose_sample_fraction"), 0.5);
  EXPECT_EQ(info.at("settings").at("association").at("method"), "nn");
  EXPECT_EQ(info.at("partial"), false);
  EXPECT_FALSE(info.at("slamkit_version").get<std::string>().empty());
  EXPECT_EQ(info.at("command_line").at(1), "run");

  const Result repeat = slamkit("run --config " + (first / "r" / "run.json").string() + " --out r", *work_, second);
  ASSERT_EQ(repeat.exit_code, 0) << repeat.err;
  EXPECT_EQ(read_file(first / "r" / "trajectory.tum"), read_file(second / "r" / "trajectory.tum"));
  EXPECT_EQ(read_file(first / "r" / "map.txt"), read_file(second / "r" / "map.txt"));
  nlohmann::json a = read_json(first / "r" / "metrics.json"), b = read_json(second / "r" / "metrics.json");
  a.erase("wall_time_s");
  b.erase("wall_time_s");
  EXPECT_EQ(a, b);
  EXPECT_EQ(read_json(second / "r" / "run.json").at("settings"), info.at("settings"));

  // The folder evaluates from anywhere, and settings cannot be mixed into a repeat.
  const Result evaluate = slamkit("evaluate " + (first / "r").string(), *work_, second);
  EXPECT_EQ(evaluate.exit_code, 0) << evaluate.err;
  const Result mixed =
      slamkit("run --config " + (first / "r" / "run.json").string() + " --particles 3 --out r", *work_, second);
  EXPECT_EQ(mixed.exit_code, 2) << mixed.err;
}

TEST_F(Cli, PrintConfigShowsEveryEffectiveSettingWithoutRunning) {
  const Result r = slamkit("run --filter fastslam1 --particles 7 --data sim:" + (*work_ / "sim").string() +
                               " --print-config",
                           *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json config = nlohmann::json::parse(r.out);
  EXPECT_EQ(config.at("settings").at("filter"), "fastslam1");
  EXPECT_EQ(config.at("settings").at("particles"), 7);
  EXPECT_EQ(config.at("settings").at("resample"), "systematic");
  EXPECT_TRUE(config.at("settings").at("association").contains("accept_probability"));
  EXPECT_EQ(config.at("dataset"), "sim:" + fs::weakly_canonical(*work_ / "sim").string());

  const Result ukf = slamkit("run --filter ukf --ukf-noise additive --data sim:" + (*work_ / "sim").string() +
                                 " --print-config",
                             *work_);
  ASSERT_EQ(ukf.exit_code, 0) << ukf.err;
  EXPECT_EQ(nlohmann::json::parse(ukf.out).at("settings").at("ukf_noise"), "additive");
}

// The association file sets what it names, the flags override it, and run.json records the result.
TEST_F(Cli, AssociationSettingsComeFromAFileAndFlagsOverrideIt) {
  const fs::path file = *work_ / "association.json";
  std::ofstream(file) << R"({"method": "jcbb", "accept_probability": 0.95, "confirm_after": 5, "gate_known": false})";
  const std::string data = " --data sim:" + (*work_ / "sim").string();
  const Result printed = slamkit("run --assoc-config " + file.string() + " --confirm-after 4 --gate-known on" + data +
                                     " --print-config",
                                 *work_);
  ASSERT_EQ(printed.exit_code, 0) << printed.err;
  const nlohmann::json association = nlohmann::json::parse(printed.out).at("settings").at("association");
  EXPECT_EQ(association.at("method"), "jcbb");
  EXPECT_EQ(association.at("accept_probability"), 0.95);
  EXPECT_EQ(association.at("confirm_after"), 4);
  EXPECT_EQ(association.at("gate_known"), true);
  EXPECT_EQ(association.at("provisional_max_misses"), 3);  // not named anywhere: the default

  const fs::path out = *work_ / "assoc_flags_run";
  const Result run = slamkit("run --assoc-config " + file.string() + " --assoc nn --new-landmark-probability 0.999" +
                                 data + " --out " + out.string(),
                             *work_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::ifstream run_json(out / "run.json");
  const nlohmann::json recorded = nlohmann::json::parse(run_json).at("settings").at("association");
  EXPECT_EQ(recorded.at("method"), "nn");
  EXPECT_EQ(recorded.at("new_landmark_probability"), 0.999);
  EXPECT_EQ(recorded.at("confirm_after"), 5);

  // The shipped settings for cluttered worlds load, and the clutter term's flags override them.
  const fs::path cluttered = fs::path(SLAMKIT_SOURCE_DIR) / "config" / "association-cluttered.json";
  const Result clutter = slamkit("run --assoc-config " + cluttered.string() + " --clutter-per-scan 2" + data +
                                     " --print-config",
                                 *work_);
  ASSERT_EQ(clutter.exit_code, 0) << clutter.err;
  const nlohmann::json clutter_settings = nlohmann::json::parse(clutter.out).at("settings").at("association");
  EXPECT_EQ(clutter_settings.at("min_pairing_probability"), 0.9);
  EXPECT_EQ(clutter_settings.at("clutter_per_scan"), 2.0);
  EXPECT_EQ(slamkit("run --min-pairing-probability 1" + data + " --out " + (*work_ / "never").string(), *work_).exit_code,
            2);

  // A wrong file is bad input naming it, before any data is read; a repeated run takes none of these.
  std::ofstream(*work_ / "bad_association.json") << R"({"confirm_afterr": 5})";
  const Result bad = slamkit("run --assoc-config " + (*work_ / "bad_association.json").string() +
                                 " --data sim:/nonexistent/log --out " + (*work_ / "never").string(),
                             *work_);
  EXPECT_EQ(bad.exit_code, 1) << bad.err;
  EXPECT_NE(bad.err.find("bad_association.json"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("confirm_afterr"), std::string::npos) << bad.err;
  const Result repeat = slamkit("run --config " + (out / "run.json").string() + " --confirm-after 2 --out " +
                                    (*work_ / "never").string(),
                                *work_);
  EXPECT_EQ(repeat.exit_code, 2) << repeat.err;
}

TEST_F(Cli, VersionUnknownSubcommandAndIgnoredOptions) {
  const Result version = slamkit("--version", *work_);
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_NE(version.out.find('.'), std::string::npos) << version.out;

  const Result typo = slamkit("rnu --filter ekf", *work_);
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_EQ(count_lines(typo.err), 1u) << typo.err;
  EXPECT_NE(typo.err.find("unknown subcommand 'rnu'; expected one of: simulate, make-world, run"), std::string::npos)
      << typo.err;

  const fs::path out = *work_ / "ignored";
  const Result ekf = slamkit("run --filter ekf --particles 50 --data sim:" + (*work_ / "sim").string() + " --out " +
                                 out.string(),
                             *work_);
  ASSERT_EQ(ekf.exit_code, 0) << ekf.err;
  EXPECT_NE(ekf.err.find("warning: --particles is ignored by the EKF"), std::string::npos) << ekf.err;
  // The truth beside the estimate, in the same format and time base.
  EXPECT_TRUE(fs::exists(out / "truth.tum"));
  EXPECT_TRUE(fs::exists(out / "pose_error.svg"));
  EXPECT_EQ(count_lines(read_file(out / "truth.tum")) > 100, true);
}

TEST_F(Cli, ReplayPageIsSelfContainedAndRewrittenFromItsRecording) {
  const fs::path out = *work_ / "replay";
  const Result run = slamkit("run --data sim:" + (*work_ / "sim").string() + " --out " + out.string() + " --replay",
                             *work_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string page = read_file(out / "replay.html");
  // One file: the script and style inline, nothing fetched.
  EXPECT_EQ(page.find("<script src"), std::string::npos);
  EXPECT_EQ(page.find("<link"), std::string::npos);
  EXPECT_EQ(page.find("http://"), std::string::npos);
  EXPECT_EQ(page.find("https://"), std::string::npos);
  EXPECT_NE(page.find("window.replay"), std::string::npos);
  const nlohmann::json recording = read_json(out / "replay.json");
  EXPECT_GT(recording.at("frames").size(), 100u);
  EXPECT_LE(recording.at("frames").size(), 601u);

  fs::remove(out / "replay.html");
  const Result again = slamkit("replay " + out.string(), *work_);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(read_file(out / "replay.html"), page);
}

// --history none keeps the run folder to the start and the final estimate, which evaluate reads back
// and scores; --replay needs every scan, so it is a usage error with another history.
TEST_F(Cli, HistoryNoneWritesTheFinalEstimateAndReplayNeedsFullHistory) {
  const fs::path out = *work_ / "history_none";
  const std::string data = " --data sim:" + (*work_ / "sim").string();
  const Result r = slamkit("run --filter ekf --history none" + data + " --out " + out.string(), *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(count_lines(read_file(out / "trajectory.tum")), 3u);  // the header, the start, the end
  EXPECT_EQ(read_json(out / "run.json")["history"], "none");
  EXPECT_TRUE(read_json(out / "metrics.json").contains("final_position_error_m"));
  const Result e = slamkit("evaluate " + out.string(), *work_);
  EXPECT_EQ(e.exit_code, 0) << e.err;

  const Result replay = slamkit("run --history decimated --replay" + data + " --out " + out.string(), *work_);
  EXPECT_EQ(replay.exit_code, 2);
  EXPECT_NE(replay.err.find("--replay records every scan; it needs --history full"), std::string::npos) << replay.err;
  const Result unknown = slamkit("run --history some" + data + " --out " + out.string(), *work_);
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("expected one of: full, decimated, none"), std::string::npos) << unknown.err;
}
