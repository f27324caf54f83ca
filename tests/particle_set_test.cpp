// The particle set both FastSLAMs share: weighing in log space, the best particle across
// resampling, the policy, the tallies, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "slamkit/core/types.hpp"
#include "slamkit/filters/particle_set.hpp"

using namespace slamkit;

namespace {

// A particle that knows which particle of the first generation it descends from.
struct Ancestor {
  int index = 0;
};

ParticleSet<Ancestor> numbered(std::size_t count, const std::string& policy, std::uint64_t seed = 3,
                               ResampleMethod method = ResampleMethod::kSystematic) {
  ParticleSet<Ancestor> set(count, Ancestor{}, method, parse_resample_policy(policy), seed);
  for (std::size_t i = 0; i < count; ++i) set[i].index = static_cast<int>(i);
  return set;
}

struct PoseParticle {
  Pose2 pose = Pose2::Zero();
  Matrix3 pose_cov = Matrix3::Zero();
};

std::map<std::string, double> statistics_of(const ParticleSet<Ancestor>& set) {
  std::map<std::string, double> statistics;
  set.add_statistics(statistics);
  return statistics;
}

}  // namespace

TEST(ParticleSet, StartsWithEqualWeights) {
  const ParticleSet<Ancestor> set = numbered(4, "ess:0.5");
  for (const double w : set.weights()) EXPECT_DOUBLE_EQ(w, 0.25);
  EXPECT_EQ(statistics_of(set).at("ess_mean"), 4.0);
  EXPECT_THROW(ParticleSet<Ancestor>(0, Ancestor{}, ResampleMethod::kSystematic, ResamplePolicy{}, 1),
               std::invalid_argument);
}

TEST(ParticleSet, WeighsByTheLikelihoodsAndNormalises) {
  ParticleSet<Ancestor> set = numbered(3, "ess:0.5");
  set.weigh(std::vector<double>{std::log(1.0), std::log(2.0), std::log(5.0)});
  EXPECT_NEAR(set.weights()[0], 0.125, 1e-15);
  EXPECT_NEAR(set.weights()[1], 0.25, 1e-15);
  EXPECT_NEAR(set.weights()[2], 0.625, 1e-15);
  EXPECT_EQ(set.best(), 2u);
  // Weights multiply across scans.
  set.weigh(std::vector<double>{std::log(5.0), std::log(2.0), std::log(1.0)});
  EXPECT_NEAR(set.weights()[0], 5.0 / 14.0, 1e-15);
  EXPECT_NEAR(set.weights()[1], 4.0 / 14.0, 1e-15);
  EXPECT_NEAR(set.weights()[2], 5.0 / 14.0, 1e-15);
}

TEST(ParticleSet, AWeightBelowTheSmallestDoubleCanRecover) {
  // exp(-2000) is zero in double precision; a set that kept log(weight) would have lost particle 0
  // for good. Its log-weight stays finite, so the next scan can bring it back exactly.
  ParticleSet<Ancestor> set = numbered(2, "every:1000");
  set.weigh(std::vector<double>{-2000.0, 0.0});
  EXPECT_EQ(set.weights()[0], 0.0);
  set.weigh(std::vector<double>{2000.0, 0.0});
  EXPECT_NEAR(set.weights()[0], 0.5, 1e-12);
  EXPECT_NEAR(set.weights()[1], 0.5, 1e-12);
}

TEST(ParticleSet, ALikelihoodThatRulesOutEveryParticleEqualisesAndIsCounted) {
  ParticleSet<Ancestor> set = numbered(3, "ess:0.5");
  set.weigh(std::vector<double>{0.0, 1.0, 2.0});
  set.weigh(std::vector<double>{std::numeric_limits<double>::quiet_NaN(), -std::numeric_limits<double>::infinity(),
                                -std::numeric_limits<double>::infinity()});
  for (const double w : set.weights()) EXPECT_DOUBLE_EQ(w, 1.0 / 3.0);
  EXPECT_EQ(statistics_of(set).at("weight_collapses"), 1.0);
  // A NaN is a zero weight, not a poison: the others still compare.
  set.weigh(std::vector<double>{std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0});
  EXPECT_EQ(set.weights()[0], 0.0);
  EXPECT_DOUBLE_EQ(set.weights()[1], 0.5);
}

TEST(ParticleSet, TheBestParticleStaysBestThroughResampling) {
  ParticleSet<Ancestor> set = numbered(5, "always");
  set.weigh(std::vector<double>{0.0, 0.5, 3.0, 0.2, 0.1});
  ASSERT_EQ(set.best(), 2u);
  EXPECT_TRUE(set.resample_if_due());
  EXPECT_EQ(set.best_particle().index, 2);
  // The copies of the best fill most of the set and the weights are equal again.
  int copies = 0;
  for (const Ancestor& a : set) copies += a.index == 2 ? 1 : 0;
  EXPECT_GE(copies, 3);
  for (const double w : set.weights()) EXPECT_DOUBLE_EQ(w, 0.2);
  EXPECT_EQ(statistics_of(set).at("resamples"), 1.0);
}

