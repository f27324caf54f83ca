// Resampling schemes (unbiased copy counts, each scheme's bounds on them), the policies and the
// log-weight normalisation.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <stdexcept>
#include <vector>

#include "slamkit/filters/resampling.hpp"

using namespace slamkit;

namespace {

// N w_i = 0.21, 1.75, 0, 0.84, 2.8, 0.035, 1.365: small, large and zero expected counts.
const std::vector<double> kWeights = {0.03, 0.25, 0.0, 0.12, 0.4, 0.005, 0.195};
constexpr std::size_t kN = 7;  // kWeights.size(): the schemes draw as many as there are weights

struct CopyStats {
  std::vector<double> mean, variance;
  std::vector<int> min, max;
};

CopyStats copy_statistics(ResampleMethod method, int draws) {
  std::mt19937_64 rng(7);
  const std::size_t n = kWeights.size();
  std::vector<double> sum(n, 0.0), sum_sq(n, 0.0);
  CopyStats s{{}, {}, std::vector<int>(n, INT32_MAX), std::vector<int>(n, 0)};
  for (int d = 0; d < draws; ++d) {
    const std::vector<std::size_t> parents = resample(method, kWeights, rng);
    EXPECT_EQ(parents.size(), n);
    EXPECT_TRUE(std::is_sorted(parents.begin(), parents.end()));
    std::vector<int> copies(n, 0);
    for (const std::size_t p : parents) ++copies.at(p);
    for (std::size_t i = 0; i < n; ++i) {
      sum[i] += copies[i];
      sum_sq[i] += copies[i] * copies[i];
      s.min[i] = std::min(s.min[i], copies[i]);
      s.max[i] = std::max(s.max[i], copies[i]);
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    s.mean.push_back(sum[i] / draws);
    s.variance.push_back(sum_sq[i] / draws - s.mean[i] * s.mean[i]);
  }
  return s;
}

}  // namespace

class ResamplerTest : public ::testing::TestWithParam<ResampleMethod> {};

TEST_P(ResamplerTest, MeanCopiesAreNTimesTheWeight) {
  constexpr int kDraws = 20000;
  const CopyStats s = copy_statistics(GetParam(), kDraws);
  for (std::size_t i = 0; i < kWeights.size(); ++i) {
    const double expected = static_cast<double>(kN) * kWeights[i];
    const double standard_error = std::sqrt(std::max(s.variance[i], 0.0) / kDraws);
    EXPECT_NEAR(s.mean[i], expected, 4.5 * standard_error + 1e-12) << to_string(GetParam()) << " particle " << i;
  }
  EXPECT_EQ(s.max[2], 0) << "a zero-weight particle is never drawn";
}

TEST_P(ResamplerTest, CopyCountBoundsOfEachScheme) {
  const CopyStats s = copy_statistics(GetParam(), 5000);
  for (std::size_t i = 0; i < kWeights.size(); ++i) {
    const double expected = static_cast<double>(kN) * kWeights[i];
    const int lo = static_cast<int>(std::floor(expected)), hi = static_cast<int>(std::ceil(expected));
    switch (GetParam()) {
      case ResampleMethod::kSystematic:
        EXPECT_GE(s.min[i], lo) << i;
        EXPECT_LE(s.max[i], hi) << i;
        break;
      case ResampleMethod::kStratified:
        EXPECT_GE(s.min[i], lo - 1) << i;
        EXPECT_LE(s.max[i], hi + 1) << i;
        break;
      case ResampleMethod::kResidual:
        EXPECT_GE(s.min[i], lo) << i;
        break;
      case ResampleMethod::kMultinomial:
        // Binomial(N, w): the variance is N w (1 - w).
        EXPECT_NEAR(s.variance[i], expected * (1.0 - kWeights[i]), 0.15 * expected + 0.01) << i;
        break;
    }
  }
}

TEST_P(ResamplerTest, SameSeedSameDrawAndRejectsEmpty) {
  std::mt19937_64 a(3), b(3);
  EXPECT_EQ(resample(GetParam(), kWeights, a), resample(GetParam(), kWeights, b));
  EXPECT_THROW(resample(GetParam(), std::vector<double>{}, a), std::invalid_argument);
  const std::vector<double> one = {1.0};
  EXPECT_EQ(resample(GetParam(), one, a), std::vector<std::size_t>{0});
}

INSTANTIATE_TEST_SUITE_P(AllSchemes, ResamplerTest,
                         ::testing::Values(ResampleMethod::kMultinomial, ResampleMethod::kStratified,
                                           ResampleMethod::kSystematic, ResampleMethod::kResidual),
                         [](const auto& info) { return to_string(info.param); });

TEST(Resampling, SystematicAndResidualAddLessNoiseThanMultinomial) {
  const CopyStats multinomial = copy_statistics(ResampleMethod::kMultinomial, 5000);
  const CopyStats systematic = copy_statistics(ResampleMethod::kSystematic, 5000);
  const CopyStats residual = copy_statistics(ResampleMethod::kResidual, 5000);
  // Residual sampling only removes variance from particles with N w_i >= 1, so it is compared in
  // total; for a tiny weight both are Bernoulli-like and equal up to sampling noise.
  double residual_total = 0.0, multinomial_total = 0.0;
  for (std::size_t i = 0; i < kWeights.size(); ++i) {
    EXPECT_LE(systematic.variance[i], multinomial.variance[i] + 1e-12) << i;
    residual_total += residual.variance[i];
    multinomial_total += multinomial.variance[i];
  }
  EXPECT_LT(residual_total, 0.75 * multinomial_total);
}

TEST(Resampling, ParseMethods) {
  for (const ResampleMethod m : {ResampleMethod::kMultinomial, ResampleMethod::kStratified,
                                 ResampleMethod::kSystematic, ResampleMethod::kResidual})
    EXPECT_EQ(parse_resample_method(to_string(m)), m);
  try {
    parse_resample_method("bootstrap");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("systematic"), std::string::npos) << e.what();
  }
}

