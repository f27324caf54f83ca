// Chi-square functions against reference values (computed to 17 digits with mpmath's exact series for
// the regularized incomplete gamma function), against closed forms, and against each other.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "slamkit/core/chi_square.hpp"

using namespace slamkit::eval;

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

struct QuantileCase {
  double p;
  double dof;
  double expected;
};

void expect_relative(double actual, double expected, double tolerance) {
  EXPECT_LE(std::abs(actual - expected), tolerance * std::abs(expected))
      << "actual " << actual << ", expected " << expected;
}

}  // namespace

TEST(ChiSquareQuantile, MatchesReferenceValues) {
  const QuantileCase cases[] = {
      {0.975, 3, 9.3484036044961458},     {0.025, 3, 0.21579528262389788},
      {0.95, 2, 5.9914645471079802},      {0.05, 2, 0.10258658877510107},
      {0.975, 1, 5.0238861873148874},     {0.025, 1, 0.00098206911717525602},
      {0.5, 1, 0.45493642311957275},      {0.5, 0.5, 0.087347604705746821},
      {0.1, 5, 1.610307986962323},        {0.9, 5, 9.2363568997811191},
      {0.5, 30, 29.336031516661586},      {0.99, 150, 193.20768638551057},
      {0.01, 150, 112.66758283241268},    {0.975, 300, 349.87446882991526},
      {0.025, 300, 253.91232260248973},   {0.999999, 0.5, 21.37563515282196},
      {1e-12, 1, 1.5707963267948966e-24}, {1.0 - 1e-12, 3, 58.919800665904698},
  };
  for (const QuantileCase& c : cases) {
    SCOPED_TRACE(testing::Message() << "p " << c.p << ", dof " << c.dof);
    expect_relative(chi_square_quantile(c.p, c.dof), c.expected, 1e-13);
  }
}

TEST(ChiSquareQuantile, LargeDegreesOfFreedom) {
  const QuantileCase cases[] = {
      {0.999, 1e4, 10442.730565410178}, {0.001, 1e4, 9568.6684950939682}, {0.5, 1e4, 9999.3333412351448},
      {0.99, 1e5, 101043.31473677837},  {0.01, 1e5, 98962.567778290221},
  };
  for (const QuantileCase& c : cases) {
    SCOPED_TRACE(testing::Message() << "p " << c.p << ", dof " << c.dof);
    expect_relative(chi_square_quantile(c.p, c.dof), c.expected, 1e-13);
  }
}

TEST(ChiSquareQuantile, MatchesClosedFormForTwoDofAcrossExtremeProbabilities) {
  // chi2(2) is exponential with mean 2: q(p) = -2 ln(1 - p).
  for (const double p : {1e-300, 1e-100, 1e-12, 1e-3, 0.3, 0.5, 0.7, 0.999, 1.0 - 1e-12, 1.0 - 1e-15}) {
    SCOPED_TRACE(testing::Message() << "p " << p);
    expect_relative(chi_square_quantile(p, 2), -2.0 * std::log1p(-p), 1e-12);
  }
}

TEST(ChiSquareQuantile, TinyProbabilityWithOneDof) {
  // For small x, P(X <= x) = erf(sqrt(x / 2)) ~ sqrt(2 x / pi), so q(p) ~ pi p^2 / 2.
  expect_relative(chi_square_quantile(1e-150, 1), std::numbers::pi / 2 * 1e-300, 1e-12);
}

TEST(ChiSquareQuantile, InvertsTheCdf) {
  for (const double dof : {0.5, 1.0, 2.0, 3.0, 7.5, 30.0, 150.0, 1000.0, 1e5}) {
    for (const double p : {1e-10, 1e-4, 0.01, 0.025, 0.2, 0.5, 0.8, 0.975, 0.99}) {
      SCOPED_TRACE(testing::Message() << "p " << p << ", dof " << dof);
      const double x = chi_square_quantile(p, dof);
      expect_relative(chi_square_cdf(x, dof), p, 1e-12);
    }
  }
}

TEST(ChiSquareQuantile, IncreasesWithProbability) {
  for (const double dof : {1.0, 3.0, 40.0}) {
    double previous = 0.0;
    for (int i = 1; i < 1000; ++i) {
      const double x = chi_square_quantile(i / 1000.0, dof);
      ASSERT_GT(x, previous) << "p " << i / 1000.0 << ", dof " << dof;
      previous = x;
    }
  }
}

