// The axes of the SVG plots: 1-2-5 ticks covering the range, exact multiples of the step, log ticks
// by decade or 1-2-5 within few decades; the measured geometry of log axes is in svg_plot_test.cpp.
#include "slamkit/plot/svg_plot.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "svg_test_support.hpp"

using namespace slamkit;
using namespace slamkit::plot;
using namespace slamkit::plot::test_svg;

TEST(SvgPlotTicks, LinearTicksAre125StepsCoveringTheRange) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> exponent(-6, 6), unit(-1, 1);
  std::vector<std::pair<double, double>> ranges = {{0, 1},      {-3.7, 12.2},  {1e-4, 3e-4},
                                                   {-1e6, 2e6}, {99.5, 100.5}, {-0.03, 0}};
  for (int i = 0; i < 500; ++i) {
    const double scale = std::pow(10.0, exponent(rng));
    const double a = unit(rng) * scale, b = a + std::abs(unit(rng)) * scale + 1e-3 * scale;
    ranges.emplace_back(a, b);
  }
  for (const auto& [lo, hi] : ranges) {
    const std::vector<double> t = linear_ticks(lo, hi, 6);
    ASSERT_GE(t.size(), 2u) << lo << " " << hi;
    EXPECT_LE(t.size(), 12u) << lo << " " << hi;
    const double step = t[1] - t[0];
    EXPECT_TRUE(is_125(step)) << "step " << step << " for [" << lo << ", " << hi << "]";
    for (std::size_t k = 1; k < t.size(); ++k) EXPECT_NEAR(t[k] - t[k - 1], step, 1e-9 * step);
    const double eps = 1e-9 * (hi - lo);
    EXPECT_GE(t.front(), lo - eps);
    EXPECT_LE(t.back(), hi + eps);
    EXPECT_LT(t.front() - lo, step + eps) << "range start not covered";
    EXPECT_LT(hi - t.back(), step + eps) << "range end not covered";
  }
}

TEST(SvgPlotTicks, LinearTicksAreExactMultiplesOfTheStep) {
  const std::vector<double> t = linear_ticks(-0.35, 0.35, 7);
  ASSERT_FALSE(t.empty());
  EXPECT_TRUE(std::find(t.begin(), t.end(), 0.0) != t.end()) << "zero must be an exact tick";
  EXPECT_EQ(linear_ticks(0, 10, 5), (std::vector<double>{0, 2, 4, 6, 8, 10}));
}

TEST(SvgPlotTicks, LinearTicksHandleDegenerateInput) {
  EXPECT_EQ(linear_ticks(3, 3, 5), std::vector<double>{3});
  EXPECT_TRUE(linear_ticks(kNaN, 1, 5).empty());
  EXPECT_TRUE(linear_ticks(0, kInf, 5).empty());
  EXPECT_TRUE(linear_ticks(2, 1, 5).empty());
}

TEST(SvgPlotTicks, LogTicksArePowersOfTenAcrossDecades) {
  const std::vector<double> t = log_ticks(0.003, 40);
  ASSERT_EQ(t.size(), 4u);
  const double expected[] = {0.01, 0.1, 1, 10};
  for (std::size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i], expected[i], 1e-12 * expected[i]);

  // Many decades: every n-th decade, still powers of ten, few enough to read.
  const std::vector<double> wide = log_ticks(1e-9, 1e9);
  EXPECT_GE(wide.size(), 4u);
  EXPECT_LE(wide.size(), 9u);
  for (const double v : wide) EXPECT_NEAR(std::log10(v), std::round(std::log10(v)), 1e-9);
}

TEST(SvgPlotTicks, LogTicksUse125WithinFewDecades) {
  const std::vector<double> t = log_ticks(0.07, 2);
  const std::vector<double> expected = {0.1, 0.2, 0.5, 1, 2};
  ASSERT_EQ(t.size(), expected.size());
  for (std::size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i], expected[i], 1e-12);
  EXPECT_TRUE(log_ticks(-1, 10).empty());
  EXPECT_GE(log_ticks(2.1, 4.9).size(), 2u) << "a narrow log range still gets ticks";
}
