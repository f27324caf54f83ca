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
    EXPECT_LT(rejected[variant], 0.05) << variant;
  }
  EXPECT_LT(ate["fej"], 1.5 * ate["full"]);
  EXPECT_LT(ate["invariant"], 1.5 * ate["full"]);
}

}  // namespace