TEST(ParticleSet, ResamplesWhenThePolicySays) {
  ParticleSet<Ancestor> by_ess = numbered(4, "ess:0.5");
  by_ess.weigh(std::vector<double>{0.0, 0.0, 0.0, 0.1});  // ESS near 4: keep the diversity
  EXPECT_FALSE(by_ess.resample_if_due());
  by_ess.weigh(std::vector<double>{0.0, 0.0, 0.0, 5.0});  // one particle holds nearly all
  EXPECT_TRUE(by_ess.resample_if_due());

  ParticleSet<Ancestor> every_other = numbered(4, "every:2");
  std::vector<bool> resampled;
  for (int scan = 0; scan < 4; ++scan) {
    every_other.weigh(std::vector<double>{0.0, 0.0, 0.0, 0.0});
    resampled.push_back(every_other.resample_if_due());
  }
  EXPECT_EQ(resampled, (std::vector<bool>{false, true, false, true}));
  const std::map<std::string, double> statistics = statistics_of(every_other);
  EXPECT_EQ(statistics.at("resamples"), 2.0);
  EXPECT_DOUBLE_EQ(statistics.at("ess_mean"), 4.0);
}

TEST(ParticleSet, TheSameSeedDrawsTheSameParticles) {
  auto draw = [](std::uint64_t seed) {
    // Multinomial: N independent draws, so two seeds cannot agree by the chance that a systematic
    // draw's single offset lands in the same gaps.
    ParticleSet<Ancestor> set = numbered(50, "always", seed, ResampleMethod::kMultinomial);
    std::vector<double> log_likelihoods(50);
    for (std::size_t i = 0; i < 50; ++i) log_likelihoods[i] = 0.5 * static_cast<double>(i % 7);
    set.weigh(log_likelihoods);
    set.resample_if_due();
    std::vector<int> ancestors;
    for (const Ancestor& a : set) ancestors.push_back(a.index);
    return ancestors;
  };
  EXPECT_EQ(draw(11), draw(11));
  EXPECT_NE(draw(11), draw(12));
}

TEST(ParticleSet, OneLikelihoodPerParticle) {
  ParticleSet<Ancestor> set = numbered(3, "ess:0.5");
  EXPECT_THROW(set.weigh(std::vector<double>{0.0, 0.0}), std::invalid_argument);
}

TEST(ParticleSet, TheCloudsGaussianWrapsTheHeading) {
  ParticleSet<PoseParticle> set(2, PoseParticle{}, ResampleMethod::kSystematic, ResamplePolicy{}, 1);
  // Headings either side of +-pi: their mean is pi, not 0, and their spread 0.1 rad, not 3.
  set[0].pose = Pose2(0.0, 0.0, M_PI - 0.1);
  set[1].pose = Pose2(2.0, 0.0, -M_PI + 0.1);
  set[0].pose_cov = Matrix3::Identity() * 0.01;
  set[1].pose_cov = Matrix3::Identity() * 0.03;
  const Pose2 mean = set.mean_pose();
  EXPECT_NEAR(mean[0], 1.0, 1e-12);
  EXPECT_NEAR(std::abs(mean[2]), M_PI, 1e-12);
  const Matrix3 covariance = set.pose_covariance();
  EXPECT_NEAR(covariance(0, 0), 1.0 + 0.02, 1e-12);  // spread of x plus the mean kept variance
  EXPECT_NEAR(covariance(2, 2), 0.01 + 0.02, 1e-12);
  EXPECT_NEAR(covariance(0, 2), covariance(2, 0), 0.0);
  // Weighted: the samples carry the weights the moments used.
  set.weigh(std::vector<double>{0.0, std::log(3.0)});
  EXPECT_NEAR(set.mean_pose()[0], 1.5, 1e-12);
  const std::vector<WeightedPose> samples = set.pose_samples();
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_NEAR(samples[1].weight, 0.75, 1e-15);
  EXPECT_EQ(samples[1].pose, set[1].pose);
}

TEST(ParticleSet, EachSlotHasItsOwnStreamThatStaysWithTheSlot) {
  ParticleSet<Ancestor> one = numbered(3, "always", 5), two = numbered(3, "always", 5);
  EXPECT_NE(one.stream(0)(), one.stream(1)());
  // Resampling moves particles, not streams: the draws of slot 2 do not depend on what was drawn.
  two.weigh(std::vector<double>{5.0, 0.0, 0.0});
  two.resample_if_due();
  EXPECT_EQ(two.best_particle().index, 0);
  EXPECT_EQ(one.stream(2)(), two.stream(2)());
}
