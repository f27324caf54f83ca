// The full Victoria Park run, from the raw laser, without identities: EKF-SLAM and FastSLAM 2.0
// against GPS. Skips where the shared datasets are absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/io/victoria_park.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "test_data.hpp"

using namespace slamkit;

namespace {

Metrics run_victoria_park(const FilterConfig& config) {
  const Dataset data = read_victoria_park(test_data::shared_dataset("victoria_park").string());
  auto filter = make_filter(config, data);
  const RunResult run = run_filter(*filter, data);
  for (const auto& p : run.trajectory) EXPECT_TRUE(p.pose.allFinite()) << "t " << p.t;
  for (const auto& lm : run.map) EXPECT_TRUE(lm.position.allFinite() && lm.covariance.allFinite());
  return evaluate_run(run, data.truth);
}

Metrics run_victoria_park(const std::string& filter_name, AssociationMethod method, int particles = 100,
                          std::uint64_t seed = 1, double pose_sample_fraction = 1.0) {
  FilterConfig config;
  config.filter = parse_filter_kind(filter_name);
  config.association.method = method;
  config.particles = particles;
  config.seed = seed;
  config.pose_sample_fraction = pose_sample_fraction;
  return run_victoria_park(config);
}

void expect_good_run(const Metrics& m) {
  ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m);
  EXPECT_GT(m.matched_poses, 900u) << "every GPS fix is matched";
  EXPECT_LE(*m.ate_rmse_m, 5.0);
  EXPECT_LE(*m.ate_rmse_m, 0.2 * *m.dead_reckoning_ate_rmse_m)
      << "SLAM " << *m.ate_rmse_m << " m, dead reckoning " << *m.dead_reckoning_ate_rmse_m << " m";
  // The literature's maps of the park hold about 150 trees after association.
  EXPECT_GE(m.landmarks, 100u);
  EXPECT_LE(m.landmarks, 300u);
  EXPECT_FALSE(m.nees_pose.has_value()) << "GPS has no heading: no pose NEES";
}

}  // namespace

TEST(VictoriaParkSlam, EkfWithJcbbOnTheFullRun) {
  SLAMKIT_REQUIRE_DATASET(test_data::shared_dataset("victoria_park"));
  expect_good_run(run_victoria_park("ekf", AssociationMethod::kJcbb));
}

TEST(VictoriaParkSlam, EkfWithNearestNeighbourOnTheFullRun) {
  SLAMKIT_REQUIRE_DATASET(test_data::shared_dataset("victoria_park"));
  expect_good_run(run_victoria_park("ekf", AssociationMethod::kNearestNeighbour));
}

TEST(VictoriaParkSlam, FastSlam2WithHundredParticlesOnTheFullRun) {
  SLAMKIT_REQUIRE_DATASET(test_data::shared_dataset("victoria_park"));
  expect_good_run(run_victoria_park("fastslam2", AssociationMethod::kNearestNeighbour, 100));
}

// The park's raw laser as range scans, with the car's real odometry: the grid filters map the same
// log the landmark filters do. Over the first 150 s (a window: the whole run takes minutes) both map
// every scan and mark the trees; scan matching ends below dead reckoning's error against GPS (1.32
// against 1.63 m; a park's few trunks leave the match rough, and its result follows small changes
// of the method: 0.84 m before the match weighed the odometry). Grid FastSLAM's error is not bounded here: its particles sample the park's
// deliberately wide odometry noise wherever a scan matches too little (docs/grid-mapping.md), so
// with 5 particles one build gives 1.21 m and another (clang, sanitizers) 2.63 m.
TEST(VictoriaParkSlam, GridFiltersMapTheRawLaserOfTheFirstMinutes) {
  SLAMKIT_REQUIRE_DATASET(test_data::shared_dataset("victoria_park"));
  VictoriaParkOptions window;
  window.end_time = 150.0;
  const Dataset data = read_victoria_park(test_data::shared_dataset("victoria_park").string(), window);
  for (const FilterKind kind : {FilterKind::kScanMatching, FilterKind::kGridFastSlam}) {
    FilterConfig config;
    config.filter = kind;
    config.particles = 5;
    config.grid.grid.resolution = 0.1;
    auto filter = make_filter(config, data);
    const RunResult run = run_filter(*filter, data);
    EXPECT_FALSE(run.partial);
    EXPECT_GT(run.scans, 600u) << "every scan of the window is mapped";
    ASSERT_FALSE(run.grid.empty());
    const auto occupied = std::count_if(run.grid.log_odds.begin(), run.grid.log_odds.end(),
                                        [](float l) { return l > 0.0f; });
    EXPECT_GT(occupied, 100) << "trees and bushes mapped";
    const Metrics m = evaluate_run(run, data.truth);
    ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m);
    EXPECT_GT(m.matched_poses, 90u) << "every GPS fix of the window is matched";
    if (kind == FilterKind::kScanMatching)
      EXPECT_LT(*m.ate_rmse_m, *m.dead_reckoning_ate_rmse_m)
          << *m.ate_rmse_m << " m, dead reckoning " << *m.dead_reckoning_ate_rmse_m << " m";
  }
}

