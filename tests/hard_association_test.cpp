// Association where it is hard: the loop-closure scenario's return scored by evaluate_run's
// loop_closure_fraction (the metric scripts/association_table.sh reports), the existence rule on
// the cluttered sparse world, and JCBB, which FastSLAM does not do per particle, refused.
#include <gtest/gtest.h>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"

namespace slamkit {
namespace {

Dataset simulate_scenario(const std::string& name, std::uint64_t seed) {
  Scenario s = scenario(name);
  s.config.seed = seed;
  s.config.provide_ids = false;
  return simulate(s.world, s.config);
}

struct EkfRun {
  Metrics metrics;
  std::map<std::string, double> statistics;
};

EkfRun run_ekf(const Dataset& d, AssociationMethod method) {
  FilterConfig config;
  config.association.method = method;
  RunResult run = run_filter(*make_filter(config, d), d);
  run.association = to_string(method);
  return {evaluate_run(run, d.truth), run.statistics};
}

TEST(HardAssociation, EkfClosesTheLoopClosureScenariosLoopWithoutDuplicates) {
  const Dataset d = simulate_scenario("loop-closure", 1);
  const Metrics m = run_ekf(d, AssociationMethod::kNearestNeighbour).metrics;
  ASSERT_TRUE(m.association.has_value());
  EXPECT_GT(m.association->return_observations, 1000U) << "the drive past the start re-observes the first landmarks";
  ASSERT_TRUE(m.association->loop_closure_fraction());
  EXPECT_GE(*m.association->loop_closure_fraction(), kLoopClosedFraction);
  EXPECT_EQ(m.association->spurious_landmarks, 0U);
}

// Clutter starts a provisional landmark at every false detection; those that left the view before
// three misses in it used to stay in the EKF's state for good (170-190 of them on this world).
TEST(HardAssociation, ProvisionalLandmarksThatLeaveTheViewUnconfirmedAreRemoved) {
  const Dataset d = simulate_scenario("sparse-cluttered", 1);
  const EkfRun run = run_ekf(d, AssociationMethod::kNearestNeighbour);
  const double provisional = run.statistics.at("landmarks_provisional");
  EXPECT_EQ(provisional, run.statistics.at("landmarks_in_state") - static_cast<double>(run.metrics.landmarks));
  EXPECT_LT(provisional, 60.0);
  ASSERT_TRUE(run.metrics.association.has_value());
  EXPECT_GT(run.metrics.association->clutter_observations, 2000U);
}

TEST(HardAssociation, JcbbForFastSlamIsRefusedNotReplacedByNearestNeighbour) {
  FilterConfig config;
  config.filter = FilterKind::kFastSlam2;
  config.association.method = AssociationMethod::kJcbb;
  EXPECT_THROW(validate(config), std::invalid_argument);
  config.filter = FilterKind::kEkf;
  EXPECT_NO_THROW(validate(config));
  config.filter = FilterKind::kUkf;  // a joint Gaussian too, whose JCBB is the EKF's
  EXPECT_NO_THROW(validate(config));

  const Dataset d = simulate_scenario("sparse", 1);
  FastSlamConfig fs;
  fs.association.method = AssociationMethod::kJcbb;
  EXPECT_THROW(FastSlam(d.motion, d.observation, fs), std::invalid_argument);
}

}  // namespace
}  // namespace slamkit
