// SVG figures: well-formed XML with escaped text, geometry that can be measured back from the
// output (ellipse axes, equal aspect, log spacing), no non-finite numbers, compact paths, files and
// palettes. Ticks: svg_axes_test.cpp; the SLAM pictures: slam_figures_test.cpp.
#include "slamkit/plot/svg_plot.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "svg_test_support.hpp"
#include "test_data.hpp"

using namespace slamkit;
using namespace slamkit::plot;
using namespace slamkit::plot::test_svg;

// ---- Well-formed output -------------------------------------------------------------------------

TEST(SvgPlotXml, CheckerRejectsBrokenDocuments) {
  EXPECT_EQ(xml_error("<svg><g></g></svg>"), "");
  EXPECT_NE(xml_error("<svg><g></svg>"), "");
  EXPECT_NE(xml_error("<svg><text>a < b</text></svg>"), "");
  EXPECT_NE(xml_error("<svg><text>a & b</text></svg>"), "");
  EXPECT_NE(xml_error("<svg a=\"1\" a=\"2\"/>"), "");
  EXPECT_NE(xml_error("<svg/><svg/>"), "");
}

TEST(SvgPlotXml, EveryKindOfContentGivesWellFormedSvg) {
  Figure fig;
  fig.set_title("all\ncontent");
  fig.set_subtitle("line one\nline two");
  fig.set_x_label("x [m]");
  fig.set_y_label("y [m]");
  const std::vector<Vector2> pts = {{0, 0}, {1, 2}, {3, 1}};
  fig.add_line(pts, {palette::kBlue, 1.5, Dash::kDashDot}, "line");
  for (const Marker m : {Marker::kCircle, Marker::kCross, Marker::kPlus, Marker::kTriangle})
    fig.add_markers(pts, {m, palette::kGreen, 6, 1, false}, "markers");
  EXPECT_TRUE(
      fig.add_ellipse({1, 1}, Matrix2::Identity() * 0.1, 2, {{palette::kVermillion, 1}, 0.2}, "ellipse"));
  fig.add_text({2, 2}, "note");
  fig.add_legend_entry("style", LineStyle{palette::kGrey, 1, Dash::kDotted});
  fig.set_colorbar("colour", 0, 10);
  const std::string svg = fig.to_svg();
  EXPECT_EQ(xml_error(svg), "");
  EXPECT_NE(svg.find("xmlns=\"http://www.w3.org/2000/svg\""), std::string::npos);
  EXPECT_EQ(xml_error(map_figure(sample_map()).to_svg()), "");
  EXPECT_EQ(xml_error(landmark_std_figure(sample_std(3)).to_svg()), "");
  EXPECT_EQ(xml_error(landmark_std_figure(sample_std(120)).to_svg()), "");
  EXPECT_EQ(xml_error(Figure().to_svg()), "") << "an empty figure is still a valid picture";
}

TEST(SvgPlotXml, ContainsTitleLegendAndAxisLabels) {
  const std::string svg = map_figure(sample_map()).to_svg();
  for (const char* text : {">EKF-SLAM map<", ">ATE 0.4 m<", ">x [m]<", ">y [m]<", ">true trajectory<",
                           ">estimated trajectory<", ">dead reckoning<", ">reference fixes<",
                           ">true landmarks<", ">estimated landmarks<", ">2\u03C3 covariance<"})
    EXPECT_NE(svg.find(text), std::string::npos) << text;
  const std::string std_svg = landmark_std_figure(sample_std(3)).to_svg();
  for (const char* text : {">time [s]<", "standard deviation", ">landmark 0<", ">landmark 2<"})
    EXPECT_NE(std_svg.find(text), std::string::npos) << text;
}

TEST(SvgPlotXml, EscapesSpecialCharacters) {
  Figure fig;
  fig.set_title("a & b <c> \"d\" 'e'");
  fig.set_x_label("x<y");
  const std::vector<Vector2> pts = {{0, 0}, {1, 1}};
  fig.add_line(pts, {}, "R&D");
  fig.add_text({0.5, 0.5}, "</text><script>");
  // A stray Latin-1 byte and a control character would make browsers reject the whole file.
  fig.set_subtitle(std::string("caf\xE9 \x01ok"));
  const std::string svg = fig.to_svg();
  EXPECT_EQ(xml_error(svg), "");
  EXPECT_NE(svg.find("a &amp; b &lt;c&gt; &quot;d&quot; &apos;e&apos;"), std::string::npos);
  EXPECT_NE(svg.find(">x&lt;y<"), std::string::npos);
  EXPECT_NE(svg.find(">R&amp;D<"), std::string::npos);
  EXPECT_NE(svg.find("&lt;/text&gt;&lt;script&gt;"), std::string::npos);
  EXPECT_EQ(svg.find("<script>"), std::string::npos);
  EXPECT_NE(svg.find("caf\uFFFD ok"), std::string::npos);
  EXPECT_EQ(svg.find('\x01'), std::string::npos);
}

