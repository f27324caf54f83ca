// Run folders from the command line, under the conditions that break them: a rerun that fails
// half-way (a full disk) leaves the previous run whole; what a killed run left is cleared by the next
// writer; SIGINT, SIGTERM and SIGHUP stop a run and still write it; a second writer of a folder is
// refused at once. slamkit runs here as a child process whose limits and signals the test sets
// between fork and exec, which the shell's popen of tests/cli_test.cpp cannot.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "slamkit/core/atomic_folder.hpp"
#include "test_data.hpp"

using slamkit::test_data::read_json;
using slamkit::test_data::read_text;

namespace fs = std::filesystem;

namespace {

struct ChildSetup {
  /// RLIMIT_FSIZE, with SIGXFSZ ignored: a write past it fails (EFBIG) as it would on a full disk.
  rlim_t max_file_size = RLIM_INFINITY;
  /// Raised while blocked before exec, so it is pending when slamkit starts and arrives the moment
  /// slamkit unblocks it: during the run, without any timing.
  int pending_signal = 0;
};

struct Outcome {
  int exit_code = -1;  // -1 if the child did not exit (a signal ended it)
  std::string err;
};

/// Runs the slamkit binary with `args`; stdout is discarded, stderr returned.
Outcome run_cli(const std::vector<std::string>& args, const fs::path& work, const ChildSetup& setup = {}) {
  std::vector<std::string> words = {SLAMKIT_CLI};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& word : words) argv.push_back(word.data());
  argv.push_back(nullptr);
  const fs::path err_path = work / "stderr.txt";
  const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
  const pid_t pid = ::fork();
  if (pid == 0) {  // only async-signal-safe calls until exec
    if (setup.max_file_size != RLIM_INFINITY) {
      const rlimit limit{setup.max_file_size, setup.max_file_size};
      ::setrlimit(RLIMIT_FSIZE, &limit);
      ::signal(SIGXFSZ, SIG_IGN);
    }
    if (setup.pending_signal != 0) {
      sigset_t set;
      sigemptyset(&set);
      sigaddset(&set, setup.pending_signal);
      ::sigprocmask(SIG_BLOCK, &set, nullptr);
      ::raise(setup.pending_signal);
    }
    ::dup2(null, STDOUT_FILENO);
    ::dup2(err, STDERR_FILENO);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(err);
  ::close(null);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_text(err_path)};
}

/// Every file of a folder by name, with its contents.
std::map<std::string, std::string> contents(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::directory_iterator(dir)) files[entry.path().filename().string()] = read_text(entry);
  return files;
}

/// The entries of `parent` whose names start with `prefix`.
std::vector<std::string> entries_starting(const fs::path& parent, const std::string& prefix) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(parent))
    if (entry.path().filename().string().rfind(prefix, 0) == 0) names.push_back(entry.path().filename().string());
  return names;
}


class RunFolderCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    work_ = new fs::path(fs::temp_directory_path() / ("slamkit_run_folder_cli_" + std::to_string(getpid())));
    fs::remove_all(*work_);
    fs::create_directories(*work_);
    const Outcome sim = run_cli({"simulate", "--seed", "3", "--out", (*work_ / "sim").string()}, *work_);
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
  }
  static void TearDownTestSuite() {
    fs::remove_all(*work_);
    delete work_;
  }
  /// An EKF run into `out`, which must succeed.
  static void run_ekf(const fs::path& out) {
    const Outcome r = run_cli({"run", "--filter", "ekf", "--data", data(), "--out", out.string()}, *work_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  static std::string data() { return "sim:" + (*work_ / "sim").string(); }
  static fs::path* work_;
};
fs::path* RunFolderCli::work_ = nullptr;

}  // namespace

// The probe's reproducer: a rerun with another filter fails after writing its first file; before,
// the folder held the UKF's trajectory beside the EKF's run.json, map and covariances (partial:
// false), and evaluate scored that mix with exit code 0.
TEST_F(RunFolderCli, ARerunThatFailsHalfWayLeavesThePreviousRunWhole) {
  const fs::path out = *work_ / "rerun";
  run_ekf(out);
  const auto before = contents(out);
  // Room for trajectory.tum, the first file written, but not for pose_covariance.txt, the second.
  const auto room = fs::file_size(out / "trajectory.tum") + 65536;
  ASSERT_GT(fs::file_size(out / "pose_covariance.txt"), room);

  const Outcome r = run_cli({"run", "--filter", "ukf", "--data", data(), "--out", out.string()}, *work_,
                            {.max_file_size = room});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("pose_covariance.txt: write failed"), std::string::npos) << r.err;
  EXPECT_TRUE(contents(out) == before) << "the previous run's files, every one as it was";
  EXPECT_EQ(entries_starting(*work_, "rerun"), std::vector<std::string>{"rerun"}) << "no staging folder, no lock";

  const Outcome e = run_cli({"evaluate", out.string()}, *work_);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const nlohmann::json scored = read_json(out / "metrics.json"), original = nlohmann::json::parse(before.at("metrics.json"));
  EXPECT_EQ(scored["filter"], "ekf");
  // The run's own numbers, up to the rounding of the files evaluate reads them from.
  EXPECT_NEAR(scored["ate_rmse_m"].get<double>(), original["ate_rmse_m"].get<double>(), 1e-9);
  EXPECT_NEAR(scored["map_rmse_m"].get<double>(), original["map_rmse_m"].get<double>(), 1e-9);
}

