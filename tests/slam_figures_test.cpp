// The SLAM pictures drawn on the SVG figure: the map's legend and aspect, and the landmark
// uncertainty plot's lines, colours and legend.
#include "slamkit/plot/svg_plot.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "svg_test_support.hpp"

using namespace slamkit;
using namespace slamkit::plot;
using namespace slamkit::plot::test_svg;

TEST(SvgPlotSlam, MapLeavesEmptySeriesOutOfTheLegend) {
  MapPlotData m = sample_map();
  m.dead_reckoning.clear();
  m.reference_points = {{kNaN, kNaN}};  // nothing drawable is as good as empty
  for (Landmark& l : m.estimated_landmarks) l.covariance.setZero();
  const std::string svg = map_figure(m).to_svg();
  EXPECT_EQ(svg.find("dead reckoning"), std::string::npos);
  EXPECT_EQ(svg.find("reference fixes"), std::string::npos);
  EXPECT_EQ(svg.find("covariance"), std::string::npos) << "no ellipse was drawn";
  EXPECT_NE(svg.find(">estimated landmarks<"), std::string::npos);
  EXPECT_NE(svg.find(">true trajectory<"), std::string::npos);
}

TEST(SvgPlotSlam, MapIsEqualAspectWithLegendOutsideThePlotArea) {
  const Figure fig = map_figure(sample_map());
  const Frame f = fig.frame();
  EXPECT_NEAR(f.plot_width / (f.x_max - f.x_min), f.plot_height / (f.y_max - f.y_min), 1e-9);
  const std::string svg = fig.to_svg();
  const std::size_t legend = svg.find("rx=\"3\"");  // the legend box
  ASSERT_NE(legend, std::string::npos);
  const std::size_t rect = svg.rfind("<rect x=\"", legend);
  const double legend_x = std::stod(svg.substr(rect + 9));
  EXPECT_GT(legend_x, f.left + f.plot_width);
}

// A landmark 1e300 m out (an estimate run off, or a truth no reader would now accept) wrote tick
// labels of 300 digits, too wide for the figure: "leaves no room to plot" ended a run after the
// filter had finished. Large values and steps far below them get a shared power of ten instead.
TEST(SvgPlotSlam, FarOffPointsGetShortTickLabels) {
  for (const double far : {1e300, -3.5e12, 2e7}) {
    MapPlotData m = sample_map();
    m.true_landmarks.push_back(Landmark{99, Vector2(far, far), Matrix2::Zero()});
    const Figure fig = map_figure(m);
    const std::string svg = fig.to_svg();
    EXPECT_EQ(xml_error(svg), "") << far;
    EXPECT_LT(fig.frame().left, 150.0) << far << ": the y tick labels took the plot's room";
    EXPECT_EQ(svg.find("0000000000"), std::string::npos) << far << ": a label with ten zeros";
    // Eight digits are still written out.
    EXPECT_EQ(svg.find("\u00D710") == std::string::npos, far == 2e7) << far;
  }
}

TEST(SvgPlotSlam, ManyLandmarksAreExplainedByStyleNotListed) {
  const std::string svg = landmark_std_figure(sample_std(150)).to_svg();
  EXPECT_EQ(xml_error(svg), "");
  EXPECT_EQ(svg.find(">landmark 17<"), std::string::npos);
  EXPECT_NE(svg.find(">one line per landmark<"), std::string::npos);
  EXPECT_NE(svg.find(">landmark id<"), std::string::npos);
  EXPECT_NE(svg.find("linearGradient"), std::string::npos);
  // One path per landmark, coloured from the start to the end of the sequential palette.
  EXPECT_GE(count(svg, "<path d=\"M"), 150u);
  EXPECT_NE(svg.find(sequential_color(0).hex()), std::string::npos);
  EXPECT_NE(svg.find(sequential_color(1).hex()), std::string::npos);
}

TEST(SvgPlotSlam, StdPlotDrawsTheLargerDeviationOnALogAxis) {
  StdPlotData d;
  d.series.push_back({4, {0, 1, 2}, {1.0, 0.1, 0.01}, {0.5, 0.5, 0.001}});
  const Figure fig = landmark_std_figure(d);
  const Frame f = fig.frame();
  EXPECT_TRUE(f.log_y);
  EXPECT_LT(f.y_min, 0.01);
  EXPECT_GT(f.y_min, 0.005);
  EXPECT_GT(f.y_max, 1.0);
  const std::string svg = fig.to_svg();
  const auto pieces =
      parse_polyline_path(paths_in_group(svg, "stroke=\"" + categorical_color(0).hex()).at(0));
  ASSERT_EQ(pieces.size(), 1u);
  ASSERT_EQ(pieces[0].size(), 3u);
  EXPECT_NEAR(f.to_data(pieces[0][1]).y(), 0.5, 0.01);  // max(0.1, 0.5)
  EXPECT_NEAR(f.to_data(pieces[0][2]).y(), 0.01, 0.001);

  d.log_y = false;
  EXPECT_FALSE(landmark_std_figure(d).frame().log_y);
}

TEST(SvgPlotSlam, StdSeriesOfMismatchedLengthsThrow) {
  StdPlotData d;
  d.series.push_back({1, {0, 1}, {1, 2}, {1}});
  EXPECT_THROW(landmark_std_figure(d), std::invalid_argument);
}

// A laser's no-returns through a window or a door reach far beyond the walls; framing the whole
// grid would leave the building a speck in the middle of the picture.
TEST(SvgPlotSlam, AGridMapIsFramedOnItsWallsAndPaths) {
  MapPlotData m;
  m.grid_png = "png";
  m.grid_lower_left = Vector2(-50.0, -50.0);
  m.grid_size = Vector2(100.0, 100.0);
  m.estimated_trajectory = {Vector2(0.0, 0.0), Vector2(6.0, 1.0)};
  const Frame whole = map_figure(m).frame();
  EXPECT_LE(whole.x_min, -50.0) << "without a focus the whole grid is shown";
  m.grid_focus_min = Vector2(-5.0, -4.0);
  m.grid_focus_max = Vector2(5.0, 4.0);
  const Frame framed = map_figure(m).frame();
  EXPECT_LE(framed.x_min, -5.0);
  EXPECT_GE(framed.x_max, 6.0) << "the trajectory is inside";
  EXPECT_GT(framed.x_min, -8.0);
  EXPECT_LT(framed.x_max, 9.0);
  EXPECT_LE(framed.y_min, -4.0);
  EXPECT_GE(framed.y_max, 4.0);
}