// ---- Geometry -------------------------------------------------------------------------------------

TEST(SvgPlotGeometry, EllipseHasTheCovariancesSemiAxes) {
  // Eigenvalues 9 and 1 along 30 degrees: the 2-sigma ellipse has semi-axes 6 and 2.
  const double angle = std::numbers::pi / 6;
  Eigen::Matrix2d r;
  r << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  const Matrix2 cov = r * Eigen::Vector2d(9, 1).asDiagonal() * r.transpose();
  const Vector2 centre(5, -3);

  Figure fig;
  fig.set_equal_aspect(true);
  const std::vector<Vector2> box = {{-5, -13}, {15, 7}};
  fig.add_markers(box, {});
  ASSERT_TRUE(fig.add_ellipse(centre, cov, 2.0, {{Color{0x12, 0x34, 0x56}, 1}}));
  const std::string svg = fig.to_svg();
  const Frame f = fig.frame();
  const std::vector<std::string> paths = paths_in_group(svg, "stroke=\"#123456\"");
  ASSERT_EQ(paths.size(), 1u);
  const auto pieces = parse_polyline_path(paths[0]);
  ASSERT_EQ(pieces.size(), 1u);
  ASSERT_GE(pieces[0].size(), 16u);

  double longest = 0, shortest = kInf;
  Vector2 far = Vector2::Zero();
  for (const Vector2& px : pieces[0]) {
    const Vector2 d = f.to_data(px) - centre;
    if (d.norm() > longest) {
      longest = d.norm();
      far = d;
    }
    shortest = std::min(shortest, d.norm());
  }
  const double tolerance = 0.15 / (f.plot_width / (f.x_max - f.x_min));  // 0.15 px in metres
  EXPECT_NEAR(longest, 6.0, tolerance);
  EXPECT_NEAR(shortest, 2.0, tolerance);
  // The major axis points along 30 degrees (either way).
  EXPECT_NEAR(std::abs(far.normalized().dot(Vector2(std::cos(angle), std::sin(angle)))), 1.0, 1e-3);
}

TEST(SvgPlotGeometry, DegenerateCovariancesAreSkipped) {
  Figure fig;
  const EllipseStyle style{{Color{0x12, 0x34, 0x56}, 1}};
  Matrix2 negative;
  negative << 1, 0, 0, -1;
  Matrix2 nan = Matrix2::Identity();
  nan(0, 1) = kNaN;
  EXPECT_FALSE(fig.add_ellipse({0, 0}, Matrix2::Zero(), 2, style));
  EXPECT_FALSE(fig.add_ellipse({0, 0}, negative, 2, style));
  EXPECT_FALSE(fig.add_ellipse({0, 0}, nan, 2, style));
  EXPECT_FALSE(fig.add_ellipse({kNaN, 0}, Matrix2::Identity(), 2, style));
  EXPECT_FALSE(fig.add_ellipse({0, 0}, Matrix2::Identity(), 0, style));
  Matrix2 flat;  // rank one: a line segment is what the covariance says
  flat << 1, 1, 1, 1;
  EXPECT_TRUE(fig.add_ellipse({0, 0}, flat, 2, style));
  const std::string svg = fig.to_svg();
  EXPECT_EQ(xml_error(svg), "");
  EXPECT_EQ(paths_in_group(svg, "stroke=\"#123456\"").size(), 1u);
}