TEST(Resampling, ParsePolicies) {
  EXPECT_EQ(parse_resample_policy("always").kind, ResamplePolicy::Kind::kAlways);
  const ResamplePolicy every = parse_resample_policy("every:3");
  EXPECT_EQ(every.kind, ResamplePolicy::Kind::kEvery);
  EXPECT_EQ(every.every, 3);
  const ResamplePolicy ess = parse_resample_policy("ess:0.25");
  EXPECT_EQ(ess.kind, ResamplePolicy::Kind::kEss);
  EXPECT_DOUBLE_EQ(ess.ess_fraction, 0.25);
  EXPECT_EQ(to_string(parse_resample_policy(to_string(ess))).rfind("ess:0.25", 0), 0u);
  EXPECT_EQ(to_string(every), "every:3");
  for (const char* bad : {"", "never", "every", "every:", "every:0", "every:-2", "every:2.5", "every:3x", "ess:0",
                          "ess:1.5", "ess:abc", "ess:nan", "ess", "always:1"})
    EXPECT_THROW(parse_resample_policy(bad), std::invalid_argument) << bad;
}

TEST(Resampling, PoliciesDecideAsConfigured) {
  const ResamplePolicy every = parse_resample_policy("every:3");
  std::vector<std::size_t> resampled;
  for (std::size_t scan = 1; scan <= 9; ++scan)
    if (every.should_resample(scan, 100.0, 100)) resampled.push_back(scan);
  EXPECT_EQ(resampled, (std::vector<std::size_t>{3, 6, 9}));
  EXPECT_TRUE(parse_resample_policy("always").should_resample(1, 100.0, 100));

  // Weights built to have an ESS just below and just above half of N = 10.
  const ResamplePolicy half = parse_resample_policy("ess:0.5");
  auto weights_with_ess = [](double heavy) {  // one particle with `heavy`, nine sharing the rest
    std::vector<double> w(10, (1.0 - heavy) / 9.0);
    w[0] = heavy;
    return w;
  };
  const double ess_low = effective_sample_size(weights_with_ess(0.42));
  const double ess_high = effective_sample_size(weights_with_ess(0.38));
  ASSERT_LT(ess_low, 5.0);
  ASSERT_GT(ess_high, 5.0);
  EXPECT_TRUE(half.should_resample(1, ess_low, 10));
  EXPECT_FALSE(half.should_resample(1, ess_high, 10));
  EXPECT_FALSE(half.should_resample(1, effective_sample_size(std::vector<double>(10, 0.1)), 10));
}

TEST(Resampling, EffectiveSampleSize) {
  EXPECT_NEAR(effective_sample_size(std::vector<double>(8, 0.125)), 8.0, 1e-12);
  EXPECT_NEAR(effective_sample_size(std::vector<double>{0.0, 1.0, 0.0}), 1.0, 1e-12);
}

TEST(Resampling, LogSumExpNormalisation) {
  std::vector<double> w;
  // exp(-1e5) underflows; the shift by the maximum keeps the ratio 1 : 2.
  const std::optional<double> log_sum = normalize_log_weights(std::vector<double>{-1e5, -1e5 + std::log(2.0)}, w);
  ASSERT_TRUE(log_sum.has_value());
  EXPECT_NEAR(*log_sum, -1e5 + std::log(3.0), 1e-9);
  EXPECT_NEAR(w[0], 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(w[1], 2.0 / 3.0, 1e-12);

  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(normalize_log_weights(std::vector<double>{nan, 3.0, -inf, 3.0}, w).has_value());
  EXPECT_EQ(w, (std::vector<double>{0.0, 0.5, 0.0, 0.5}));

  EXPECT_FALSE(normalize_log_weights(std::vector<double>{-inf, nan, -inf}, w).has_value()) << "a collapse is reported";
  for (const double v : w) EXPECT_DOUBLE_EQ(v, 1.0 / 3.0);
}
