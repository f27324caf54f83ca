// The NEES-over-time pictures: one run's, and the Monte Carlo mean over runs with its band.
#include <gtest/gtest.h>

#include <filesystem>

#include "slamkit/plot/report.hpp"
#include "slamkit/plot/svg_plot.hpp"
#include "test_data.hpp"

using slamkit::test_data::read_text;

using namespace slamkit;

namespace {

Metrics run_with(std::vector<Vector2> series) {
  Metrics m;
  m.nees_pose_series = std::move(series);
  return m;
}

}  // namespace

TEST(MonteCarloNees, AveragesTheStepTimesAllRunsShareAndCountsThemAgainstTheMeanBand) {
  const auto path = std::filesystem::temp_directory_path() / "slamkit_nees_plot_test.svg";
  // Run 2 has no NEES at t = 0.1 (a start pose known exactly) and one step more at the end: only
  // t = 0.2 and 0.3 are averaged, to (3 + 5) / 2 = 4 and (2 + 2) / 2 = 2, both inside the 2-run band.
  write_monte_carlo_nees(path.string(),
                         {run_with({{0.1, 1e6}, {0.2, 3.0}, {0.3, 2.0}}), run_with({{0.2, 5.0}, {0.3, 2.0}, {0.4, 7.0}})},
                         "test");
  const std::string svg = read_text(path);
  EXPECT_NE(svg.find("2 runs: mean NEES 3.00, 100% of steps inside the 95% interval of the 2-run mean"),
            std::string::npos);
  std::filesystem::remove(path);
}

TEST(MonteCarloNees, RejectsRunsWithoutNeesOrWithoutACommonStep) {
  const std::string path = (std::filesystem::temp_directory_path() / "slamkit_nees_plot_unused.svg").string();
  EXPECT_THROW(write_monte_carlo_nees(path, {}, "t"), std::invalid_argument);
  EXPECT_THROW(write_monte_carlo_nees(path, {run_with({{0.1, 2.0}}), run_with({})}, "t"), std::invalid_argument);
  EXPECT_THROW(write_monte_carlo_nees(path, {run_with({{0.1, 2.0}}), run_with({{0.2, 2.0}})}, "t"),
               std::invalid_argument);
}

TEST(NeesFigure, DrawsTheBandAndRejectsAnEmptyBand) {
  plot::NeesPlotData data;
  data.nees = {{0.0, 2.0}, {1.0, 4.0}};
  data.band_lo = 0.216;
  data.band_hi = 9.35;
  const std::string svg = plot::nees_figure(data).to_svg();
  EXPECT_NE(svg.find("95% interval"), std::string::npos);
  EXPECT_NE(svg.find("pose NEES"), std::string::npos);
  data.band_hi = data.band_lo;
  EXPECT_THROW(plot::nees_figure(data), std::invalid_argument);
}