TEST(SvgPlotGeometry, NonFiniteInputsNeverReachTheSvg) {
  Figure fig;
  const std::vector<Vector2> line = {{0, 0}, {1, 1}, {kNaN, 2}, {2, kInf}, {3, 1}, {4, 0}};
  fig.add_line(line, {Color{0x12, 0x34, 0x56}});
  const std::vector<Vector2> markers = {{kNaN, kNaN}, {1, 0.5}, {-kInf, 0}};
  fig.add_markers(markers, {});
  fig.add_text({kNaN, 0}, "lost");
  const std::string svg = fig.to_svg();
  EXPECT_EQ(xml_error(svg), "");
  EXPECT_EQ(lower(svg).find("nan"), std::string::npos);
  EXPECT_EQ(lower(svg).find("inf"), std::string::npos);
  EXPECT_EQ(svg.find(">lost<"), std::string::npos);
  // The gap splits the line in two pieces rather than joining across it.
  const auto paths = paths_in_group(svg, "stroke=\"#123456\"");
  ASSERT_EQ(paths.size(), 1u);
  EXPECT_EQ(parse_polyline_path(paths[0]).size(), 2u);
  // The auto-range ignores the non-finite points.
  const Frame f = fig.frame();
  EXPECT_TRUE(std::isfinite(f.x_min) && std::isfinite(f.x_max) && std::isfinite(f.y_min) &&
              std::isfinite(f.y_max));
  EXPECT_LT(f.x_max, 4.5);
}

TEST(SvgPlotGeometry, AutoRangeCoversTheDataWithASmallMargin) {
  Figure fig;
  const std::vector<Vector2> pts = {{-2, 10}, {8, 30}};
  fig.add_line(pts, {});
  const Frame f = fig.frame();
  EXPECT_LT(f.x_min, -2);
  EXPECT_GT(f.x_max, 8);
  EXPECT_GT(f.x_min, -2 - 0.1 * 10);
  EXPECT_LT(f.x_max, 8 + 0.1 * 10);
  EXPECT_LT(f.y_min, 10);
  EXPECT_GT(f.y_max, 30);
  EXPECT_GT(f.y_min, 10 - 0.1 * 20);

  Figure fixed;
  fixed.add_line(pts, {});
  fixed.set_x_limits(0, 5);
  fixed.set_y_limits(-1, 1);
  const Frame g = fixed.frame();
  EXPECT_EQ(g.x_min, 0);
  EXPECT_EQ(g.x_max, 5);
  EXPECT_EQ(g.y_min, -1);
  EXPECT_EQ(g.y_max, 1);
  EXPECT_THROW(fixed.set_x_limits(1, 1), std::invalid_argument);
}

TEST(SvgPlotGeometry, EqualAspectGivesTheSameScaleOnBothAxes) {
  for (const Vector2& extent : {Vector2(200, 10), Vector2(10, 200), Vector2(50, 40)}) {
    Figure fig(900, 700);
    fig.set_equal_aspect(true);
    const std::vector<Vector2> pts = {{0, 0}, extent};
    fig.add_line(pts, {}, "data");
    const Frame f = fig.frame();
    const double sx = f.plot_width / (f.x_max - f.x_min), sy = f.plot_height / (f.y_max - f.y_min);
    EXPECT_NEAR(sx / sy, 1.0, 1e-9) << "extent " << extent.transpose();
    // Pixels per metre measured through the transform agree too.
    const Vector2 o = f.to_pixel({0, 0}), ex = f.to_pixel({1, 0}), ey = f.to_pixel({0, 1});
    EXPECT_NEAR((ex - o).norm(), (ey - o).norm(), 1e-9);
    EXPECT_LE(f.x_min, 0);
    EXPECT_GE(f.x_max, extent.x());
    EXPECT_LE(f.y_min, 0);
    EXPECT_GE(f.y_max, extent.y());
    EXPECT_LE(f.height, 700.0);
  }
  // A wide map gets a shorter canvas instead of empty bands.
  Figure wide(900, 700);
  wide.set_equal_aspect(true);
  const std::vector<Vector2> strip = {{0, 0}, {200, 60}};
  wide.add_line(strip, {});
  EXPECT_LT(wide.frame().height, 650);
  const std::string svg = wide.to_svg();
  const std::size_t at = svg.find(" height=\"");
  ASSERT_NE(at, std::string::npos);
  EXPECT_NEAR(std::stod(svg.substr(at + 9)), wide.frame().height, 0.05);
}

