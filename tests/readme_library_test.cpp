// The README's library example as a test: the code between the README markers below is the
// README's snippet line for line (checked here against README.md), run on a simulated log with a
// forward-looking sensor, where leaving out the sensor limits would remove the landmarks behind
// the vehicle.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"

namespace fs = std::filesystem;

namespace {

// README:begin
slamkit::RunResult readme_example() {
  slamkit::Dataset data = slamkit::load_dataset("sim:out/demo/sim");
  slamkit::EkfSlamOptions options;
  options.initial_pose = data.initial_pose;
  options.sensor = data.sensor;  // which landmarks are in view; else they count as missed when out of view
  options.association.method = slamkit::AssociationMethod::kNearestNeighbour;  // as --assoc nn
  slamkit::EkfSlam ekf(data.motion, data.observation, options);
  slamkit::RunResult run = slamkit::run_filter(ekf, data);
  return run;
}
// README:end

std::vector<std::string> lines_of(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::string trimmed(const std::string& s) {
  const auto first = s.find_first_not_of(' ');
  return first == std::string::npos ? "" : s.substr(first);
}

/// Runs the test in a folder of its own holding out/demo/sim, the log the README names: the
/// default world seen by a sensor that looks forward only.
class ReadmeLibrary : public ::testing::Test {
 protected:
  void SetUp() override {
    slamkit::Scenario s = slamkit::scenario("default");
    s.config.fov = slamkit::deg2rad(180.0);
    s.config.loops = 1;
    slamkit::write_sim_log(scratch_.file("out/demo/sim"), slamkit::simulate(s.world, s.config), s.config, s.world);
    previous_ = fs::current_path();
    fs::current_path(scratch_.path());
  }
  void TearDown() override { fs::current_path(previous_); }

  slamkit::test_data::ScratchDir scratch_;
  fs::path previous_;
};

}  // namespace

TEST(ReadmeLibraryText, TheExampleIsTheReadmesSnippet) {
  const std::vector<std::string> readme = lines_of(fs::path(SLAMKIT_SOURCE_DIR) / "README.md");
  auto line = std::find(readme.begin(), readme.end(), "## Library");
  ASSERT_NE(line, readme.end());
  line = std::find(line, readme.end(), "```cpp");
  ASSERT_NE(line, readme.end());
  std::vector<std::string> includes, code;
  for (++line; line != readme.end() && *line != "```"; ++line) {
    if (line->starts_with("#include")) includes.push_back(*line);
    else if (!line->empty()) code.push_back(*line);
  }

  const std::vector<std::string> test = lines_of(fs::path(SLAMKIT_SOURCE_DIR) / "tests" / "readme_library_test.cpp");
  for (const std::string& include : includes)
    EXPECT_NE(std::find(test.begin(), test.end(), include), test.end()) << include;
  const auto begin = std::find(test.begin(), test.end(), "// README:begin");
  const auto end = std::find(test.begin(), test.end(), "// README:end");
  ASSERT_LT(begin, end);
  // The lines of the function around the snippet: its signature, return and closing brace.
  std::vector<std::string> body;
  for (auto l = begin + 2; l < end - 2; ++l) body.push_back(trimmed(*l));
  EXPECT_EQ(body, code);
}

TEST_F(ReadmeLibrary, TheExampleRunsAsTheCommandLineDoes) {
  const slamkit::RunResult run = readme_example();
  // What `slamkit run --filter ekf --assoc nn` builds for the same data.
  const slamkit::Dataset data = slamkit::load_dataset("sim:out/demo/sim");
  slamkit::FilterConfig config;
  config.association.method = slamkit::AssociationMethod::kNearestNeighbour;
  const auto cli_filter = slamkit::make_filter(config, data);
  const slamkit::RunResult cli = slamkit::run_filter(*cli_filter, data);

  ASSERT_EQ(run.map.size(), cli.map.size());
  for (std::size_t i = 0; i < run.map.size(); ++i) {
    EXPECT_EQ(run.map[i].id, cli.map[i].id);
    EXPECT_EQ(run.map[i].position, cli.map[i].position);
  }
  ASSERT_EQ(run.trajectory.size(), cli.trajectory.size());
  EXPECT_EQ(run.trajectory.back().pose, cli.trajectory.back().pose);
}

TEST_F(ReadmeLibrary, WithoutTheSensorLimitsLandmarksOutOfViewWouldBeRemoved) {
  const slamkit::RunResult run = readme_example();
  const slamkit::Dataset data = slamkit::load_dataset("sim:out/demo/sim");
  slamkit::EkfSlamOptions options;
  options.initial_pose = data.initial_pose;
  options.association.method = slamkit::AssociationMethod::kNearestNeighbour;
  slamkit::EkfSlam ekf(data.motion, data.observation, options);
  const slamkit::RunResult without = slamkit::run_filter(ekf, data);
  // With the limits no confirmed landmark is removed (one seen twice at the edge of the view and
  // never confirmed is); without them a 360 degree view is assumed, and each landmark behind the
  // vehicle counts as missed scan after scan (101 removals).
  EXPECT_LE(run.statistics.at("landmarks_removed"), 1.0);
  EXPECT_EQ(run.map.size(), 100U);
  EXPECT_GT(without.statistics.at("landmarks_removed"), 50.0);
}
