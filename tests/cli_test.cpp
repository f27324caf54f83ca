// The slamkit command line, end to end: the demo pipeline, its outputs, and how it fails on bad input
// (one line on stderr naming the file, the line and what was expected; a non-zero exit code).
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "sanitizers.hpp"
#include "test_data.hpp"

using slamkit::test_data::read_json;
using slamkit::test_data::read_text;

namespace fs = std::filesystem;

namespace {

struct Result {
  int exit_code = -1;
  std::string out;
  std::string err;
};

/// Runs the slamkit binary with `args` (shell-quoted by the caller), capturing stdout and stderr; in
/// the folder `cwd` if given, after the shell text `prefix` (a ulimit, a timeout).
Result slamkit_cli(const std::string& args, const fs::path& work, const fs::path& cwd = {}, const std::string& prefix = {}) {
  const fs::path err_file = work / "stderr.txt";
  const std::string command = (cwd.empty() ? "" : "cd " + cwd.string() + " && ") + prefix + std::string(SLAMKIT_CLI) +
                              " " + args + " 2>" + err_file.string();
  Result r;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe) != nullptr) r.out += buffer.data();
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.err = read_text(err_file);
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
    const Result sim = slamkit_cli("simulate --seed 3 --out " + (*work_ / "sim").string(), *work_);
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
  const Result r = slamkit_cli("run --filter ekf --data sim:" + (*work_ / "sim").string() + " --out " + out.string(), *work_);
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
  const Result e = slamkit_cli("evaluate " + out.string(), *work_);
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
    const Result r = slamkit_cli("run " + std::string(filter) + data + " --out " + out.string(), *work_);
    ASSERT_EQ(r.exit_code, 0) << filter << ": " << r.err;
    EXPECT_TRUE(fs::exists(out / "nees.svg")) << filter;
    std::ifstream in(out / "metrics.json");
    const auto m = nlohmann::json::parse(in);
    EXPECT_EQ(m["filter"], std::string(filter).find("ukf") != std::string::npos ? "ukf" : "ekf");
    EXPECT_LT(m["ate_rmse_m"].get<double>(), 0.25 * m["dead_reckoning_ate_rmse_m"].get<double>()) << filter;
    dirs += " " + out.string();
  }
  const fs::path svg = *work_ / "nees_mc.svg";
  const Result p = slamkit_cli("plot-nees" + dirs + " --out " + svg.string(), *work_);
  ASSERT_EQ(p.exit_code, 0) << p.err;
  std::ifstream in(svg);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("95% interval of the 4-run mean"), std::string::npos);
}

TEST_F(Cli, SameSeedSameLog) {
  const Result a = slamkit_cli("simulate --seed 3 --out " + (*work_ / "again").string(), *work_);
  ASSERT_EQ(a.exit_code, 0);
  EXPECT_EQ(read_text(*work_ / "sim" / "events.txt"), read_text(*work_ / "again" / "events.txt"));
}

TEST_F(Cli, EveryCommandHasHelp) {
  for (const char* cmd : {"", "simulate", "make-world", "run", "evaluate"}) {
    const Result r = slamkit_cli(std::string(cmd) + " --help", *work_);
    EXPECT_EQ(r.exit_code, 0) << cmd;
    EXPECT_NE(r.out.find("--help"), std::string::npos) << cmd;
  }
}

TEST_F(Cli, MissingDatasetIsOneLineError) {
  const Result r = slamkit_cli("run --filter ekf --data sim:/nonexistent/log --out " + (*work_ / "x").string(), *work_);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(count_lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("/nonexistent/log"), std::string::npos) << r.err;
}

TEST_F(Cli, MalformedLineNamesFileAndLine) {
  const fs::path log = copy_of_log("malformed");
  replace_line(log / "events.txt", 40, "control 1.0 oops");
  const Result r = slamkit_cli("run --filter ekf --data sim:" + log.string() + " --out " + (*work_ / "y").string(), *work_);
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
  const Result r = slamkit_cli("run --filter ekf --data sim:" + log.string() + " --out " + (*work_ / "z").string(), *work_);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(count_lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("events.txt:" + std::to_string(target) + ":"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("finite"), std::string::npos) << r.err;
}

TEST_F(Cli, UnknownOptionFilterAndDatasetKind) {
  const Result opt = slamkit_cli("run --data sim:" + (*work_ / "sim").string() + " --out " + (*work_ / "w").string() +
                                 " --bogus 1",
                             *work_);
  EXPECT_EQ(opt.exit_code, 2);
  EXPECT_EQ(count_lines(opt.err), 1u) << opt.err;
  EXPECT_NE(opt.err.find("--bogus"), std::string::npos) << opt.err;
  EXPECT_NE(opt.err.find("slamkit run --help"), std::string::npos) << opt.err;
  const Result missing = slamkit_cli("run --filter ekf", *work_);
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("--data is required"), std::string::npos) << missing.err;

  const Result filter = slamkit_cli("run --filter nope --data sim:" + (*work_ / "sim").string() + " --out " +
                                    (*work_ / "w").string(), *work_);
  EXPECT_EQ(filter.exit_code, 2);
  EXPECT_NE(filter.err.find("unknown filter 'nope'"), std::string::npos) << filter.err;

  const Result kind = slamkit_cli("run --data tape:/x --out " + (*work_ / "w").string(), *work_);
  EXPECT_EQ(kind.exit_code, 2);
  EXPECT_NE(kind.err.find("unknown dataset kind 'tape'"), std::string::npos) << kind.err;

  const Result no_cmd = slamkit_cli("", *work_);
  EXPECT_EQ(no_cmd.exit_code, 2);
}

TEST_F(Cli, EvaluateRejectsAFolderThatIsNotARun) {
  const Result r = slamkit_cli("evaluate " + (*work_ / "sim").string(), *work_);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(count_lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("run.json"), std::string::npos) << r.err;
}

TEST_F(Cli, MakeWorldThenSimulateIt) {
  const fs::path world = *work_ / "big.world";
  const Result w = slamkit_cli("make-world --landmarks 400 --width 300 --height 200 --out " + world.string(), *work_);
  ASSERT_EQ(w.exit_code, 0) << w.err;
  const Result s = slamkit_cli("simulate --loops 1 --world " + world.string() + " --out " + (*work_ / "big").string(), *work_);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_NE(s.out.find("400 landmarks"), std::string::npos) << s.out;
}

TEST_F(Cli, UnknownAssociationOnALogWithoutIds) {
  const fs::path log = *work_ / "noids";
  const Result s = slamkit_cli("simulate --scenario cluttered --out " + log.string(), *work_);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const Result known = slamkit_cli("run --data sim:" + log.string() + " --out " + (*work_ / "k").string(), *work_);
  EXPECT_NE(known.exit_code, 0);
  EXPECT_EQ(count_lines(known.err), 1u) << known.err;
  EXPECT_NE(known.err.find("--assoc nn"), std::string::npos) << known.err;

  const fs::path out = *work_ / "jcbb";
  const Result r = slamkit_cli("run --assoc jcbb --data sim:" + log.string() + " --out " + out.string(), *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(out / "metrics.json");
  const auto m = nlohmann::json::parse(in);
  EXPECT_EQ(m["association"], "jcbb");
  for (const char* key : {"association_correct", "association_wrong", "association_missed", "spurious_landmarks",
                          "landmarks_true_seen", "clutter_observations", "landmarks_removed"})
    EXPECT_TRUE(m.contains(key)) << key;
  EXPECT_EQ(m["landmarks_true_seen"], 100);
  EXPECT_TRUE(fs::exists(out / "associations.txt"));

  const Result e = slamkit_cli("evaluate " + out.string(), *work_);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  std::ifstream in2(out / "metrics.json");
  const auto m2 = nlohmann::json::parse(in2);
  EXPECT_EQ(m2["association_correct"], m["association_correct"]);
  EXPECT_EQ(m2["spurious_landmarks"], m["spurious_landmarks"]);

  // FastSLAM runs the same JCBB, per particle.
  const fs::path particles = *work_ / "fastslam-jcbb";
  const Result f = slamkit_cli("run --filter fastslam2 --particles 10 --assoc jcbb --data sim:" + log.string() +
                               " --out " + particles.string(),
                           *work_);
  ASSERT_EQ(f.exit_code, 0) << f.err;
  std::ifstream in3(particles / "metrics.json");
  const auto m3 = nlohmann::json::parse(in3);
  EXPECT_EQ(m3["association"], "jcbb");
  EXPECT_GT(m3["jcbb_nodes"].get<double>(), 0.0);
  EXPECT_GT(m3["association_correct"].get<double>(), 1000.0);

  const Result bad = slamkit_cli("run --assoc fuzzy --data sim:" + log.string() + " --out " + out.string(), *work_);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("unknown association 'fuzzy'"), std::string::npos) << bad.err;
}