TEST(SvgPlotGeometry, LogScaleSpacesDecadesEvenly) {
  Figure fig;
  fig.set_log_y(true);
  const std::vector<Vector2> pts = {{0, 1e-3}, {1, 0.5}, {2, -5}, {3, 100}, {4, 20}, {5, 0.0}};
  fig.add_line(pts, {Color{0x12, 0x34, 0x56}});
  const Frame f = fig.frame();
  ASSERT_TRUE(f.log_y);
  EXPECT_LT(f.y_min, 1e-3);
  EXPECT_GT(f.y_min, 1e-4);
  EXPECT_GT(f.y_max, 100);
  EXPECT_LT(f.y_max, 1e3);
  const double a = f.to_pixel({0, 0.01}).y(), b = f.to_pixel({0, 0.1}).y(), c = f.to_pixel({0, 1}).y();
  EXPECT_NEAR(a - b, b - c, 1e-9);
  EXPECT_GT(a - b, 20) << "a decade should span a readable distance";
  EXPECT_FALSE(std::isfinite(f.to_pixel({0, 0}).y()));
  EXPECT_FALSE(std::isfinite(f.to_pixel({0, -5}).y()));

  const std::string svg = fig.to_svg();
  EXPECT_EQ(xml_error(svg), "");
  for (const char* label : {">0.001<", ">0.01<", ">0.1<", ">1<", ">10<", ">100<"})
    EXPECT_NE(svg.find(label), std::string::npos) << label;
  EXPECT_EQ(lower(svg).find("nan"), std::string::npos);
  // Zero and negative values break the line like missing data.
  const auto pieces = parse_polyline_path(paths_in_group(svg, "stroke=\"#123456\"").at(0));
  ASSERT_EQ(pieces.size(), 2u);
  EXPECT_EQ(pieces[0].size(), 2u);
  EXPECT_EQ(pieces[1].size(), 2u);
}

TEST(SvgPlotGeometry, LogLabelsUsePowersOfTenForExtremeValues) {
  Figure fig;
  fig.set_log_y(true);
  const std::vector<Vector2> pts = {{0, 1e-9}, {1, 1e-3}};
  fig.add_line(pts, {});
  const std::string svg = fig.to_svg();
  EXPECT_NE(svg.find(">10\u207B\u2076<"), std::string::npos) << "10^-6 as a superscript";
  EXPECT_THROW(fig.set_y_limits(0, 1), std::invalid_argument);
  Figure late;
  late.set_y_limits(-1, 1);
  late.set_log_y(true);
  EXPECT_THROW(late.to_svg(), std::invalid_argument);
}

// ---- Compact output ---------------------------------------------------------------------------------

TEST(SvgPlotSize, LongPolylinesAreThinnedButKeepTheirShape) {
  Figure fig(800, 600);
  fig.set_equal_aspect(true);
  std::vector<Vector2> circle;
  for (int i = 0; i <= 20000; ++i) {
    const double a = 2 * std::numbers::pi * i / 20000;
    circle.emplace_back(std::cos(a), std::sin(a));
  }
  fig.add_line(circle, {Color{0x12, 0x34, 0x56}});
  const std::string svg = fig.to_svg();
  const Frame f = fig.frame();
  const auto pieces = parse_polyline_path(paths_in_group(svg, "stroke=\"#123456\"").at(0));
  ASSERT_EQ(pieces.size(), 1u);
  const std::vector<Vector2>& kept = pieces[0];
  EXPECT_LT(kept.size(), 1000u);
  EXPECT_GT(kept.size(), 20u);
  const double px_per_unit = f.plot_width / (f.x_max - f.x_min);
  for (const Vector2& p : kept) EXPECT_NEAR(f.to_data(p).norm(), 1.0, 0.2 / px_per_unit);
  EXPECT_LT((kept.front() - f.to_pixel(circle.front())).norm(), 0.1);
  EXPECT_LT((kept.back() - f.to_pixel(circle.back())).norm(), 0.1);
  // Apart from the data's true end, which is always kept, no two points are closer than ~0.5 px.
  for (std::size_t i = 1; i + 1 < kept.size(); ++i) EXPECT_GE((kept[i] - kept[i - 1]).norm(), 0.4);
  EXPECT_LT(svg.size(), 20000u);
}

TEST(SvgPlotSize, PathCoordinatesHaveAtMostOneDecimal) {
  const std::string svg = map_figure(sample_map()).to_svg();
  std::size_t checked = 0;
  for (std::size_t p = svg.find(" d=\""); p != std::string::npos; p = svg.find(" d=\"", p + 1)) {
    const std::string d = svg.substr(p + 4, svg.find('"', p + 4) - p - 4);
    for (std::size_t dot = d.find('.'); dot != std::string::npos; dot = d.find('.', dot + 1)) {
      ++checked;
      ASSERT_TRUE(dot + 1 < d.size() && std::isdigit(static_cast<unsigned char>(d[dot + 1]))) << d;
      EXPECT_FALSE(dot + 2 < d.size() && std::isdigit(static_cast<unsigned char>(d[dot + 2]))) << d;
    }
  }
  EXPECT_GT(checked, 100u);
}