TEST(ChiSquareQuantile, EdgeProbabilitiesAndInvalidArguments) {
  EXPECT_EQ(chi_square_quantile(0.0, 3), 0.0);
  EXPECT_EQ(chi_square_quantile(1.0, 3), kInfinity);
  EXPECT_THROW(chi_square_quantile(-0.1, 3), std::invalid_argument);
  EXPECT_THROW(chi_square_quantile(1.1, 3), std::invalid_argument);
  EXPECT_THROW(chi_square_quantile(std::nan(""), 3), std::invalid_argument);
  EXPECT_THROW(chi_square_quantile(0.5, 0), std::invalid_argument);
  EXPECT_THROW(chi_square_quantile(0.5, -2), std::invalid_argument);
  EXPECT_THROW(chi_square_quantile(0.5, kInfinity), std::invalid_argument);
  EXPECT_THROW(chi_square_quantile(0.5, 1e11), std::invalid_argument);
}

TEST(ChiSquareCdf, MatchesReferenceValues) {
  struct Case {
    double x, dof, expected;
  };
  const Case cases[] = {
      {1, 1, 0.6826894921370859},         {3, 2, 0.77686983985157017},     {10, 3, 0.98143386453695677},
      {100, 150, 0.00057775452620999654}, {0.5, 4, 0.026499021160743915},  {200, 150, 0.99602681402917839},
      {1e-3, 5, 1.6814877189706275e-9},   {1e4, 1e4, 0.50188063403381736}, {1e5, 1e5, 0.50059470810479331},
      {1.01e5, 1e5, 0.98713115962276633},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(testing::Message() << "x " << c.x << ", dof " << c.dof);
    expect_relative(chi_square_cdf(c.x, c.dof), c.expected, 1e-13);
  }
}

TEST(ChiSquareCdf, MatchesClosedForms) {
  for (double x = 0.01; x < 80.0; x *= 1.3) {
    SCOPED_TRACE(testing::Message() << "x " << x);
    EXPECT_NEAR(chi_square_cdf(x, 1), std::erf(std::sqrt(x / 2)), 1e-14);
    expect_relative(chi_square_cdf(x, 2), -std::expm1(-x / 2), 1e-13);
    EXPECT_NEAR(chi_square_cdf(x, 4), 1.0 - std::exp(-x / 2) * (1.0 + x / 2), 1e-14);
  }
}

TEST(ChiSquareCdf, EdgeArguments) {
  EXPECT_EQ(chi_square_cdf(0.0, 3), 0.0);
  EXPECT_EQ(chi_square_cdf(-1.0, 3), 0.0);
  EXPECT_EQ(chi_square_cdf(kInfinity, 3), 1.0);
  EXPECT_TRUE(std::isnan(chi_square_cdf(std::nan(""), 3)));
  EXPECT_THROW(chi_square_cdf(1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(chi_square_cdf(1.0, std::nan("")), std::invalid_argument);
}

TEST(ChiSquareInterval, TwoSidedWithEqualTails) {
  const Interval i = chi_square_interval(0.95, 3);
  EXPECT_NEAR(i.lo, 0.21579528262389788, 1e-12);
  EXPECT_NEAR(i.hi, 9.3484036044961458, 1e-11);
  EXPECT_TRUE(i.contains(3.0));
  EXPECT_TRUE(i.contains(i.lo));
  EXPECT_TRUE(i.contains(i.hi));
  EXPECT_FALSE(i.contains(0.1));
  EXPECT_FALSE(i.contains(10.0));
  EXPECT_FALSE(i.contains(kInfinity));
  EXPECT_THROW(chi_square_interval(0.0, 3), std::invalid_argument);
  EXPECT_THROW(chi_square_interval(1.0, 3), std::invalid_argument);
}

TEST(AveragedNeesInterval, ScalesTheIntervalOfTheSum) {
  // 50 runs of a 2-D NEES: the sum is chi2(100), Bar-Shalom's example interval [1.5, 2.6].
  const Interval two = averaged_nees_interval(0.95, 2, 50);
  EXPECT_NEAR(two.lo, 74.221927474923726 / 50, 1e-12);
  EXPECT_NEAR(two.hi, 129.56119718583659 / 50, 1e-12);

  const Interval three = averaged_nees_interval(0.95, 3, 50);
  EXPECT_NEAR(three.lo, 117.9845154029029 / 50, 1e-12);
  EXPECT_NEAR(three.hi, 185.80044700379325 / 50, 1e-12);

  const Interval single = averaged_nees_interval(0.95, 3, 1);
  const Interval plain = chi_square_interval(0.95, 3);
  EXPECT_EQ(single.lo, plain.lo);
  EXPECT_EQ(single.hi, plain.hi);

  EXPECT_THROW(averaged_nees_interval(0.95, 3, 0), std::invalid_argument);
  EXPECT_THROW(averaged_nees_interval(0.95, 0, 10), std::invalid_argument);
}