// A run killed with SIGKILL leaves its staging folder (with its AtomicFile temporaries) and its lock
// file; earlier versions left temporaries inside the folder itself. The next run into the folder
// removes them all, and nothing of another folder's writer beside it.
TEST_F(RunFolderCli, TheNextWriterClearsWhatAKilledRunLeft) {
  const fs::path out = *work_ / "killed";
  run_ekf(out);
  std::ofstream(out / "map.txt.partial-4000001") << "half a map";
  fs::create_directory(*work_ / "killed.partial-4000002");
  std::ofstream(*work_ / "killed.partial-4000002" / slamkit::kIncompleteMarker) << "slamkit process 4000002\n";
  std::ofstream(*work_ / "killed.partial-4000002" / "trajectory.tum.partial-4000002") << "half a trajectory";
  std::ofstream(*work_ / "killed.lock") << "4000002";
  fs::create_directory(*work_ / "killed-too.partial-4000003");  // another folder's: not this writer's to judge

  run_ekf(out);
  EXPECT_EQ(entries_starting(*work_, "killed."), std::vector<std::string>{}) << "staging folder and lock file gone";
  EXPECT_FALSE(fs::exists(out / "map.txt.partial-4000001"));
  EXPECT_TRUE(fs::exists(*work_ / "killed-too.partial-4000003"));

  std::ofstream(out / "metrics.json.partial-4000004") << "{";  // an evaluate killed while writing
  const Outcome e = run_cli({"evaluate", out.string()}, *work_);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_FALSE(fs::exists(out / "metrics.json.partial-4000004"));
}

// SIGTERM (a scheduler, kill) and SIGHUP (the terminal closed) stop a run like Ctrl-C: after the
// current step, with the partial result written and the shell's exit code for the signal. Before,
// only SIGINT was handled, and a signal blocked by the parent never reached the run.
TEST_F(RunFolderCli, StopSignalsWriteThePartialRunWithTheSignalsExitCode) {
  for (const auto& [signal, name] : {std::pair{SIGINT, "SIGINT"}, {SIGTERM, "SIGTERM"}, {SIGHUP, "SIGHUP"}}) {
    const fs::path out = *work_ / ("stopped-" + std::string(name));
    const Outcome r = run_cli({"run", "--filter", "ekf", "--data", data(), "--out", out.string()}, *work_,
                              {.pending_signal = signal});
    EXPECT_EQ(r.exit_code, 128 + signal) << name << ": " << r.err;
    EXPECT_NE(r.err.find(std::string("stopped by ") + name + ": writing the partial result"), std::string::npos)
        << r.err;
    const nlohmann::json info = read_json(out / "run.json");
    EXPECT_EQ(info["partial"], true) << name;
    EXPECT_EQ(info["steps"], 0) << name << ": the signal was pending, so the run stops before its first step";
    const Outcome e = run_cli({"evaluate", out.string()}, *work_);
    EXPECT_EQ(e.exit_code, 0) << name << ": " << e.err;
  }
  const fs::path help = *work_ / "help.txt";
  ASSERT_EQ(std::system((std::string(SLAMKIT_CLI) + " run --help > " + help.string()).c_str()), 0);
  EXPECT_NE(read_text(help).find("(130 Ctrl-C, 143 SIGTERM, 129 SIGHUP)"), std::string::npos);
}

// Two writers of one folder would interleave their files. The second, a run or an evaluate, fails at
// once naming the folder and the process that holds it, and leaves the folder as it was; when the
// holder ends, the folder is free.
TEST_F(RunFolderCli, ASecondWriterOfAFolderIsRefusedAtOnce) {
  const fs::path out = *work_ / "busy";
  run_ekf(out);
  const auto before = contents(out);
  {
    const slamkit::FolderLock holder(out.string());
    const std::string expected = out.string() + ": in use by slamkit process " + std::to_string(getpid());
    const Outcome r = run_cli({"run", "--filter", "ukf", "--data", data(), "--out", out.string()}, *work_);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    const Outcome e = run_cli({"evaluate", out.string()}, *work_);
    EXPECT_EQ(e.exit_code, 1);
    EXPECT_NE(e.err.find(expected), std::string::npos) << e.err;
    EXPECT_TRUE(contents(out) == before);
  }
  run_ekf(out);
}

// A run folder is replaced as a whole, so an existing folder that holds no run.json (`--out .` by
// mistake) is refused rather than replaced; an empty one is used.
TEST_F(RunFolderCli, AFolderThatIsNotARunIsNotReplaced) {
  const fs::path notes = *work_ / "notes";
  fs::create_directory(notes);
  std::ofstream(notes / "ideas.txt") << "keep me\n";
  const Outcome r = run_cli({"run", "--filter", "ekf", "--data", data(), "--out", notes.string()}, *work_);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("is not empty and holds no run.json"), std::string::npos) << r.err;
  EXPECT_EQ(read_text(notes / "ideas.txt"), "keep me\n");

  const fs::path empty = *work_ / "empty";
  fs::create_directory(empty);
  run_ekf(empty);
  EXPECT_TRUE(fs::exists(empty / "run.json"));
}