// ---- Stacked panels -----------------------------------------------------------------------------

/// The attribute `name` of the first element at or after `from` that has it.
double attribute_after(const std::string& svg, std::size_t from, const std::string& name) {
  const std::size_t at = svg.find(" " + name + "=\"", from);
  return at == std::string::npos ? kNaN : std::stod(svg.substr(at + name.size() + 3));
}

TEST(SvgPlotStacked, PanelsShareTheirPlotAreasLeftAndRightAndHaveIdsOfTheirOwn) {
  // Tick labels of different widths and legends of different widths: alone, their plot areas differ.
  Figure top(900, 400), bottom(900, 300);
  const std::vector<Vector2> small = {{0, 0.001}, {10, 0.002}}, large = {{0, -123456}, {10, 987654}};
  top.set_title("stacked");
  top.add_line(small, {}, "a");
  bottom.add_line(large, {}, "a much longer legend label");
  bottom.set_colorbar("colour", 0, 1);
  ASSERT_NE(top.frame().left, bottom.frame().left);
  ASSERT_NE(top.frame().plot_width, bottom.frame().plot_width);

  const std::string svg = stacked_svg({top, bottom});
  EXPECT_EQ(xml_error(svg), "");
  EXPECT_NEAR(attribute_after(svg, 0, "height"), top.frame().height + bottom.frame().height, 0.1)
      << "one above the other";
  const std::size_t first = svg.find("<clipPath id=\"slamkit-plot-area-1\">");
  const std::size_t second = svg.find("<clipPath id=\"slamkit-plot-area-2\">");
  ASSERT_NE(first, std::string::npos);
  ASSERT_NE(second, std::string::npos);
  EXPECT_EQ(count(svg, "url(#slamkit-plot-area-1)"), 1u);
  EXPECT_EQ(count(svg, "url(#slamkit-plot-area-2)"), 1u);
  EXPECT_EQ(count(svg, "id=\"slamkit-colorbar-2\""), 1u);
  EXPECT_EQ(count(svg, "url(#slamkit-colorbar-2)"), 1u);
  for (const char* edge : {"x", "width"})
    EXPECT_EQ(attribute_after(svg, first, edge), attribute_after(svg, second, edge)) << edge;
  const std::size_t shift = svg.rfind("<g transform=\"translate(0 ");
  ASSERT_NE(shift, std::string::npos);
  EXPECT_NEAR(std::stod(svg.substr(shift + 26)), top.frame().height, 0.1);
  EXPECT_THROW(stacked_svg({}), std::invalid_argument);
}

// ---- Files ----------------------------------------------------------------------------------------

TEST(SvgPlotFile, SaveWritesTheSvg) {
  const std::string path = ::testing::TempDir() + "/slamkit_svg_plot_map.svg";
  write_map_svg(path, sample_map());
  EXPECT_EQ(test_data::read_text(path), map_figure(sample_map()).to_svg());
  std::remove(path.c_str());
}

TEST(SvgPlotFile, SaveToAnUnwritablePathThrowsNamingIt) {
  const std::string path = ::testing::TempDir() + "/no/such/dir/plot.svg";
  try {
    Figure().save(path);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_THROW(write_landmark_std_svg(path, sample_std(2)), std::runtime_error);
}

TEST(SvgPlotColors, PalettesAreDistinctAndClamped) {
  for (std::size_t i = 0; i < kCategoricalColors; ++i)
    for (std::size_t j = i + 1; j < kCategoricalColors; ++j)
      EXPECT_NE(categorical_color(i), categorical_color(j));
  EXPECT_EQ(categorical_color(kCategoricalColors), categorical_color(0));
  EXPECT_EQ(sequential_color(-1), sequential_color(0));
  EXPECT_EQ(sequential_color(2), sequential_color(1));
  EXPECT_EQ(sequential_color(0).hex(), "#440154");  // viridis starts at its dark purple
  EXPECT_NE(sequential_color(0.5), sequential_color(0.6));
}