// Issue 10's bound, against the EKF with JCBB (1.55 m: bound 2.33 m). Sampling the whole proposal
// (pose_sample_fraction 1) misses it in all three seeds (ATE 4.10, 3.50, 2.63 m: each run's path is
// one draw from a posterior metres wide); carrying 99% of it as a Gaussian per particle meets it
// (1.77, 1.68, 1.70 m). Seeds from the tuning set, not the ones docs/results.md reports; one test each, so
// that they run side by side (the sanitized build runs the first only: a run takes minutes there).
class VictoriaParkFastSlamSeed : public ::testing::TestWithParam<std::uint64_t> {};

TEST_P(VictoriaParkFastSlamSeed, StaysWithinHalfAgainTheEkf) {
  SLAMKIT_REQUIRE_DATASET(test_data::shared_dataset("victoria_park"));
  const Metrics ekf = run_victoria_park("ekf", AssociationMethod::kJcbb);
  ASSERT_TRUE(ekf.ate_rmse_m);
  const Metrics fastslam = run_victoria_park("fastslam2", AssociationMethod::kNearestNeighbour, 100, GetParam(), 0.01);
  ASSERT_TRUE(fastslam.ate_rmse_m);
  EXPECT_LE(*fastslam.ate_rmse_m, 1.5 * *ekf.ate_rmse_m) << "EKF " << *ekf.ate_rmse_m << " m";
}

INSTANTIATE_TEST_SUITE_P(TuningSeeds, VictoriaParkFastSlamSeed, ::testing::Values(11, 17, 18));

// Issue 11's bound for the UKF: its ATE within 10% of the EKF's (1.55 m, both with JCBB). The
// textbook (augmented) UKF misses it (1.80 m): the park's control noise is an allowance for model
// error (2 m/s, 6 degrees of steering), and through the sigma points its curvature moves the mean
// (the car turns about 1% more on average). Added as zero-mean process noise it moves nothing; the
// ATE is 1.54 m, and 0.94-1.05 of the EKF's over the 19 settings of
// campaigns/victoria-park-sensitivity.json, where the augmented UKF is at 1.05-1.30
// (docs/consistency.md).
TEST(VictoriaParkSlam, UkfWithAdditiveControlNoiseWithinTenPercentOfTheEkf) {
  SLAMKIT_REQUIRE_DATASET(test_data::shared_dataset("victoria_park"));
  FilterConfig config;
  config.association.method = AssociationMethod::kJcbb;
  const Metrics ekf = run_victoria_park(config);
  config.filter = FilterKind::kUkf;
  config.ukf_noise = UkfNoise::kAdditive;
  const Metrics ukf = run_victoria_park(config);
  ASSERT_TRUE(ekf.ate_rmse_m && ukf.ate_rmse_m);
  expect_good_run(ukf);
  EXPECT_LE(*ukf.ate_rmse_m, 1.1 * *ekf.ate_rmse_m) << "EKF " << *ekf.ate_rmse_m << " m";
}
