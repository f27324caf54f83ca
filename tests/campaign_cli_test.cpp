// `slamkit campaign` and `slamkit report` as a user runs them: a campaign killed (SIGKILL) half-way
// and run again ends with every job once and the report of an uninterrupted one; under mpirun it
// gives the same report as on one process; a malformed spec is an error naming the key.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sanitizers.hpp"
#include "test_data.hpp"

using nlohmann::json;
using slamkit::test_data::read_json;
using slamkit::test_data::read_text;
using slamkit::test_data::write_text;

namespace fs = std::filesystem;

namespace {

constexpr const char* kSpec = R"({
  "name": "resume",
  "outputs": "folder",
  "datasets": [{"name": "default", "spec": "scenario:default", "seeds": {"from": 1, "count": 4},
                "settings": {"loops": 1}}],
  "filters": [{"name": "ekf"}, {"name": "fej", "settings": {"ekf_variant": "fej"}}]
})";

/// Starts `program` with `args`, stdout and stderr into `log`; returns its pid.
pid_t start(const std::string& program, const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> words = {program};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& word : words) argv.push_back(word.data());
  argv.push_back(nullptr);
  const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  const pid_t pid = ::fork();
  if (pid == 0) {  // only async-signal-safe calls until exec
    ::dup2(out, STDOUT_FILENO);
    ::dup2(out, STDERR_FILENO);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(out);
  return pid;
}

