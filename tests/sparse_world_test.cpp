// The sparse test bed (sparse_world, scenarios sparse and sparse-cluttered) and world start poses:
// the world where association and consistency are hard, so its properties are pinned down here.
#include <gtest/gtest.h>

#include "test_data.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace slamkit {
namespace {

using test_data::input_error_at;
using test_data::ScratchDir;

double distance_to_closed_route(const World& w, const Vector2& p) {
  double d = 1e300;
  const std::size_t n = w.waypoints.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vector2 a = w.waypoints[i], ab = w.waypoints[(i + 1) % n] - a;
    const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    d = std::min(d, (a + t * ab - p).norm());
  }
  return d;
}

TEST(SparseWorld, ThirtyFiveLandmarksBesideASixHundredMetreLoopWithTurns) {
  const World w = sparse_world();
  ASSERT_EQ(w.landmarks.size(), 35U);
  EXPECT_TRUE(w.closed);
  ASSERT_TRUE(w.start.has_value());
  EXPECT_EQ(*w.start, Pose2::Zero());

  double length = 0.0;
  int turns = 0;
  const std::size_t n = w.waypoints.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vector2 in = w.waypoints[i] - w.waypoints[(i + n - 1) % n], out = w.waypoints[(i + 1) % n] - w.waypoints[i];
    length += out.norm();
    if (std::abs(wrap_angle(std::atan2(out.y(), out.x()) - std::atan2(in.y(), in.x()))) > deg2rad(30.0)) ++turns;
  }
  EXPECT_GT(length, 600.0);
  EXPECT_LT(length, 680.0);
  EXPECT_GE(turns, 6);

  std::set<int> ids;
  for (const Landmark& l : w.landmarks) {
    ids.insert(l.id);
    const double d = distance_to_closed_route(w, l.position);
    EXPECT_GE(d, 4.0 - 1e-9) << l.id;
    EXPECT_LE(d, 25.0 + 1e-9) << l.id;
    for (const Landmark& m : w.landmarks)
      if (m.id != l.id) EXPECT_GE((m.position - l.position).norm(), 8.0) << l.id << " " << m.id;
  }
  EXPECT_EQ(ids.size(), 35U);

  const World again = sparse_world();
  EXPECT_EQ(again.waypoints, w.waypoints);
  for (std::size_t i = 0; i < w.landmarks.size(); ++i) EXPECT_EQ(again.landmarks[i].position, w.landmarks[i].position);
}

TEST(SparseScenario, ForwardSensorSeesAboutOneAndAHalfLandmarksAndClosesItsLoopTwice) {
  const Scenario s = scenario("sparse");
  EXPECT_NEAR(rad2deg(s.config.fov), 180.0, 1e-9);
  EXPECT_EQ(s.config.loops, 2);
  EXPECT_TRUE(s.config.provide_ids);
  EXPECT_EQ(s.config.clutter_rate, 0.0);

  const Dataset d = simulate(s.world, s.config);
  EXPECT_EQ(d.initial_pose, Pose2::Zero());
  EXPECT_EQ(d.truth.poses.front().pose, Pose2::Zero());

  std::size_t observations = 0, controls = 0;
  double longest_blind_s = 0.0, last_scan_t = 0.0, end_t = 0.0;
  std::set<int> seen_early, seen_late;
  for (const Event& e : d.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      ++controls;
      end_t = c->t;
      continue;
    }
    const auto& scan = std::get<ScanEvent>(e);
    longest_blind_s = std::max(longest_blind_s, scan.t - last_scan_t);
    last_scan_t = scan.t;
    for (const Observation& o : scan.observations) {
      ++observations;
      EXPECT_LE(std::abs(o.z[1]), 0.5 * s.config.fov + 5.0 * deg2rad(1.0));
      if (scan.t < 30.0) seen_early.insert(o.id);
    }
  }
  // The second lap (and each lap's return to the start) re-observes the first landmarks.
  for (const Event& e : d.events)
    if (const auto* scan = std::get_if<ScanEvent>(&e); scan && scan->t > 0.45 * end_t)
      for (const Observation& o : scan->observations) seen_late.insert(o.id);
  const double sweeps = static_cast<double>(controls) * s.config.control_period / s.config.observation_period;
  const double per_sweep = static_cast<double>(observations) / sweeps;
  EXPECT_GT(per_sweep, 1.2);
  EXPECT_LT(per_sweep, 1.7);
  EXPECT_GT(longest_blind_s, 10.0);  // stretches with no landmark in view at all
  ASSERT_GE(seen_early.size(), 2U);
  for (const int id : seen_early) EXPECT_TRUE(seen_late.count(id)) << id;
}

TEST(SparseScenario, ClutteredVariantHasTheClutteredDetection) {
  const Scenario s = scenario("sparse-cluttered");
  EXPECT_EQ(s.world.waypoints, sparse_world().waypoints);
  EXPECT_NEAR(rad2deg(s.config.fov), 180.0, 1e-9);
  EXPECT_EQ(s.config.clutter_rate, 1.0);
  EXPECT_EQ(s.config.detection_probability, 0.9);
  EXPECT_FALSE(s.config.provide_ids);
}

TEST(WorldStart, RoundTripsThroughTheWorldFileAndStartsTheVehicleThere) {
  const ScratchDir scratch;
  World w = sparse_world();
  w.start = Pose2(-5.0, 2.5, deg2rad(30.0));
  write_world(scratch.file("w.txt"), w);
  const World r = read_world(scratch.file("w.txt"));
  ASSERT_TRUE(r.start.has_value());
  EXPECT_NEAR(((*r.start) - (*w.start)).norm(), 0.0, 1e-12);

  SimulatorConfig c;
  c.loops = 1;
  const Dataset d = simulate(r, c);
  EXPECT_NEAR((d.initial_pose - *w.start).norm(), 0.0, 1e-12);
  EXPECT_NEAR((d.truth.poses.front().pose - *w.start).norm(), 0.0, 1e-12);
  // It drives to the first waypoint from there, and round the route.
  const auto reached = std::any_of(d.truth.poses.begin(), d.truth.poses.end(), [&](const StampedPose& p) {
    return (p.pose.head<2>() - w.waypoints.front()).norm() < c.waypoint_tolerance;
  });
  EXPECT_TRUE(reached);

  const std::string path = scratch.file("plain.txt");
  std::ofstream(path) << "waypoint 0 0\nwaypoint 10 0\n";
  EXPECT_FALSE(read_world(path).start.has_value());
}

TEST(WorldStart, BadStartLinesAreNamed) {
  const ScratchDir scratch;
  const std::string path = scratch.file("w.txt");
  const std::string good = "waypoint 0 0\nwaypoint 10 0\n";
  std::ofstream(path) << good << "start 1 2\n";
  EXPECT_NE(input_error_at([&] { read_world(path); }, path, 3).find("start <x> <y> <heading_deg>"), std::string::npos);
  std::ofstream(path) << "start 0 0 0\n" << good << "start 1 2 3\n";
  EXPECT_NE(input_error_at([&] { read_world(path); }, path, 4).find("duplicate start line (first on line 1)"),
            std::string::npos);
  std::ofstream(path) << good << "start 0 nan 0\n";
  input_error_at([&] { read_world(path); }, path, 3);
}

}  // namespace
}  // namespace slamkit