TEST_F(Cli, FastSlamRunWritesParticlesAndItsStatistics) {
  const fs::path out = *work_ / "fastslam2";
  const Result r = slamkit_cli("run --filter fastslam2 --particles 20 --resample residual --resample-when every:5 --data sim:" +
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
  const Result e = slamkit_cli("evaluate " + out.string(), *work_);
  ASSERT_EQ(e.exit_code, 0) << e.err;

  const Result bad = slamkit_cli("run --filter fastslam1 --resample-when sometimes --data sim:" + (*work_ / "sim").string() +
                                 " --out " + out.string(),
                             *work_);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(count_lines(bad.err), 1u) << bad.err;
  EXPECT_NE(bad.err.find("sometimes"), std::string::npos) << bad.err;
}

TEST_F(Cli, RunsTheShippedCourseExample) {
  const fs::path out = *work_ / "course";
  const Result r = slamkit_cli("run --data course:" + (fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course").string() +
                               " --out " + out.string(),
                           *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(out / "metrics.json");
  const auto m = nlohmann::json::parse(in);
  EXPECT_EQ(m["landmarks"], 8);
  EXPECT_EQ(m["map_landmarks_paired"], 8);
  EXPECT_LT(m["map_rmse_m"].get<double>(), 0.5);
}

// The information filters from the command line, on the shipped course (a short log: the exact EIF
// costs a factorisation per scan). The SEIF with two active landmarks sparsifies at every scan; the
// ESEIF with four relocates.
TEST_F(Cli, InformationFiltersRunTheCourseAndRecordTheirSettings) {
  const std::string course = "course:" + (fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course").string();
  const fs::path eif = *work_ / "course-eif", seif = *work_ / "course-seif";
  const Result e = slamkit_cli("run --filter eif --data " + course + " --out " + eif.string(), *work_);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const Result s = slamkit_cli("run --filter seif --seif-active 2 --seif-sweeps 3 --seif-covariance exact --data " +
                                   course + " --out " + seif.string(),
                               *work_);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const auto read = [](const fs::path& file) {
    std::ifstream in(file);
    return nlohmann::json::parse(in);
  };
  const auto me = read(eif / "metrics.json"), ms = read(seif / "metrics.json");
  EXPECT_EQ(me["filter"], "eif");
  EXPECT_EQ(ms["filter"], "seif");
  EXPECT_EQ(me["landmarks"], 8);
  EXPECT_EQ(ms["landmarks"], 8);
  EXPECT_LT(me["map_rmse_m"].get<double>(), 0.5);
  EXPECT_LT(ms["map_rmse_m"].get<double>(), 0.5);
  EXPECT_GT(me["information_factorisations"].get<double>(), 0.0);
  EXPECT_GT(ms["seif_sparsifications"].get<double>(), 0.0);
  EXPECT_LE(ms["seif_active_landmarks"].get<double>(), 8.0);
  const auto settings = read(seif / "run.json")["settings"];
  EXPECT_EQ(settings["seif_active_landmarks"], 2);
  EXPECT_EQ(settings["seif_recovery_sweeps"], 3);
  EXPECT_EQ(settings["seif_covariance"], "exact");
  // The information matrix's picture: the EIF's one matrix, the SEIF's sparsification step.
  const auto text = [](const fs::path& file) {
    std::ifstream in(file);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_NE(text(eif / "information.svg").find("the exact information matrix"), std::string::npos);
  const std::string seif_picture = text(seif / "information.svg");
  EXPECT_NE(seif_picture.find("SEIF"), std::string::npos);
  EXPECT_NE(seif_picture.find("seif_active_landmarks 2"), std::string::npos);

  const fs::path eseif = *work_ / "course-eseif";
  const Result x = slamkit_cli("run --filter eseif --eseif-active 4 --eseif-covariance local --data " + course +
                                   " --out " + eseif.string(),
                               *work_);
  ASSERT_EQ(x.exit_code, 0) << x.err;
  const auto mx = read(eseif / "metrics.json");
  EXPECT_EQ(mx["filter"], "eseif");
  EXPECT_EQ(mx["landmarks"], 8);
  EXPECT_LT(mx["map_rmse_m"].get<double>(), 0.5);
  EXPECT_GT(mx["eseif_relocations"].get<double>(), 0.0);
  EXPECT_EQ(read(eseif / "run.json")["settings"]["eseif_covariance"], "local");
  EXPECT_NE(text(eseif / "information.svg").find("eseif_active_landmarks 4"), std::string::npos);

  const fs::path tjtf = *work_ / "course-tjtf";
  const Result j =
      slamkit_cli("run --filter tjtf --tjtf-clique 3 --assoc jcbb --data " + course + " --out " + tjtf.string(), *work_);
  ASSERT_EQ(j.exit_code, 0) << j.err;
  const auto mj = read(tjtf / "metrics.json");
  EXPECT_EQ(mj["filter"], "tjtf");
  EXPECT_EQ(mj["landmarks"], 7);  // as the EKF's JCBB run: one landmark is seen too rarely to be confirmed
  EXPECT_LT(mj["map_rmse_m"].get<double>(), 0.5);
  EXPECT_GT(mj["tjtf_contractions"].get<double>(), 0.0);
  EXPECT_LE(mj["tjtf_widest_clique"].get<double>(), 3.0);
  EXPECT_EQ(read(tjtf / "run.json")["settings"]["tjtf_max_clique_landmarks"], 3);
  EXPECT_NE(text(tjtf / "information.svg").find("tjtf_max_clique_landmarks 3"), std::string::npos);
}

TEST_F(Cli, DatasetSettingsFileIsUsedAndChecked) {
  const fs::path course = fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course";
  const fs::path shipped = fs::path(SLAMKIT_SOURCE_DIR) / "config" / "course.json";
  const fs::path out = *work_ / "course-settings";
  const Result r = slamkit_cli("run --data course:" + course.string() + " --data-config " + shipped.string() + " --out " +
                               out.string(),
                           *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(out / "run.json");
  EXPECT_EQ(nlohmann::json::parse(in)["dataset_settings"], shipped.string());

  const fs::path bad = *work_ / "bad-settings.json";
  std::ofstream(bad) << "{\"sigma_range_m\": 0.2, \"bogus\": 1}\n";
  const Result b = slamkit_cli("run --data course:" + course.string() + " --data-config " + bad.string() + " --out " +
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
  const Result lost = slamkit_cli("run --data course:" + course.string() + " --data-config " + tight.string() +
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

  const Result fine = slamkit_cli("run --data course:" + course.string() + " --out " + (*work_ / "course-fine").string() +
                                  " --quiet",
                              *work_);
  ASSERT_EQ(fine.exit_code, 0) << fine.err;
  EXPECT_EQ(fine.err, "");
}

TEST_F(Cli, CalibrateWritesMrclamSettingsThatRunReads) {
  // Where test_data::shared_dataset looks (its header's namespace would hide this file's slamkit_cli()).
  const char* data = std::getenv("SLAMKIT_DATA");
  const fs::path dataset = (data != nullptr && *data != '\0' ? fs::path(data)
                                                              : fs::path(SLAMKIT_SOURCE_DIR) / ".." / "shared" / "datasets") /
                           "mrclam" / "MRCLAM_Dataset6";
  if (!fs::exists(dataset)) GTEST_SKIP() << "dataset not found at " << dataset.string();
  const fs::path settings = *work_ / "calibrated.json", report = *work_ / "calibration-report.json";
  const std::string robot4 = "mrclam:" + dataset.string() + ":robot4";
  const Result c =
      slamkit_cli("calibrate --data " + robot4 + " --out " + settings.string() + " --report " + report.string(), *work_);
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
  const Result run = slamkit_cli("run --data " + robot4 + " --data-config " + settings.string() + " --out " +
                                 (*work_ / "calibrated-run").string() + " --quiet",
                             *work_);
  EXPECT_EQ(run.exit_code, 0) << run.err;

  const Result wrong = slamkit_cli("calibrate --data sim:" + (*work_ / "sim").string() + " --out " + settings.string(), *work_);
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
      {"--filter ekff",
       "--filter: unknown filter 'ekff' (did you mean 'ekf'?); expected one of: ekf, ukf, eif, seif, eseif, tjtf, fastslam1, fastslam2"},
      {"--filter ukf --ekf-variant fej",
       "EKF variant 'fej' applies to the filter 'ekf' and the information filters 'eif', 'seif' and 'eseif', not 'ukf'"},
      {"--assoc nearest", "--assoc: unknown association 'nearest'; expected one of: known, nn, jcbb"},
      {"--ekf-variant sparse", "--ekf-variant: unknown EKF variant 'sparse'; expected one of: full, compressed, fej, invariant"},
      {"--ekf-update both", "--ekf-update: unknown EKF update 'both'; expected one of: joint, sequential, iterated"},
      {"--filter ukf --ukf-noise both", "--ukf-noise: unknown UKF noise 'both'; expected one of: augmented, additive"},
      {"--resample best", "--resample: unknown resampling method 'best'; expected one of: multinomial"},
      {"--resample-when sometimes", "--resample-when: unknown resampling policy 'sometimes'; expected always"},
      {"--resample-when every:0", "K must be an integer >= 1"},
      {"--resample-when ess:2", "F must be a number in (0, 1]"},
      {"--particles 0", "--particles: expected an integer >= 1, found 0"},
      {"--seif-active 0", "--seif-active: expected an integer >= 1, found 0"},
      {"--seif-sweeps -1", "--seif-sweeps: expected an integer >= 0, found -1"},
      {"--seif-covariance all", "--seif-covariance: unknown covariance recovery 'all'; expected one of: local, exact"},
      {"--eseif-active 0", "--eseif-active: expected an integer >= 1, found 0"},
      {"--tjtf-clique 2", "--tjtf-clique: expected an integer >= 3, found 2"},
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
    const Result r = slamkit_cli("run " + std::string(c.options) + rest, *work_);
    EXPECT_EQ(r.exit_code, 2) << c.options << ": " << r.err;
    EXPECT_EQ(count_lines(r.err), 1u) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("slamkit run --help"), std::string::npos) << r.err;
  }
  // With valid settings the same command fails on the data instead.
  const Result data = slamkit_cli("run --filter fastslam1 --particles 5" + rest, *work_);
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
      {"simulate --detection-prob 2 --out x", "--detection-prob: expected in (0, 1], found 2"},
      {"make-world --width 0 --out x", "--width: expected > 0, found 0"},
      {"make-world --landmarks 0 --out x", "--landmarks: expected an integer >= 1, found 0"},
  };
  for (const auto& c : cases) {
    const Result r = slamkit_cli(c.command, *work_);
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
    const Result run = slamkit_cli(std::string("run --ekf-variant compressed --ekf-update ") + update + data, *work_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(run.err, "") << update;
  }
}

TEST_F(Cli, SettingsFilesWithANumberBeyondADoubleNameTheFileAndLine) {
  const fs::path config = *work_ / "huge.json";
  std::ofstream(config) << "{\n  \"speed_mps\": 2,\n  \"wheelbase_m\": 1e400\n}\n";
  const Result sim = slamkit_cli("simulate --config " + config.string() + " --out " + (*work_ / "huge").string(), *work_);
  EXPECT_EQ(sim.exit_code, 1);
  EXPECT_EQ(count_lines(sim.err), 1u) << sim.err;
  EXPECT_NE(sim.err.find(config.string() + ":3: "), std::string::npos) << sim.err;
  EXPECT_NE(sim.err.find("1e400"), std::string::npos) << sim.err;

  const fs::path settings = *work_ / "huge-course.json";
  std::ofstream(settings) << "{\"max_range_m\": -1e400}\n";
  const Result run = slamkit_cli("run --data course:" + (fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course").string() +
                                 " --data-config " + settings.string() + " --out " + (*work_ / "never").string(),
                             *work_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(count_lines(run.err), 1u) << run.err;
  EXPECT_NE(run.err.find(settings.string() + ":1: "), std::string::npos) << run.err;
}


TEST_F(Cli, RunJsonRepeatsTheRunBitForBitFromAnotherFolder) {
  // A run given relative paths and a settings file, then repeated from elsewhere after the settings
  // file is gone: run.json alone (absolute data path, the settings' contents, every filter setting)
  // must give the same estimate and the same metrics.
  const fs::path first = *work_ / "repeat" / "first", second = *work_ / "repeat" / "second";
  fs::create_directories(first);
  fs::create_directories(second);
  fs::copy(fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course", first / "course", fs::copy_options::recursive);
  std::ofstream(first / "settings.json") << read_text(fs::path(SLAMKIT_SOURCE_DIR) / "config" / "course.json");
  const Result run = slamkit_cli("run --filter fastslam2 --particles 15 --seed 5 --assoc nn --resample-when every:2 "
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
  // The compiler, the build type and the instruction set the numbers came from.
  const std::string build = info.at("build").get<std::string>();
  EXPECT_EQ(std::count(build.begin(), build.end(), ','), 2) << build;
  EXPECT_EQ(info.at("command_line").at(1), "run");

  const Result repeat = slamkit_cli("run --config " + (first / "r" / "run.json").string() + " --out r", *work_, second);
  ASSERT_EQ(repeat.exit_code, 0) << repeat.err;
  EXPECT_EQ(read_text(first / "r" / "trajectory.tum"), read_text(second / "r" / "trajectory.tum"));
  EXPECT_EQ(read_text(first / "r" / "map.txt"), read_text(second / "r" / "map.txt"));
  nlohmann::json a = read_json(first / "r" / "metrics.json"), b = read_json(second / "r" / "metrics.json");
  a.erase("wall_time_s");
  b.erase("wall_time_s");
  EXPECT_EQ(a, b);
  EXPECT_EQ(read_json(second / "r" / "run.json").at("settings"), info.at("settings"));

  // The folder evaluates from anywhere, and settings cannot be mixed into a repeat.
  const Result evaluate = slamkit_cli("evaluate " + (first / "r").string(), *work_, second);
  EXPECT_EQ(evaluate.exit_code, 0) << evaluate.err;
  const Result mixed =
      slamkit_cli("run --config " + (first / "r" / "run.json").string() + " --particles 3 --out r", *work_, second);
  EXPECT_EQ(mixed.exit_code, 2) << mixed.err;
}

TEST_F(Cli, PrintConfigShowsEveryEffectiveSettingWithoutRunning) {
  const Result r = slamkit_cli("run --filter fastslam1 --particles 7 --data sim:" + (*work_ / "sim").string() +
                               " --print-config",
                           *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json config = nlohmann::json::parse(r.out);
  EXPECT_EQ(config.at("settings").at("filter"), "fastslam1");
  EXPECT_EQ(config.at("settings").at("particles"), 7);
  EXPECT_EQ(config.at("settings").at("resample"), "systematic");
  EXPECT_TRUE(config.at("settings").at("association").contains("accept_probability"));
  EXPECT_EQ(config.at("dataset"), "sim:" + fs::weakly_canonical(*work_ / "sim").string());

  const Result ukf = slamkit_cli("run --filter ukf --ukf-noise additive --data sim:" + (*work_ / "sim").string() +
                                 " --print-config",
                             *work_);
  ASSERT_EQ(ukf.exit_code, 0) << ukf.err;
  EXPECT_EQ(nlohmann::json::parse(ukf.out).at("settings").at("ukf_noise"), "additive");
  EXPECT_EQ(nlohmann::json::parse(ukf.out).at("settings").at("likelihood"), "gaussian");

  const Result t = slamkit_cli("run --likelihood student-t --likelihood-dof 3 --data sim:" + (*work_ / "sim").string() +
                               " --print-config",
                           *work_);
  ASSERT_EQ(t.exit_code, 0) << t.err;
  EXPECT_EQ(nlohmann::json::parse(t.out).at("settings").at("likelihood"), "student-t");
  EXPECT_EQ(nlohmann::json::parse(t.out).at("settings").at("likelihood_dof"), 3.0);

  const Result one_sided =
      slamkit_cli("run --likelihood student-t-long --data sim:" + (*work_ / "sim").string() + " --print-config", *work_);
  ASSERT_EQ(one_sided.exit_code, 0) << one_sided.err;
  EXPECT_EQ(nlohmann::json::parse(one_sided.out).at("settings").at("likelihood"), "student-t-long");
}

// --range-calibration turns the calibration on with its default prior, a deviation given turns it
// on too, and a run reports what it estimated.
TEST_F(Cli, RangeCalibrationFlagsSetItsPriorAndTheRunReportsTheEstimate) {
  const std::string data = " --data sim:" + (*work_ / "sim").string();
  const auto settings = [&](const std::string& flags) {
    const Result r = slamkit_cli("run" + flags + data + " --print-config", *work_);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(r.out).at("settings").at("range_calibration");
  };
  EXPECT_TRUE(settings("").is_null());
  // The documented default prior: 0 +- 1 m and 0 +- 0.1.
  const nlohmann::json on = settings(" --range-calibration");
  EXPECT_EQ(on.at("offset_m"), 0.0);
  EXPECT_EQ(on.at("offset_std_m"), 1.0);
  EXPECT_EQ(on.at("scale_error_std"), 0.1);
  const nlohmann::json scale = settings(" --range-scale-std 0.02");
  EXPECT_EQ(scale.at("scale_error_std"), 0.02);
  EXPECT_EQ(scale.at("offset_std_m"), 1.0);

  const Result run = slamkit_cli("run --range-calibration" + data + " --out " + (*work_ / "calibrated").string(), *work_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::ifstream metrics(*work_ / "calibrated" / "metrics.json");
  const nlohmann::json m = nlohmann::json::parse(metrics);
  // The built-in world's sensor has no systematic error.
  EXPECT_LT(std::abs(m.at("range_offset_m").get<double>()), 4.0 * m.at("range_offset_std_m").get<double>());
  EXPECT_LT(std::abs(m.at("range_scale_error").get<double>()), 4.0 * m.at("range_scale_error_std").get<double>());
}

// The association file sets what it names, the flags override it, and run.json records the result.
TEST_F(Cli, AssociationSettingsComeFromAFileAndFlagsOverrideIt) {
  const fs::path file = *work_ / "association.json";
  std::ofstream(file) << R"({"method": "jcbb", "accept_probability": 0.95, "confirm_after": 5, "gate_known": false})";
  const std::string data = " --data sim:" + (*work_ / "sim").string();
  const Result printed = slamkit_cli("run --assoc-config " + file.string() + " --confirm-after 4 --gate-known on" + data +
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
  const Result run = slamkit_cli("run --assoc-config " + file.string() + " --assoc nn --new-landmark-probability 0.999" +
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
  const Result clutter = slamkit_cli("run --assoc-config " + cluttered.string() + " --clutter-per-scan 2" + data +
                                     " --print-config",
                                 *work_);
  ASSERT_EQ(clutter.exit_code, 0) << clutter.err;
  const nlohmann::json clutter_settings = nlohmann::json::parse(clutter.out).at("settings").at("association");
  EXPECT_EQ(clutter_settings.at("min_pairing_probability"), 0.9);
  EXPECT_EQ(clutter_settings.at("clutter_per_scan"), 2.0);
  EXPECT_EQ(slamkit_cli("run --min-pairing-probability 1" + data + " --out " + (*work_ / "never").string(), *work_).exit_code,
            2);

  // A wrong file is bad input naming it, before any data is read; a repeated run takes none of these.
  std::ofstream(*work_ / "bad_association.json") << R"({"confirm_afterr": 5})";
  const Result bad = slamkit_cli("run --assoc-config " + (*work_ / "bad_association.json").string() +
                                 " --data sim:/nonexistent/log --out " + (*work_ / "never").string(),
                             *work_);
  EXPECT_EQ(bad.exit_code, 1) << bad.err;
  EXPECT_NE(bad.err.find("bad_association.json"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("confirm_afterr"), std::string::npos) << bad.err;
  const Result repeat = slamkit_cli("run --config " + (out / "run.json").string() + " --confirm-after 2 --out " +
                                    (*work_ / "never").string(),
                                *work_);
  EXPECT_EQ(repeat.exit_code, 2) << repeat.err;
}

TEST_F(Cli, VersionUnknownSubcommandAndIgnoredOptions) {
  const Result version = slamkit_cli("--version", *work_);
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_NE(version.out.find('.'), std::string::npos) << version.out;

  const Result typo = slamkit_cli("rnu --filter ekf", *work_);
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_EQ(count_lines(typo.err), 1u) << typo.err;
  EXPECT_NE(typo.err.find("unknown subcommand 'rnu' (did you mean 'run'?); expected one of: simulate, make-world, run"),
            std::string::npos)
      << typo.err;

  const fs::path out = *work_ / "ignored";
  const Result ekf = slamkit_cli("run --filter ekf --particles 50 --data sim:" + (*work_ / "sim").string() + " --out " +
                                 out.string(),
                             *work_);
  ASSERT_EQ(ekf.exit_code, 0) << ekf.err;
  EXPECT_NE(ekf.err.find("warning: --particles is ignored by the EKF"), std::string::npos) << ekf.err;
  // The truth beside the estimate, in the same format and time base.
  EXPECT_TRUE(fs::exists(out / "truth.tum"));
  EXPECT_TRUE(fs::exists(out / "pose_error.svg"));
  EXPECT_EQ(count_lines(read_text(out / "truth.tum")) > 100, true);
}

TEST_F(Cli, ReplayPageIsSelfContainedAndRewrittenFromItsRecording) {
  const fs::path out = *work_ / "replay";
  const Result run = slamkit_cli("run --data sim:" + (*work_ / "sim").string() + " --out " + out.string() + " --replay",
                             *work_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string page = read_text(out / "replay.html");
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
  const Result again = slamkit_cli("replay " + out.string(), *work_);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(read_text(out / "replay.html"), page);
}

// --history none keeps the run folder to the start and the final estimate, which evaluate reads back
// and scores; --replay needs every scan, so it is a usage error with another history.
TEST_F(Cli, HistoryNoneWritesTheFinalEstimateAndReplayNeedsFullHistory) {
  const fs::path out = *work_ / "history_none";
  const std::string data = " --data sim:" + (*work_ / "sim").string();
  const Result r = slamkit_cli("run --filter ekf --history none" + data + " --out " + out.string(), *work_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(count_lines(read_text(out / "trajectory.tum")), 3u);  // the header, the start, the end
  EXPECT_EQ(read_json(out / "run.json")["history"], "none");
  EXPECT_TRUE(read_json(out / "metrics.json").contains("final_position_error_m"));
  const Result e = slamkit_cli("evaluate " + out.string(), *work_);
  EXPECT_EQ(e.exit_code, 0) << e.err;

  const Result replay = slamkit_cli("run --history decimated --replay" + data + " --out " + out.string(), *work_);
  EXPECT_EQ(replay.exit_code, 2);
  EXPECT_NE(replay.err.find("--replay records every scan; it needs --history full"), std::string::npos) << replay.err;
  const Result unknown = slamkit_cli("run --history some" + data + " --out " + out.string(), *work_);
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("expected one of: full, decimated, none"), std::string::npos) << unknown.err;
}

// Every option of every subcommand given a wrong value (or none, or twice), every missing or
// misspelt argument: one line of slamkit's own words naming what was expected, and the exit code of
// the kind of mistake: 2 for usage (the command's words), 1 for bad data (a file missing or wrong).
// The options are read from each subcommand's --help, so one added without a case here fails.
TEST_F(Cli, EveryOptionWithAWrongValueIsOneClearLineWithItsExitCode) {
  const std::string sim = (*work_ / "sim").string();
  const std::string out = (*work_ / "sweep").string();
  const std::string course = (fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course").string();
  const std::string run_dir = (*work_ / "sweep-run").string();
  ASSERT_EQ(slamkit_cli("run --data sim:" + sim + " --out " + run_dir + " --quiet", *work_).exit_code, 0);
  const std::string data = " --data sim:" + sim + " --out " + out;
  const struct {
    std::string command;
    int code;
    std::string message;
  } cases[] = {
      {"", 2, "expected a subcommand: simulate, make-world, run, replay, evaluate, calibrate, plot-nees, plot-bench"},
      {"rnu", 2, "unknown subcommand 'rnu' (did you mean 'run'?)"},
      {"--bogus", 2, "unknown option '--bogus'; expected a subcommand first"},

      {"simulate --scenario loop-closre --out " + out, 2,
       "--scenario: unknown scenario 'loop-closre' (did you mean 'loop-closure'?); expected one of: default"},
      {"simulate --world /nonexistent/w.txt --out " + out, 1,
       "/nonexistent/w.txt: cannot open file for reading (No such file or directory)"},
      {"simulate --config /nonexistent/s.json --out " + out, 1,
       "/nonexistent/s.json: cannot open file for reading (No such file or directory)"},
      {"simulate --seed -1 --out " + out, 2, "--seed: expected an integer >= 0, found -1"},
      {"simulate --loops 0 --out " + out, 2, "--loops: expected an integer >= 1, found 0"},
      {"simulate --clutter -1 --out " + out, 2, "--clutter: expected >= 0, found -1"},
      {"simulate --clutter 2000 --out " + out, 2, "--clutter: 'clutter_rate_per_scan' must be >= 0 and <= 1000, found 2000"},
      {"simulate --detection-prob 0 --out " + out, 2, "--detection-prob: expected in (0, 1], found 0"},
      {"simulate --sensor sonar --out " + out, 2,
       "--sensor: unknown sensor 'sonar'; expected one of: range-bearing, range-only, bearing-only"},
      {"simulate --no-ids=maybe --out " + out, 2, "--no-ids is a flag: expected no value (or true or false), found 'maybe'"},
      {"simulate", 2, "missing --out: Output folder for the log and ground truth"},
      {"simulate --out", 2, "--out needs a value"},
      {"simulate --sede 3 --out " + out, 2, "unknown option '--sede' (did you mean '--seed'?)"},
      {"simulate --family sparse-clutered --out " + out, 2,
       "--family: unknown world family 'sparse-clutered' (did you mean 'sparse-cluttered'?)"},
      {"simulate --world-seed x --family sparse --out " + out, 2, "--world-seed: expected an integer >= 0, found x"},

      {"make-world --landmarks 0 --out " + out, 2, "--landmarks: expected an integer >= 1, found 0"},
      {"make-world --landmarks 20000000 --out " + out, 2, "world generation: landmarks must be from 0 to 1e7"},
      {"make-world --width 0 --out " + out, 2, "--width: expected > 0, found 0"},
      {"make-world --height 2e6 --out " + out, 2, "height must be a positive number of metres up to 1e6, found 2000000"},
      {"make-world --band 2 --out " + out, 2, "band_outer must be a distance greater than band_inner"},
      {"make-world --band nan --out " + out, 2, "--band: expected > 0, found nan"},
      {"make-world --seed x --out " + out, 2, "--seed: expected an integer >= 0, found x"},
      {"make-world", 2, "missing --out: World file to write"},
      {"make-world --family denes --out " + out, 2, "--family: unknown world family 'denes' (did you mean 'dense'?)"},
      {"make-world --world-seed -1 --family dense --out " + out, 2, "--world-seed: expected an integer >= 0, found -1"},
      {"make-world --scenario cty --out " + out, 2, "--scenario: unknown scenario 'cty' (did you mean 'city'?)"},

      {"run --filter ekff" + data, 2, "--filter: unknown filter 'ekff' (did you mean 'ekf'?)"},
      {"run --assoc jcb" + data, 2, "--assoc: unknown association 'jcb' (did you mean 'jcbb'?)"},
      {"run --data tape:/x --out " + out, 2, "--data: unknown dataset kind 'tape'; expected one of: sim, victoria-park"},
      {"run --data victoria_park --out " + out, 2, "is not a dataset spec; expected KIND:PATH"},
      {"run --data mrclam:/x:robot9 --out " + out, 2, "--data: no MRCLAM robot 'robot9'; expected a robot from 1 to 5"},
      {"run --data mrclam:/x:robot --out " + out, 2, "--data: no robot number in 'robot'; expected a robot from 1 to 5"},
      {"run --data sim:/nonexistent/log --out " + out, 1, "/nonexistent/log"},
      {"run --data course:" + course + " --data-config /nonexistent/c.json --out " + out, 1,
       "/nonexistent/c.json: cannot open file for reading (No such file or directory)"},
      {"run --seed -1" + data, 2, "--seed: expected an integer >= 0, found -1"},
      {"run --particles 0" + data, 2, "--particles: expected an integer >= 1, found 0"},
      {"run --particles 2000000" + data, 2, "particles must be an integer from 1 to 1000000, found 2000000"},
      {"run --pose-sample-fraction 0" + data, 2, "pose_sample_fraction must lie in (0, 1], found 0"},
      {"run --pose-sample-fraction 1e400" + data, 2, "--pose-sample-fraction: expected a finite number, found 1e400"},
      {"run --resample systemtic" + data, 2, "--resample: unknown resampling method 'systemtic' (did you mean 'systematic'?)"},
      {"run --resample-when alwyas" + data, 2, "--resample-when: unknown resampling policy 'alwyas' (did you mean 'always'?)"},
      {"run --threads -1" + data, 2, "--threads: expected an integer >= 0, found -1"},
      {"run --ekf-update iterate" + data, 2, "--ekf-update: unknown EKF update 'iterate' (did you mean 'iterated'?)"},
      {"run --ekf-variant invarient" + data, 2, "--ekf-variant: unknown EKF variant 'invarient' (did you mean 'invariant'?)"},
      {"run --ukf-noise additiv" + data, 2, "--ukf-noise: unknown UKF noise 'additiv' (did you mean 'additive'?)"},
      {"run --filter seif --seif-active 0" + data, 2, "--seif-active: expected an integer >= 1, found 0"},
      {"run --filter seif --seif-sweeps x" + data, 2, "--seif-sweeps: expected an integer >= 0, found x"},
      {"run --filter seif --seif-covariance exac" + data, 2,
       "--seif-covariance: unknown covariance recovery 'exac' (did you mean 'exact'?)"},
      {"run --filter eseif --eseif-active 0" + data, 2, "--eseif-active: expected an integer >= 1, found 0"},
      {"run --filter eseif --eseif-sweeps x" + data, 2, "--eseif-sweeps: expected an integer >= 0, found x"},
      {"run --filter eseif --eseif-covariance locl" + data, 2,
       "--eseif-covariance: unknown covariance recovery 'locl' (did you mean 'local'?)"},
      {"run --filter tjtf --tjtf-clique 2" + data, 2, "--tjtf-clique: expected an integer >= 3, found 2"},
      {"run --filter grid-fastslam --grid-resolution 0" + data, 2,
       "grid.resolution_m must be from 0.005 to 1, found 0"},
      {"run --filter grid-fastslam --grid-range-cutoff x" + data, 2,
       "--grid-range-cutoff: expected a finite number, found x"},
      {"run --filter grid-fastslam --grid-sample-fraction 2" + data, 2,
       "grid.proposal_sample_fraction must be from 0 to 1, found 2"},
      {"run --filter scan-matching --grid-update-distance -1" + data, 2,
       "grid.update_distance_m must be from 0 to 100, found -1"},
      {"run --grid-resolution 0.1" + data, 2,
       "the grid settings apply to the filters 'scan-matching' and 'grid-fastslam', not 'ekf'"},
      {"simulate --building ofice --out x", 2, "--building: unknown building 'ofice' (did you mean 'office'?)"},
      {"simulate --building office --sensor range-only --out x", 2,
       "--sensor and --building cannot be given together"},
      {"run --landmark-init delay" + data, 2,
       "--landmark-init: unknown landmark initialisation 'delay' (did you mean 'delayed'?)"},
      {"run --init-max-std 0" + data, 2, "delayed initialisation: max_std_m must be > 0 and <= 10000, found 0"},
      {"run --init-window x" + data, 2, "--init-window: expected a finite number, found x"},
      {"run --init-min-distance x" + data, 2, "--init-min-distance: expected a finite number, found x"},
      {"run --init-prior-distance 0.5 --landmark-init inverse-distance" + data, 2,
       "the inverse-distance start needs 0 < min_distance_m < prior_distance_m, both finite; found 1 and 0.5"},
      {"run --range-calibration --assoc nn" + data, 2,
       "a range calibration is estimated with association 'known': nn and jcbb predict measurements without it"},
      {"run --range-offset-std 0" + data, 2, "range_calibration.offset_std_m must be > 0 and <= 10000, found 0"},
      {"run --landmark-init ring --range-calibration" + data, 2,
       "the ring landmark start does not carry a range calibration's correlations"},
      {"run --filter fastslam1 --range-calibration" + data, 2,
       "a range calibration is estimated by the filter 'ekf' with the variant full, fej or invariant, or by "
       "'fastslam2'"},
      {"run --filter fastslam2 --range-calibration --landmark-init immediate" + data, 1,
       "FastSLAM starts a landmark that moves with the range calibration through the delayed start"},
      {"run --range-scale-std x" + data, 2, "--range-scale-std: expected a finite number, found x"},
      {"run --likelihood students" + data, 2, "--likelihood: unknown likelihood 'students' (did you mean 'student-t'?)"},
      {"run --likelihood student-t --likelihood-dof 0" + data, 2,
       "the t likelihood's degrees of freedom must be positive and finite"},
      {"run --likelihood-dof 3" + data, 2, "likelihood_dof (3) applies to the likelihoods 'student-t' and 'student-t-long', not 'gaussian'"},
      {"run --assoc-config /nonexistent/a.json" + data, 1,
       "/nonexistent/a.json: cannot open file for reading (No such file or directory)"},
      {"run --accept-probability 1.5" + data, 2, "association setting accept_probability must be in (0, 1), found 1.5"},
      {"run --new-landmark-probability 0.5" + data, 2, "new_landmark_probability must be in [accept_probability, 1)"},
      {"run --min-pairing-probability 1" + data, 2, "min_pairing_probability must be in [0, 1), found 1"},
      {"run --clutter-per-scan -1" + data, 2, "clutter_per_scan must be finite and >= 0, found -1"},
      {"run --gate-known maybe" + data, 2, "--gate-known: unknown value 'maybe'; expected one of: on, off"},
      {"run --confirm-after 0" + data, 2, "--confirm-after: expected an integer >= 1, found 0"},
      {"run --provisional-max-misses 0" + data, 2, "--provisional-max-misses: expected an integer >= 1, found 0"},
      {"run --confirmed-max-misses -1" + data, 2, "--confirmed-max-misses: expected an integer >= 0, found -1"},
      {"run --view-margin-m -1" + data, 2, "view_margin_m must be finite and >= 0, found -1"},
      {"run --view-margin-rad x" + data, 2, "--view-margin-rad: expected a finite number, found x"},
      {"run --jcbb-max-nodes 0" + data, 2, "--jcbb-max-nodes: expected an integer >= 1, found 0"},
      {"run --relocalise-min-pairs 1" + data, 2, "relocalise_min_pairs must be 0 (off) or >= 2, found 1"},
      {"run --relocalise-window-s 0" + data, 2, "relocalise_window_s must be finite and > 0, found 0"},
      {"run --detection-probability 1" + data, 2, "detection_probability must be in (0, 1), found 1"},
      {"run --data sim:" + sim, 2, "--out is required"},
      {"run --config /nonexistent/run.json --out " + out, 1,
       "/nonexistent/run.json: cannot open file for reading (No such file or directory)"},
      {"run --config " + run_dir + "/run.json --particles 3 --out " + out, 2,
       "cannot be given together: --config repeats a run with every setting its run.json records"},
      {"run --print-config=maybe" + data, 2, "--print-config is a flag: expected no value (or true or false), found 'maybe'"},
      {"run --replay --history decimated" + data, 2, "--replay records every scan; it needs --history full"},
      {"run --history ful" + data, 2, "--history: unknown history 'ful' (did you mean 'full'?)"},
      {"run --quiet --verbose" + data, 2, "cannot be given together"},
      {"run -f ekf" + data, 2, "unknown option '-f' (did you mean '--filter'?)"},
      {"run --partcles 5" + data, 2, "unknown option '--partcles' (did you mean '--particles'?)"},
      {"run ekf" + data, 2, "unexpected argument 'ekf'; options are written --NAME VALUE"},
      {"run" + data + " --particles", 2, "--particles needs a value"},
      {"run --particles 3 --particles 4" + data, 2, "--particles may be given only once"},

      {"replay", 2, "missing DIR: Run folder holding replay.json"},
      {"replay /nonexistent/r", 1, "/nonexistent/r: no such folder; expected a run folder recorded with 'slamkit run --replay'"},
      {"replay " + run_dir, 1, "replay.json: missing; record the run with 'slamkit run --replay'"},

      {"evaluate", 2, "missing DIR: Run folder written by 'slamkit run'"},
      {"evaluate /nonexistent/r", 1, "/nonexistent/r: no such folder; expected a run folder written by 'slamkit run'"},
      {"evaluate " + sim, 1, "run.json: cannot open file for reading (is this a slamkit run folder?)"},
      {"evaluate " + run_dir + " --match evoo", 2,
       "--match: unknown time matching 'evoo' (did you mean 'evo'?); expected one of: interpolate, evo"},
      {"evaluate " + run_dir + " --match evo --max-time-difference -1", 2, "--max-time-difference: expected >= 0, found -1"},
      {"evaluate " + run_dir + " --max-time-difference 0.1", 2, "--max-time-difference applies to --match evo"},
      {"evaluate " + run_dir + " " + run_dir, 2, "unexpected argument '" + run_dir + "'"},

      {"calibrate --out " + out, 2, "missing --data: Logs to calibrate on"},
      {"calibrate --data sim:" + sim + " --out " + out, 2,
       "calibrate writes MRCLAM settings; expected --data mrclam:DIR:robotN, found 'sim:"},
      {"calibrate --data mrclam:/nonexistent:robot1 --out " + out, 1, "/nonexistent: not a directory"},
      {"calibrate --data mrclam:/nonexistent:robot1 --data-config /nonexistent/c.json --out " + out, 1,
       "/nonexistent/c.json: cannot open file for reading (No such file or directory)"},
      {"calibrate --data mrclam:/nonexistent:robot1 --out " + out + " --report", 2, "--report needs a value"},

      {"plot-nees --out " + out, 2, "missing DIRS: Run folders written by 'slamkit run'"},
      {"plot-nees /nonexistent/r --out " + out, 1, "/nonexistent/r: no such folder"},
      {"plot-nees " + run_dir, 2, "missing --out: SVG file to write"},
      {"plot-nees " + run_dir + " --out " + out + " --title", 2, "--title needs a value"},

      {"plot-bench --out " + out, 2, "missing JSON: Files written by slamkit_bench"},
      {"plot-bench /nonexistent/b.json --out " + out, 1, "/nonexistent/b.json"},
      {"plot-bench " + sim + "/params.json", 2, "missing --out: Folder for the SVG plots"},
  };
  std::map<std::string, std::set<std::string>> exercised;
  for (const auto& c : cases) {
    SCOPED_TRACE(c.command);
    const Result r = slamkit_cli(c.command, *work_);
    EXPECT_EQ(r.exit_code, c.code) << r.err;
    EXPECT_EQ(count_lines(r.err), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("slamkit: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    if (c.code == 2) EXPECT_NE(r.err.find(" --help')"), std::string::npos) << r.err;
    // CLI11's own phrasing, which says neither what was expected nor where to look.
    for (const char* raw : {"The following argument", "Could not convert", "is required", "required TEXT", "required INT",
                            " excludes ", " not in {", "does not exist", "At Most", "Should be true/false"})
      if (c.message.find(raw) == std::string::npos) EXPECT_EQ(r.err.find(raw), std::string::npos) << raw << ": " << r.err;
    std::istringstream words(c.command);
    std::string command, word;
    words >> command;
    while (words >> word) exercised[command].insert(word.substr(0, word.find('=')));
  }
  for (const char* command : {"simulate", "make-world", "run", "replay", "evaluate", "calibrate", "plot-nees", "plot-bench"}) {
    std::istringstream help(slamkit_cli(std::string(command) + " --help", *work_).out);
    for (std::string line; std::getline(help, line);) {
      const auto start = line.find_first_not_of(' ');
      if (start == std::string::npos || line.compare(start, 2, "--") != 0 || start == 0) continue;
      const std::string option = line.substr(start, line.find_first_of(" ,", start) - start);
      if (option != "--help" && option != "--help-all") EXPECT_TRUE(exercised[command].count(option)) << command << " " << option << " has no case";
    }
  }
}

// A dataset settings file's "recommended" settings lie beneath --assoc-config and the flags; the run
// says what it applied, run.json records it, and --config repeats the run bit for bit without the
// file. The course example stands for a dataset that needs settings (as Victoria Park does).
TEST_F(Cli, DatasetRecommendedSettingsLieBeneathTheFlagsAndAreRecorded) {
  const fs::path course = fs::path(SLAMKIT_SOURCE_DIR) / "examples" / "course";
  nlohmann::json settings = read_json(fs::path(SLAMKIT_SOURCE_DIR) / "config" / "course.json");
  settings["recommended"] = {{"ekf", {{"association", {{"method", "nn"}, {"confirm_after", 2}}}}},
                             {"fastslam2", {{"pose_sample_fraction", 0.5}}}};
  const fs::path file = *work_ / "recommending.json";
  std::ofstream(file) << settings.dump(2);
  const std::string data = " --data course:" + course.string() + " --data-config " + file.string();

  const fs::path out = *work_ / "recommended";
  const Result run = slamkit_cli("run" + data + " --out " + out.string(), *work_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("course's recommended settings for ekf: association.confirm_after 2, association.method nn (from " +
                         file.string() + "; a flag overrides each)"),
            std::string::npos)
      << run.err;
  const nlohmann::json recorded = read_json(out / "run.json");
  EXPECT_EQ(recorded.at("settings").at("association").at("method"), "nn");
  EXPECT_EQ(recorded.at("settings").at("association").at("confirm_after"), 2);
  EXPECT_EQ(recorded.at("recommended_settings").at("source"), file.string());
  EXPECT_EQ(recorded.at("recommended_settings").at("applied"), settings["recommended"]["ekf"]);
  EXPECT_EQ(read_json(out / "metrics.json").at("association"), "nn");

  // A flag and the association file each override what they name; the rest of the recommendation stays.
  const fs::path assoc = *work_ / "confirm5.json";
  std::ofstream(assoc) << R"({"confirm_after": 5})";
  const Result printed = slamkit_cli("run" + data + " --assoc jcbb --assoc-config " + assoc.string() + " --print-config", *work_);
  ASSERT_EQ(printed.exit_code, 0) << printed.err;
  const nlohmann::json layered = nlohmann::json::parse(printed.out);
  EXPECT_EQ(layered.at("settings").at("association").at("method"), "jcbb");
  EXPECT_EQ(layered.at("settings").at("association").at("confirm_after"), 5);
  EXPECT_FALSE(layered.contains("recommended_settings")) << layered.dump();
  const Result fastslam = slamkit_cli("run --filter fastslam2" + data + " --print-config", *work_);
  ASSERT_EQ(fastslam.exit_code, 0) << fastslam.err;
  EXPECT_EQ(nlohmann::json::parse(fastslam.out).at("settings").at("pose_sample_fraction"), 0.5);

  // Repeated from run.json alone, with the settings file gone: the same estimate.
  fs::remove(file);
  const fs::path again = *work_ / "recommended-again";
  const Result repeat = slamkit_cli("run --config " + (out / "run.json").string() + " --out " + again.string(), *work_);
  ASSERT_EQ(repeat.exit_code, 0) << repeat.err;
  EXPECT_EQ(read_text(out / "trajectory.tum"), read_text(again / "trajectory.tum"));
  EXPECT_EQ(read_json(again / "run.json").at("settings"), recorded.at("settings"));
  EXPECT_EQ(read_json(again / "run.json").at("recommended_settings"), recorded.at("recommended_settings"));
  EXPECT_EQ(slamkit_cli("evaluate " + again.string(), *work_).exit_code, 0);

  // A recommendation naming no filter is bad data naming the file, before any data is read.
  settings["recommended"] = {{"fastslam3", nlohmann::json::object()}};
  std::ofstream(file) << settings.dump();
  const Result bad = slamkit_cli("run" + data + " --out " + out.string(), *work_);
  EXPECT_EQ(bad.exit_code, 1) << bad.err;
  EXPECT_NE(bad.err.find(file.string() + ": in 'recommended': unknown filter 'fastslam3'"), std::string::npos) << bad.err;
}

// Victoria Park's built-in recommendation: each filter gets what the park needs, a flag overrides it.
TEST_F(Cli, VictoriaParkRecommendsAnAssociationForEveryFilter) {
  const std::string data = " --data victoria-park:/nowhere --print-config";
  const auto settings = [&](const std::string& options) {
    const Result r = slamkit_cli("run " + options + data, *work_);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(r.out).at("settings");
  };
  EXPECT_EQ(settings("--filter ekf").at("association").at("method"), "jcbb");
  EXPECT_EQ(settings("--filter ukf").at("ukf_noise"), "additive");
  EXPECT_EQ(settings("--filter fastslam1").at("association").at("method"), "nn");
  EXPECT_EQ(settings("--filter fastslam2").at("pose_sample_fraction"), 0.01);
  EXPECT_EQ(settings("--filter fastslam2 --pose-sample-fraction 1").at("pose_sample_fraction"), 1.0);
  EXPECT_EQ(settings("--filter ukf --ukf-noise augmented").at("ukf_noise"), "augmented");
}

// A world of a family is named by the family and a world seed, apart from the noise's seed: the same
// three give the same log, which records the family and world seed, and make-world writes that world.
TEST_F(Cli, FamilyWorldsRepeatBitForBitAndAreRecorded) {
  const fs::path a = *work_ / "family_a", b = *work_ / "family_b", world = *work_ / "family.world";
  const std::string args = "simulate --family sparse-cluttered --world-seed 17 --seed 2 --loops 1 --out ";
  ASSERT_EQ(slamkit_cli(args + a.string(), *work_).exit_code, 0);
  ASSERT_EQ(slamkit_cli(args + b.string(), *work_).exit_code, 0);
  for (const char* file : {"events.txt", "truth_poses.txt", "truth_observations.txt", "world.txt", "params.json"})
    EXPECT_EQ(read_text(a / file), read_text(b / file)) << file;
  const nlohmann::json params = read_json(a / "params.json");
  EXPECT_EQ(params["world"]["family"], "sparse-cluttered");
  EXPECT_EQ(params["world"]["world_seed"], 17);
  EXPECT_EQ(params["simulator"]["seed"], 2);
  EXPECT_EQ(params["simulator"]["clutter_rate_per_scan"], 1.0);
  EXPECT_EQ(params["simulator"]["fov_deg"], 180.0);

  const Result w = slamkit_cli("make-world --family sparse-cluttered --world-seed 17 --out " + world.string(), *work_);
  ASSERT_EQ(w.exit_code, 0) << w.err;
  EXPECT_EQ(read_text(world), read_text(a / "world.txt"));
  const Result other = slamkit_cli("simulate --family sparse-cluttered --world-seed 18 --seed 2 --loops 1 --out " +
                                   (*work_ / "family_c").string(),
                               *work_);
  ASSERT_EQ(other.exit_code, 0) << other.err;
  EXPECT_NE(read_text(*work_ / "family_c" / "world.txt"), read_text(a / "world.txt"));

  const Result help = slamkit_cli("simulate --help", *work_);
  EXPECT_NE(help.out.find("sparse, sparse-cluttered, dense, dense-cluttered"), std::string::npos) << help.out;
}

// make-world --scenario writes the world simulate --scenario drives; with generator options it is a
// usage error.
TEST_F(Cli, MakeWorldWritesAScenariosWorld) {
  const fs::path log = *work_ / "sparse_log", world = *work_ / "sparse.world";
  ASSERT_EQ(slamkit_cli("simulate --scenario sparse --loops 1 --out " + log.string(), *work_).exit_code, 0);
  const Result w = slamkit_cli("make-world --scenario sparse --out " + world.string(), *work_);
  ASSERT_EQ(w.exit_code, 0) << w.err;
  EXPECT_NE(w.out.find("(35 landmarks)"), std::string::npos) << w.out;
  EXPECT_EQ(read_text(world), read_text(log / "world.txt"));
  const Result both = slamkit_cli("make-world --scenario sparse --landmarks 5 --out " + world.string(), *work_);
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("--landmarks and --scenario cannot be given together"), std::string::npos) << both.err;
  EXPECT_EQ(slamkit_cli("make-world --scenario city --family dense --out " + world.string(), *work_).exit_code, 2);
}

TEST_F(Cli, FamilyMistakesAreUsageErrors) {
  const std::string out = " --out " + (*work_ / "family_never").string();
  const Result slip = slamkit_cli("simulate --family sparse-clutered" + out, *work_);
  EXPECT_EQ(slip.exit_code, 2);
  EXPECT_EQ(count_lines(slip.err), 1u) << slip.err;
  EXPECT_NE(slip.err.find("did you mean 'sparse-cluttered'?"), std::string::npos) << slip.err;
  EXPECT_EQ(slamkit_cli("make-world --family denes" + out, *work_).exit_code, 2);
  EXPECT_EQ(slamkit_cli("simulate --world-seed 3" + out, *work_).exit_code, 2);
  EXPECT_EQ(slamkit_cli("simulate --family sparse --scenario sparse" + out, *work_).exit_code, 2);
  EXPECT_EQ(slamkit_cli("make-world --family sparse --landmarks 10" + out, *work_).exit_code, 2);
  EXPECT_FALSE(fs::exists(*work_ / "family_never"));
}

// ---- Hostile inputs and sizes (issue 26, section 4) ------------------------------------------------

// run.json is a file users edit. A 'dataset' or 'dataset_settings' of another kind than a string
// aborted `run --config` on an uncaught JSON type error (SIGABRT, no error line); each is now one
// line naming the file and the key, exit code 1. tests/run_settings_test.cpp sweeps every key.
TEST_F(Cli, RunJsonWithADatasetOfAnotherKindIsOneErrorNamingTheKey) {
  const fs::path dir = *work_ / "wrong_kinds";
  const Result run =
      slamkit_cli("run --history none --quiet --data sim:" + (*work_ / "sim").string() + " --out " + (dir / "r").string(),
              *work_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json original = read_json(dir / "r" / "run.json");
  const fs::path variant = dir / "variant.json";
  for (const char* key : {"dataset", "dataset_settings"})
    for (const nlohmann::json& value : {nlohmann::json::array({1}), nlohmann::json(1.5), nlohmann::json::object({{"a", 1}}),
                                        nlohmann::json()}) {
      nlohmann::json j = original;
      j[key] = value;
      std::ofstream(variant) << j.dump();
      const Result r = slamkit_cli("run --config " + variant.string() + " --out " + (dir / "v").string(), *work_);
      EXPECT_EQ(r.exit_code, 1) << key << " = " << value << ": " << r.err;
      EXPECT_EQ(count_lines(r.err), 1u) << r.err;
      EXPECT_NE(r.err.find("slamkit: error: " + variant.string() + ": '" + key + "' must be"), std::string::npos)
          << r.err;
    }
}

// Victoria Park with an empty (0-byte) LASER.txt.gz ran with exit code 0, no scans and no warning:
// dead reckoning reported as a SLAM result.
TEST_F(Cli, EmptyVictoriaParkLaserFileIsRefusedNamingIt) {
  const fs::path dir = *work_ / "empty_laser";
  fs::create_directories(dir);
  std::ofstream(dir / "DRS.txt") << "0.025\t1.0\t0.01\r\n0.050\t1.0\t0.01\r\n";
  std::ofstream(dir / "GPS.txt") << "0.000\t0.00\t0.00\r\n";
  std::ofstream(dir / "LASER.txt.gz");
  const Result r = slamkit_cli("run --data victoria-park:" + dir.string() + " --out " + (dir / "r").string(), *work_);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find((dir / "LASER.txt.gz").string() + ": no laser scans"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "r" / "run.json"));
}

// A truth landmark at 1e300 m ran the whole filter and then failed in the plot, naming no input, with
// run.json saying "partial": false; a start 1e20 m out reported a map RMSE of 1e20 m. Both are now
// refused where they are read, naming the file (and the line).
TEST_F(Cli, PositionsBeyondTheCoordinateBoundAreRefusedWhereTheyAreRead) {
  const fs::path log = copy_of_log("far_landmark");
  replace_line(log / "truth_landmarks.txt", 3, "0 1e300 5");
  const Result far = slamkit_cli("run --data sim:" + log.string() + " --out " + (log / "r").string(), *work_);
  EXPECT_EQ(far.exit_code, 1);
  EXPECT_NE(far.err.find("truth_landmarks.txt:3: expected x within +-2e6 m, found 1e+300"), std::string::npos)
      << far.err;
  EXPECT_FALSE(fs::exists(log / "r" / "run.json"));

  const fs::path moved = copy_of_log("far_start");
  nlohmann::json params = read_json(moved / "params.json");
  params["initial_pose"] = {1e20, 0.0, 0.0};
  std::ofstream(moved / "params.json") << params.dump(2);
  const Result start = slamkit_cli("run --data sim:" + moved.string() + " --out " + (moved / "r").string(), *work_);
  EXPECT_EQ(start.exit_code, 1);
  EXPECT_NE(start.err.find("params.json: expected \"initial_pose\" x and y within +-2e6 m"), std::string::npos)
      << start.err;
}

// A FIFO given as an input file blocked forever, waiting for a writer; `timeout` turns a regression
// into a failure (exit 124) instead of a hung suite.
TEST_F(Cli, FifoGivenAsAnInputFileIsRefusedNotWaitedOn) {
  const fs::path dir = *work_ / "fifo";
  fs::create_directories(dir);
  const fs::path fifo = dir / "pipe";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const fs::path log = copy_of_log("fifo_log");
  fs::remove(log / "events.txt");
  ASSERT_EQ(mkfifo((log / "events.txt").c_str(), 0600), 0);
  for (const std::string& args : {"run --config " + fifo.string() + " --out " + (dir / "r").string(),
                                  "simulate --world " + fifo.string() + " --out " + (dir / "s").string(),
                                  "run --data sim:" + log.string() + " --out " + (dir / "r").string()}) {
    const Result r = slamkit_cli(args, *work_, {}, "timeout 60 ");
    EXPECT_EQ(r.exit_code, 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find("is a FIFO (named pipe); expected a regular file"), std::string::npos) << r.err;
  }
}

#if !defined(SLAMKIT_ADDRESS_SANITIZER)  // AddressSanitizer reserves terabytes of address space: no ulimit -v
// `run --particles 1000000` had no memory estimate and ended in a bare "std::bad_alloc" at 7.3 GB.
// Under a 4 GiB address-space limit the estimate refuses it before the filter is built, naming the
// flag; and whatever runs out of memory regardless ends in a message, not the exception's name.
TEST_F(Cli, RunsBeyondTheMemoryLimitAreRefusedUpFrontAndOutOfMemoryIsAMessage) {
  const fs::path dir = *work_ / "memory";
  const Result particles = slamkit_cli("run --filter fastslam2 --particles 1000000 --data sim:" +
                                       (*work_ / "sim").string() + " --out " + (dir / "r").string(),
                                   *work_, {}, "ulimit -v 4194304; ");
  EXPECT_EQ(particles.exit_code, 1);
  EXPECT_EQ(count_lines(particles.err), 1u) << particles.err;
  EXPECT_NE(particles.err.find("fastslam2 with 1000000 particles (--particles) and maps of about "),
            std::string::npos)
      << particles.err;
  EXPECT_NE(particles.err.find("GiB of memory; this process may use 4 GiB (ulimit)"), std::string::npos)
      << particles.err;

  // Ten million landmarks take more than 300 MiB before the generator has placed any.
  const Result world = slamkit_cli("make-world --landmarks 10000000 --out " + (dir / "w.txt").string(), *work_, {},
                               "ulimit -v 307200; ");
  EXPECT_EQ(world.exit_code, 1);
  EXPECT_EQ(world.err.find("bad_alloc"), std::string::npos) << world.err;
  EXPECT_NE(world.err.find("slamkit: error: out of memory"), std::string::npos) << world.err;
}
#endif
