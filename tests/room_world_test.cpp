// The MRCLAM-like room (sim/world.hpp, room_world; the "room" scenario) and issue 26's failure in it:
// the first-estimates EKF losing a robot that the plain EKF keeps.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

using namespace slamkit;

namespace {

TEST(RoomWorld, IsAnMrclamLikeRoomWithABlindStartAndRandomWaypoints) {
  const World w = room_world();
  ASSERT_EQ(w.landmarks.size(), 15u);
  for (const Landmark& l : w.landmarks) {
    EXPECT_LE(std::abs(l.position.x()), 7.5);
    EXPECT_LE(std::abs(l.position.y()), 4.0);
    for (const Landmark& other : w.landmarks)
      if (other.id != l.id) EXPECT_GE((other.position - l.position).norm(), 1.5);
  }
  EXPECT_EQ(std::count_if(w.landmarks.begin(), w.landmarks.end(), [](const Landmark& l) { return l.position.x() < 0.0; }), 3);
  EXPECT_FALSE(w.closed);
  EXPECT_EQ(w.waypoints.size(), 37u);

  const Scenario room = scenario("room");
  EXPECT_EQ(room.world.waypoints, w.waypoints);
  EXPECT_EQ(room.config.loops, 1);
  EXPECT_DOUBLE_EQ(room.config.fov, deg2rad(70.0));
  EXPECT_EQ(room.config.max_range, 8.0);
  const Dataset d = simulate(room.world, room.config);
  // The robot sees the first landmarks, then none for half a minute and more.
  double longest_blind = 0.0, last_scan = 0.0;
  for (const Event& e : d.events)
    if (const auto* scan = std::get_if<ScanEvent>(&e)) {
      longest_blind = std::max(longest_blind, scan->t - last_scan);
      last_scan = scan->t;
    }
  EXPECT_GT(longest_blind, 30.0);
  EXPECT_GT(d.truth.poses.back().t, 1000.0);
}

// The failure of issue 26 reproduced: a filter told half the odometry noise the robot has (as MRCLAM's
// shipped settings were overconfident) in the room. Landmarks first seen from 6-8 m after a minute of dead
// reckoning are mapped metres from where the filter later puts them. Before the first estimates were
// moved when the belief ruled them out (joint_gaussian.hpp), the first-estimates EKF kept linearising
// there: over this run its ATE was 5.10 m, worse than dead reckoning's 3.63 m, against the plain
// EKF's 0.43 m, with 76% of its identified observations rejected by the gate.
TEST(RoomWorld, TheConsistentVariantsDoNotLoseTheRobotThePlainEkfKeeps) {
  Scenario room = scenario("room");
  room.config.seed = 6;
  Dataset d = simulate(room.world, room.config);
  d.motion = std::make_shared<AckermannModel>(
      AckermannModel::Params{room.config.wheelbase, room.config.sigma_speed / 2.0, room.config.sigma_steer / 2.0});
  std::map<std::string, double> ate, rejected;
  for (const std::string variant : {"full", "fej", "invariant"}) {
    FilterConfig config;
    config.ekf_variant = parse_ekf_variant(variant);
    auto filter = make_filter(config, d);
    const RunResult run = run_filter(*filter, d);
    const Metrics m = evaluate_run(run, d.truth);
    ate[variant] = *m.ate_rmse_m;
    rejected[variant] = run.statistics.at("outliers_rejected") / static_cast<double>(run.observations);
    EXPECT_LT(ate[variant], *m.dead_reckoning_ate_rmse_m) << variant;
    // The gate's own verdict (assoc/gate_tally.hpp), and a bound far below the 76% of a lost robot.
    EXPECT_FALSE(run.statistics.contains("known_id_lost_at_s")) << variant;
    EXPECT_LT(rejected[variant], 0.05) << variant;
  }
  EXPECT_LT(ate["fej"], 1.5 * ate["full"]);
  EXPECT_LT(ate["invariant"], 1.5 * ate["full"]);
}

// A filter that has lost itself with known identities: on this world of the sparse family (a tuning
// world) the first-estimates EKF comes back to its old landmarks with a drift its covariance does not
// admit, and its gate rejects them from then on (53% of all observations; ATE 39.6 m, dead
// reckoning's 7.4 m). Held as copies outside the map, the rejected observations show one rigid motion
// between where the filter sees its old landmarks and where it mapped them; the pose covariance takes
// that drift, and the gate lets the old landmarks correct it.
TEST(KnownIdentityRecovery, AFilterWhoseGateRejectsItsOldMapFindsItAgain) {
  Scenario world = world_family("sparse").member(11);
  world.config.seed = 1;
  const Dataset d = simulate(world.world, world.config);
  std::map<bool, Metrics> metrics;
  std::map<bool, std::map<std::string, double>> statistics;
  for (const bool recover : {false, true}) {
    FilterConfig config;
    config.ekf_variant = EkfVariant::kFirstEstimates;
    config.association.method = AssociationMethod::kKnown;
    if (!recover) config.association.relocalise_min_pairs = 0;
    auto filter = make_filter(config, d);
    const RunResult run = run_filter(*filter, d);
    metrics[recover] = evaluate_run(run, d.truth);
    statistics[recover] = run.statistics;
  }
  EXPECT_TRUE(statistics[false].contains("known_id_lost_at_s"));
  EXPECT_GT(statistics[false].at("known_id_rejected_fraction"), 0.4);
  EXPECT_FALSE(statistics[false].contains("known_id_recoveries"));
  EXPECT_GE(statistics[true].at("known_id_recoveries"), 1.0);
  EXPECT_LT(statistics[true].at("known_id_rejected_fraction"), 0.15);
  EXPECT_LT(*metrics[true].ate_rmse_m, 0.25 * *metrics[false].ate_rmse_m);  // 4.3 m
  EXPECT_LT(*metrics[true].ate_rmse_m, *metrics[true].dead_reckoning_ate_rmse_m);
}

}  // namespace
