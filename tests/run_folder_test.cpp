// Reading a run folder back: associations.txt lines that do not continue the current scan or start
// the next are errors naming the line (they used to be filed silently under the last scan); a run
// being written is readable only once complete, and replaces the previous one as a whole.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "slamkit/io/run_io.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

class RunFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("slamkit_run_folder_" + std::to_string(::getpid()));
    const Scenario s = scenario("default");
    const Dataset data = simulate(s.world, s.config);
    FilterConfig config;
    config.association.method = AssociationMethod::kNearestNeighbour;
    auto filter = make_filter(config, data);
    write_run(dir_.string(), run_filter(*filter, data));
    std::ifstream in(dir_ / "associations.txt");
    for (std::string line; std::getline(in, line);) lines_.push_back(line);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Rewrites associations.txt with `lines`; returns the path.
  std::string rewrite(const std::vector<std::string>& lines) const {
    const fs::path path = dir_ / "associations.txt";
    std::ofstream out(path);
    for (const std::string& line : lines) out << line << "\n";
    return path.string();
  }
  // The index of the first line of scan `k` (the file's own lines, comments included).
  std::size_t first_line_of_scan(int k) const {
    const std::string prefix = std::to_string(k) + " ";
    for (std::size_t i = 0; i < lines_.size(); ++i)
      if (lines_[i].rfind(prefix, 0) == 0) return i;
    ADD_FAILURE() << "no scan " << k;
    return 0;
  }

  fs::path dir_;
  std::vector<std::string> lines_;
};

TEST_F(RunFolder, RoundTripsTheAssociations) {
  const RunResult back = read_run(dir_.string());
  EXPECT_GT(back.associations.size(), 100u);
  EXPECT_EQ(back.associations.size(), back.scan_times.size());
}

TEST_F(RunFolder, ALineOfAnEarlierScanIsAnErrorNotFiledUnderTheLastOne) {
  std::vector<std::string> lines = lines_;
  const std::size_t at = first_line_of_scan(20);
  lines.insert(lines.begin() + static_cast<long>(at), lines[first_line_of_scan(5)]);  // scan 5 again, inside 20's
  const std::string path = rewrite(lines);
  const std::string message = test_data::input_error_at([&] { read_run(dir_.string()); }, path, at + 1);
  EXPECT_NE(message.find("expected scan"), std::string::npos) << message;
}

TEST_F(RunFolder, AScanWithTwoTimesIsAnError) {
  std::vector<std::string> lines = lines_;
  const std::size_t second = first_line_of_scan(30) + 1;  // the default world's scans see several landmarks
  ASSERT_EQ(lines[second].rfind("30 ", 0), 0u);
  std::istringstream fields(lines[second]);
  std::string scan, t, rest;
  fields >> scan >> t;
  std::getline(fields, rest);
  lines[second] = scan + " 9999.5" + rest;
  const std::string path = rewrite(lines);
  const std::string message = test_data::input_error_at([&] { read_run(dir_.string()); }, path, second + 1);
  EXPECT_NE(message.find("has time 9999.5 here"), std::string::npos) << message;
}

// Counts too large for any integer, fractional or negative are errors naming the key: converting
// such a number to an integer type unchecked is undefined behaviour (a fuzzer's "scans": 2.2e25).
TEST_F(RunFolder, ACountThatIsNotANonNegativeIntegerIsAnError) {
  const std::string path = (dir_ / "run.json").string();
  std::ifstream in(path);
  const std::string original((std::istreambuf_iterator<char>(in)), {});
  in.close();
  const std::string key = "\"scans\": ";
  const std::size_t at = original.find(key);
  ASSERT_NE(at, std::string::npos);
  const std::size_t end = original.find_first_of(",\n", at);
  for (const std::string bad : {"2.2222e25", "-3", "4.5", "\"7\""}) {
    std::ofstream(path) << original.substr(0, at + key.size()) << bad << original.substr(end);
    const std::string message = test_data::input_error_at([&] { read_run(dir_.string()); }, path, 0);
    EXPECT_NE(message.find("expected 'scans' to be a count"), std::string::npos) << bad << ": " << message;
  }
  std::ofstream(path) << original;
  EXPECT_NO_THROW(read_run(dir_.string()));
}

// While a run is written, the folder still holds the previous run and the staging folder is
// refused by every reader (evaluate, plot-nees, Python through read_run).
TEST_F(RunFolder, ARunBeingWrittenIsReadableOnlyOnceComplete) {
  const RunResult run = read_run(dir_.string());
  AtomicFolder next = stage_run_folder(dir_.string());
  write_run_files(next.path(), run);
  const std::string message = test_data::input_error_at([&] { read_run(next.path()); }, next.path(), 0);
  EXPECT_NE(message.find("an incomplete folder"), std::string::npos) << message;
  EXPECT_NO_THROW(read_run(dir_.string()));
  next.commit();
  EXPECT_EQ(read_run(dir_.string()).associations.size(), run.associations.size());
}

// A file only some runs have (FastSLAM's particles.txt) does not outlive its run.
TEST_F(RunFolder, ARunReplacesThePreviousOneAsAWhole) {
  const RunResult run = read_run(dir_.string());
  RunResult with_particles = run;
  with_particles.particles = {ParticleSample{0.0, WeightedPose{Pose2(1.0, 2.0, 0.5), 1.0}}};
  write_run(dir_.string(), with_particles);
  EXPECT_EQ(read_run(dir_.string()).particles.size(), 1u);
  write_run(dir_.string(), run);
  EXPECT_FALSE(fs::exists(dir_ / "particles.txt"));
  EXPECT_TRUE(read_run(dir_.string()).particles.empty());
}

}  // namespace
}  // namespace slamkit
