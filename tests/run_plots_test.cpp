// The pictures of a run (plot/report.hpp): pose_error.svg's heading panel, wrapped and in degrees
// with its 2-sigma band, under the position panel; nees.svg and metrics.json saying what a particle
// filter's NEES is of and that it is no consistency test.
#include "slamkit/plot/report.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "svg_test_support.hpp"
#include "test_data.hpp"

using slamkit::test_data::read_text;

namespace slamkit {
namespace {

namespace fs = std::filesystem;

/// The numbers of the y tick labels (right-aligned text) in `svg` from `from` on.
std::vector<double> y_tick_labels(const std::string& svg, std::size_t from) {
  std::vector<double> out;
  const std::string anchor = "text-anchor=\"end\">";
  for (std::size_t at = svg.find(anchor, from); at != std::string::npos; at = svg.find(anchor, at + 1)) {
    std::string label = svg.substr(at + anchor.size(), svg.find('<', at) - at - anchor.size());
    if (label.rfind("\u2212", 0) == 0) label.replace(0, std::string("\u2212").size(), "-");
    out.push_back(std::stod(label));
  }
  return out;
}

class RunPlots : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("slamkit_run_plots_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // A straight drive whose heading sits on the +-pi seam: the estimate's heading is pi - 0.01,
    // the truth's -pi + 0.01, an error of -0.02 rad (-1.15 degrees) once wrapped, 2 pi - 0.02 if not;
    // its 2-sigma band is +-0.04 rad (+-2.29 degrees).
    for (int i = 0; i <= 200; ++i) {
      const double t = 0.1 * i;
      truth_.poses.push_back({t, Pose2(t, 0.5, -std::numbers::pi + 0.01)});
      run_.filtered.push_back({t, Pose2(t + 0.05, 0.48, std::numbers::pi - 0.01)});
      run_.pose_covariances.push_back(Eigen::Vector3d(0.01, 0.01, 4e-4).asDiagonal());
    }
    run_.trajectory = run_.dead_reckoning = run_.filtered;
    run_.dataset = "test";
  }
  void TearDown() override { fs::remove_all(dir_); }

  Metrics plots_of(const std::string& filter) {
    run_.filter = filter;
    const Metrics metrics = evaluate_run(run_, truth_);
    write_run_plots(dir_.string(), run_, truth_, metrics);
    return metrics;
  }

  fs::path dir_;
  RunResult run_;
  GroundTruth truth_;
};

TEST_F(RunPlots, PoseErrorHasAHeadingPanelWrappedInDegreesWithItsBand) {
  plots_of("ekf");
  const std::string svg = read_text(dir_ / "pose_error.svg");
  EXPECT_EQ(plot::test_svg::xml_error(svg), "");
  for (const char* text : {">position error [m]<", ">x error<", ">y error<", ">x: +-2 sigma<", ">heading error [deg]<",
                           ">heading error<", ">heading: +-2 sigma<", ">time [s]<"})
    EXPECT_NE(svg.find(text), std::string::npos) << text;
  // The heading panel's axis spans the wrapped error and its band (within +-3 degrees), not the
  // 358 degrees of an unwrapped one.
  const std::size_t heading_panel = svg.rfind("<g transform=\"translate(0 ");
  ASSERT_NE(heading_panel, std::string::npos);
  ASSERT_GT(heading_panel, svg.find(">position error [m]<"));
  const std::vector<double> labels = y_tick_labels(svg, heading_panel);
  ASSERT_GE(labels.size(), 3u);
  EXPECT_LE(*std::max_element(labels.begin(), labels.end()), 3.0);
  EXPECT_GE(*std::min_element(labels.begin(), labels.end()), -3.0);
}

TEST_F(RunPlots, FastSlamsNeesSaysItIsTheParticleCloudsAndNoConsistencyTest) {
  const Metrics fastslam = plots_of("fastslam2");
  ASSERT_TRUE(fastslam.nees_pose.has_value());
  const std::string svg = read_text(dir_ / "nees.svg");
  EXPECT_EQ(plot::test_svg::xml_error(svg), "");
  for (const char* text : {"For FastSLAM 2.0 this is the NEES of the particle cloud", "no consistency test",
                           "resampling", "judge accuracy by ate_rmse_m"})
    EXPECT_NE(svg.find(text), std::string::npos) << text;
  // Whatever the run kept: a run without full history has no smoothed trajectory.
  EXPECT_FALSE(fastslam.smoothed);
  EXPECT_EQ(to_json(fastslam).at("nees_pose_note"), std::string(kParticleCloudNeesNote));

  const Metrics ekf = plots_of("ekf");
  EXPECT_EQ(read_text(dir_ / "nees.svg").find("particle cloud"), std::string::npos);
  EXPECT_FALSE(to_json(ekf).contains("nees_pose_note"));
}

}  // namespace
}  // namespace slamkit