int wait_for(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int run(const std::string& program, const std::vector<std::string>& args, const fs::path& log) {
  return wait_for(start(program, args, log));
}

/// summary.csv without the timing rows, which differ from run to run.
std::string summary_without_times(const fs::path& report) {
  std::istringstream in(read_text(report / "summary.csv"));
  std::string kept;
  for (std::string line; std::getline(in, line);)
    if (line.find("wall_time_s") == std::string::npos) kept += line + "\n";
  return kept;
}

/// The job folders under a campaign's runs/, and anything else found there (staging folders).
std::multiset<std::string> run_folders(const fs::path& campaign) {
  std::multiset<std::string> folders;
  for (const auto& configuration : fs::directory_iterator(campaign / "runs"))
    for (const auto& run : fs::directory_iterator(configuration))
      folders.insert((configuration.path().filename() / run.path().filename()).string());
  return folders;
}

class CampaignCli : public ::testing::Test {
 protected:
  void SetUp() override {
    work_ = fs::temp_directory_path() / ("slamkit_campaign_cli_" + std::to_string(getpid()));
    fs::remove_all(work_);
    fs::create_directories(work_);
    write_text(work_ / "resume.json", kSpec);
  }
  void TearDown() override { fs::remove_all(work_); }
  std::vector<std::string> campaign(const fs::path& out, std::vector<std::string> more = {}) const {
    std::vector<std::string> args = {"campaign", (work_ / "resume.json").string(), "--out", out.string()};
    args.insert(args.end(), more.begin(), more.end());
    return args;
  }
  fs::path work_;
};

TEST_F(CampaignCli, AKilledCampaignRunAgainHasEveryJobOnceAndTheSameReport) {
  ASSERT_EQ(run(SLAMKIT_CLI, campaign(work_ / "whole"), work_ / "whole.log"), 0) << read_text(work_ / "whole.log");

  const fs::path killed = work_ / "killed";
  const pid_t pid = start(SLAMKIT_CLI, campaign(killed, {"--jobs", "1"}), work_ / "killed.log");
  // Killed once the first job's folder is whole, while later ones run.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(killed / "runs" / "ekf__default" / "seed-1" / "metrics.json") &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ::kill(pid, SIGKILL);
  wait_for(pid);
  ASSERT_FALSE(fs::exists(killed / "report")) << "killed before the end";

  ASSERT_EQ(run(SLAMKIT_CLI, campaign(killed), work_ / "rerun.log"), 0) << read_text(work_ / "rerun.log");
  const std::string rerun = read_text(work_ / "rerun.log");
  EXPECT_NE(rerun.find("already done"), std::string::npos) << rerun;
  EXPECT_EQ(run_folders(killed), run_folders(work_ / "whole"));
  EXPECT_EQ(run_folders(killed).size(), 8u);
  EXPECT_EQ(summary_without_times(killed / "report"), summary_without_times(work_ / "whole" / "report"));
  EXPECT_EQ(read_json(killed / "report" / "report.json").at("runs").size(), 8u);
}

TEST_F(CampaignCli, UnderMpiTheReportIsTheLocalOne) {
  const std::string mpiexec = SLAMKIT_MPIEXEC;
  if (mpiexec.empty()) GTEST_SKIP() << "slamkit was built without MPI (Debian's libopenmpi-dev)";
#if defined(SLAMKIT_ADDRESS_SANITIZER) || defined(SLAMKIT_THREAD_SANITIZER)
  GTEST_SKIP() << "Open MPI's own allocations are not the sanitizers' business";
#endif
  ASSERT_EQ(run(SLAMKIT_CLI, campaign(work_ / "local"), work_ / "local.log"), 0) << read_text(work_ / "local.log");
  // Root may run mpirun only when told twice; two ranks on one host whatever its cores.
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  std::vector<std::string> args = {"-n", "2", "--oversubscribe", SLAMKIT_CLI};
  for (const std::string& word : campaign(work_ / "mpi")) args.push_back(word);
  ASSERT_EQ(run(mpiexec, args, work_ / "mpi.log"), 0) << read_text(work_ / "mpi.log");
  EXPECT_NE(read_text(work_ / "mpi.log").find("2 MPI ranks"), std::string::npos) << read_text(work_ / "mpi.log");
  EXPECT_EQ(run_folders(work_ / "mpi"), run_folders(work_ / "local"));
  EXPECT_EQ(summary_without_times(work_ / "mpi" / "report"), summary_without_times(work_ / "local" / "report"));
}

TEST_F(CampaignCli, AMalformedSpecIsAnErrorNamingTheKey) {
  write_text(work_ / "bad.json", R"({"datasets": [{"spec": "scenario:default", "seeds": [1]}],
                                     "filters": [{"settings": {"filter": "ekf"}, "vary": {"particles": 5}}]})");
  EXPECT_EQ(
      run(SLAMKIT_CLI, {"campaign", (work_ / "bad.json").string(), "--out", (work_ / "x").string()}, work_ / "bad.log"),
      1);
  const std::string log = read_text(work_ / "bad.log");
  EXPECT_NE(log.find("bad.json: filters[0].vary.particles: expected a non-empty list of values"), std::string::npos)
      << log;
  EXPECT_FALSE(fs::exists(work_ / "x")) << "nothing is written for a spec that is refused";
}

TEST_F(CampaignCli, ADryRunListsTheConfigurations) {
  ASSERT_EQ(run(SLAMKIT_CLI, campaign(work_ / "dry", {"--dry-run"}), work_ / "dry.log"), 0);
  const std::string log = read_text(work_ / "dry.log");
  EXPECT_NE(log.find("campaign resume: 8 jobs"), std::string::npos) << log;
  EXPECT_NE(log.find("fej | default"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(work_ / "dry"));
}

TEST_F(CampaignCli, AReportSummarisesTheMetricsAskedFor) {
  ASSERT_EQ(run(SLAMKIT_CLI, campaign(work_ / "c", {"--no-report"}), work_ / "c.log"), 0) << read_text(work_ / "c.log");
  EXPECT_FALSE(fs::exists(work_ / "c" / "report"));
  const std::string runs = (work_ / "c" / "runs").string();
  ASSERT_EQ(run(SLAMKIT_CLI,
                {"report", runs, "--out", (work_ / "r").string(), "--no-nees", "--metrics",
                 "ate_rmse_m,association_wrong"},
                work_ / "r.log"),
            0)
      << read_text(work_ / "r.log");
  std::set<std::string> metrics;
  std::istringstream summary(read_text(work_ / "r" / "summary.csv"));
  std::string line;
  std::getline(summary, line);  // the header
  while (std::getline(summary, line)) {
    const std::size_t first = line.find(','), second = line.find(',', first + 1);
    metrics.insert(line.substr(first + 1, second - first - 1));
  }
  EXPECT_EQ(metrics, (std::set<std::string>{"ate_rmse_m", "association_wrong"}));
  EXPECT_EQ(run(SLAMKIT_CLI, {"report", runs, "--out", (work_ / "s").string(), "--metrics", "ate_rmse"}, work_ / "s.log"),
            2);
  EXPECT_NE(read_text(work_ / "s.log").find("unknown metric 'ate_rmse' (did you mean 'ate_rmse_m'?)"),
            std::string::npos)
      << read_text(work_ / "s.log");
}

TEST_F(CampaignCli, TablesOfASpecAreWrittenAndReplaceThoseOfADocument) {
  json spec = json::parse(kSpec);
  const json table_spec = {{"name", "ate"},
                           {"cell", "{ate_rmse_m.n} runs, loops {loop_closed.yes}/{n}"},
                           {"rows", json::array({"fej", {{"key", "ekf"}, {"label", "EKF"}}})}};
  spec["tables"] = json::array({table_spec});
  write_text(work_ / "tables.json", spec.dump());
  ASSERT_EQ(run(SLAMKIT_CLI, {"campaign", (work_ / "tables.json").string(), "--out", (work_ / "c").string()},
                work_ / "c.log"),
            0)
      << read_text(work_ / "c.log");
  const std::string table = "| filter | default |\n|---|---|\n| fej | 4 runs, loops 4/4 |\n| EKF | 4 runs, loops 4/4 |\n";
  EXPECT_EQ(read_text(work_ / "c" / "report" / "tables.md"), "## ate\n\n" + table + "\n");

  const fs::path document = work_ / "doc.md";
  write_text(document, "intro\n<!-- slamkit report table: ate -->\nold\n<!-- end slamkit report table -->\nend\n");
  const std::vector<std::string> report = {"report", (work_ / "c" / "runs").string(), "--out", (work_ / "r").string(),
                                           "--no-nees", "--tables", (work_ / "tables.json").string(),
                                           "--into", document.string()};
  ASSERT_EQ(run(SLAMKIT_CLI, report, work_ / "r.log"), 0) << read_text(work_ / "r.log");
  EXPECT_EQ(read_text(document), "intro\n<!-- slamkit report table: ate -->\n\n" + table +
                                     "\n<!-- end slamkit report table -->\nend\n");

  // A document without the table's marker is left as it was, and so is the report folder.
  write_text(document, "no markers\n");
  write_text(work_ / "r" / "mark", "");
  EXPECT_EQ(run(SLAMKIT_CLI, report, work_ / "bad.log"), 1);
  EXPECT_TRUE(fs::exists(work_ / "r" / "mark")) << "the earlier report was replaced";
  EXPECT_NE(read_text(work_ / "bad.log").find("no marker '<!-- slamkit report table: ate -->'"), std::string::npos)
      << read_text(work_ / "bad.log");
  EXPECT_EQ(read_text(document), "no markers\n");
  std::vector<std::string> without_tables = report;
  without_tables.erase(without_tables.end() - 4, without_tables.end() - 2);  // --tables FILE
  EXPECT_EQ(run(SLAMKIT_CLI, without_tables, work_ / "usage.log"), 2);
  EXPECT_NE(read_text(work_ / "usage.log").find("--into needs --tables"), std::string::npos) << read_text(work_ / "usage.log");

  // A campaign whose every run of a table's row failed still writes its report, with a warning.
  json failing = spec;
  failing["filters"][1] = {{"name", "grid"}, {"settings", {{"filter", "scan-matching"}}}};
  failing["tables"][0]["rows"][0] = "grid";
  write_text(work_ / "failing.json", failing.dump());
  EXPECT_EQ(run(SLAMKIT_CLI, {"campaign", (work_ / "failing.json").string(), "--out", (work_ / "f").string()},
                work_ / "f.log"),
            1);
  EXPECT_NE(read_text(work_ / "f.log").find("warning: table 'ate' left out: "),
            std::string::npos)
      << read_text(work_ / "f.log");
  EXPECT_NE(read_text(work_ / "f.log").find("failing.json: tables[0].rows[0]: no run of the filter entry 'grid'"),
            std::string::npos)
      << read_text(work_ / "f.log");
  EXPECT_TRUE(fs::exists(work_ / "f" / "report" / "report.md"));
  EXPECT_FALSE(fs::exists(work_ / "f" / "report" / "tables.md"));

  // A table naming an entry the campaign does not have is refused with the spec, before any run.
  spec["tables"][0]["rows"][0] = "fejj";
  write_text(work_ / "typo.json", spec.dump());
  EXPECT_EQ(run(SLAMKIT_CLI, {"campaign", (work_ / "typo.json").string(), "--out", (work_ / "t").string()},
                work_ / "typo.log"),
            1);
  EXPECT_NE(read_text(work_ / "typo.log").find("typo.json: tables[0].rows[0]: unknown filter entry 'fejj' (did you mean 'fej'?)"),
            std::string::npos)
      << read_text(work_ / "typo.log");
  EXPECT_FALSE(fs::exists(work_ / "t"));
}

// The README's tables of real data are what campaigns/readme.json and `slamkit report --into` give:
// regenerated from the campaign, README.md does not change. (The world-family table, 200 runs, is
// the same campaign's; `make readme-tables` regenerates all three.)
TEST_F(CampaignCli, TheReadmesRealDataTablesAreTheReportOfItsCampaign) {
#if defined(SLAMKIT_ADDRESS_SANITIZER) || defined(SLAMKIT_THREAD_SANITIZER)
  GTEST_SKIP() << "the README's figures are the release build's, which a sanitized build need not give to the digit";
#endif
  SLAMKIT_REQUIRE_DATASET(slamkit::test_data::shared_dataset("victoria_park"));
  SLAMKIT_REQUIRE_DATASET(slamkit::test_data::shared_dataset("mrclam/MRCLAM_Dataset6"));
  const fs::path source = SLAMKIT_SOURCE_DIR;
  json spec = read_json(source / "campaigns" / "readme.json");
  json real_groups = json::array(), real_tables = json::array();
  for (const json& group : spec["groups"])
    if (!group["datasets"][0]["spec"].get<std::string>().starts_with("family:")) real_groups.push_back(group);
  for (const json& table : spec["tables"])
    if (table["name"] != "world-families") real_tables.push_back(table);
  ASSERT_EQ(real_groups.size(), 2u);
  ASSERT_EQ(real_tables.size(), 2u);
  spec["groups"] = real_groups;
  spec["tables"] = real_tables;
  write_text(work_ / "readme.json", spec.dump());
  const slamkit::test_data::ScopedEnvironment data("SLAMKIT_DATA", slamkit::test_data::shared_dataset("").string());
  ASSERT_EQ(run(SLAMKIT_CLI, {"campaign", (work_ / "readme.json").string(), "--out", (work_ / "c").string(),
                              "--no-report", "--quiet"},
                work_ / "c.log"),
            0)
      << read_text(work_ / "c.log");
  const std::string readme = read_text(source / "README.md");
  write_text(work_ / "README.md", readme);
  ASSERT_EQ(run(SLAMKIT_CLI,
                {"report", (work_ / "c" / "runs").string(), "--out", (work_ / "r").string(), "--no-nees", "--tables",
                 (work_ / "readme.json").string(), "--into", (work_ / "README.md").string()},
                work_ / "r.log"),
            0)
      << read_text(work_ / "r.log");
  EXPECT_EQ(read_text(work_ / "README.md"), readme)
      << "README.md's tables differ from its campaign's; `make readme-tables` regenerates them:\n"
      << read_text(work_ / "r" / "tables.md");
}

}  // namespace
