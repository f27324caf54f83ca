#include "slamkit/sim/building.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "slamkit/core/error.hpp"
#include "slamkit/models/motion_model.hpp"

// A namespace of its own: the tests are compiled in batches of one translation unit.
namespace slamkit::building_sim_test {

constexpr double kInf = std::numeric_limits<double>::infinity();

FloorPlan walls_only(std::vector<WallSegment> walls) {
  FloorPlan plan;
  plan.name = "test";
  plan.walls = std::move(walls);
  return plan;
}

// The walls of the box [x0, x1] x [y0, y1].
std::vector<WallSegment> box(double x0, double y0, double x1, double y1) {
  return {{{x0, y0}, {x1, y0}}, {{x1, y0}, {x1, y1}}, {{x1, y1}, {x0, y1}}, {{x0, y1}, {x0, y0}}};
}

double lap_length(const FloorPlan& plan) {
  double length = 0.0;
  for (std::size_t i = 0; i < plan.route.size(); ++i)
    length += (plan.route[(i + 1) % plan.route.size()] - plan.route[i]).norm();
  return length;
}

std::vector<ControlEvent> controls(const Dataset& d) {
  std::vector<ControlEvent> out;
  for (const Event& e : d.events)
    if (const auto* c = std::get_if<ControlEvent>(&e)) out.push_back(*c);
  return out;
}

std::vector<RangeScanEvent> range_scans(const Dataset& d) {
  std::vector<RangeScanEvent> out;
  for (const Event& e : d.events)
    if (const auto* s = std::get_if<RangeScanEvent>(&e)) out.push_back(*s);
  return out;
}

// The truth's pose at time t: the simulator records one at t = 0 and one per control.
const Pose2& true_pose_at(const Dataset& d, double t) {
  const auto p = std::lower_bound(d.truth.poses.begin(), d.truth.poses.end(), t,
                                  [](const StampedPose& s, double time) { return s.t < time; });
  if (p == d.truth.poses.end() || p->t != t) throw std::logic_error("no true pose at the time of a scan");
  return p->pose;
}

// Where the controls chained from the initial pose put the robot after each control.
std::vector<Pose2> odometry_poses(const Dataset& d) {
  std::vector<Pose2> poses{d.initial_pose};
  for (const ControlEvent& c : controls(d)) poses.push_back(d.motion->predict(poses.back(), c.u, c.dt));
  return poses;
}

double end_point_drift(const Dataset& d) {
  return (odometry_poses(d).back().head<2>() - d.truth.poses.back().pose.head<2>()).norm();
}

BuildingSimConfig noise_free_laser() {
  BuildingSimConfig c;
  c.sigma_range = 0.0;
  c.missed_return_probability = 0.0;
  return c;
}

// ---- cast_ray ---------------------------------------------------------------------------------------

TEST(BuildingCastRay, StraightAtAWallIsItsDistance) {
  const FloorPlan plan = walls_only({{{5.0, -1.0}, {5.0, 1.0}}});
  EXPECT_EQ(cast_ray(plan, {0.0, 0.0}, 0.0), 5.0);
  EXPECT_NEAR(cast_ray(plan, {0.0, 0.0}, std::atan2(1.0, 5.0)), std::hypot(5.0, 1.0), 1e-12);  // its end
  EXPECT_EQ(cast_ray(plan, {0.0, 0.0}, kPi), kInf);                                          // behind
  EXPECT_EQ(cast_ray(plan, {0.0, 0.0}, std::atan2(1.1, 5.0)), kInf);                         // past its end
}

TEST(BuildingCastRay, ParallelToAWallMissesIt) {
  const FloorPlan plan = walls_only({{{1.0, 1.0}, {6.0, 1.0}}, {{1.0, 0.0}, {6.0, 0.0}}});
  EXPECT_EQ(cast_ray(plan, {0.0, 0.5}, 0.0), kInf);
  // Along a wall's own line: it has no thickness.
  EXPECT_EQ(cast_ray(plan, {0.0, 0.0}, 0.0), kInf);
}

TEST(BuildingCastRay, FromInsideABoxHitsTheWallAheadNearestFirst) {
  std::vector<WallSegment> walls = box(0.0, 0.0, 10.0, 4.0);
  walls.push_back({{6.0, 3.0}, {6.0, 0.5}});  // a screen in front of the right wall
  const FloorPlan plan = walls_only(walls);
  const Vector2 origin(2.0, 1.0);
  EXPECT_EQ(cast_ray(plan, origin, 0.0), 4.0);
  EXPECT_NEAR(cast_ray(plan, {2.0, 3.5}, 0.0), 8.0, 1e-12);  // above the screen: the right wall
  EXPECT_NEAR(cast_ray(plan, origin, kPi / 2.0), 3.0, 1e-12);
  EXPECT_NEAR(cast_ray(plan, origin, kPi), 2.0, 1e-12);
  EXPECT_NEAR(cast_ray(plan, origin, -kPi / 2.0), 1.0, 1e-12);
  EXPECT_NEAR(cast_ray(plan, origin, kPi / 4.0), 3.0 * std::sqrt(2.0), 1e-12);  // the top wall at (5, 4)
}

TEST(BuildingCastRay, NothingToHitIsInfinity) {
  EXPECT_EQ(cast_ray(walls_only({}), {0.0, 0.0}, 0.3), kInf);
  EXPECT_EQ(cast_ray(walls_only(box(0.0, 0.0, 1.0, 1.0)), {3.0, 3.0}, 0.0), kInf);
}

TEST(BuildingCastRay, DistanceToTheNearestWall) {
  const FloorPlan plan = walls_only(box(0.0, 0.0, 10.0, 4.0));
  EXPECT_NEAR(distance_to_nearest_wall(plan, {2.0, 1.0}), 1.0, 1e-12);
  EXPECT_NEAR(distance_to_nearest_wall(plan, {13.0, 8.0}), 5.0, 1e-12);  // to the corner (10, 4)
  EXPECT_EQ(distance_to_nearest_wall(walls_only({}), {0.0, 0.0}), kInf);
}

// ---- Floor plans ------------------------------------------------------------------------------------

TEST(BuildingFloorPlan, ByNameAndUnknownNamesListTheKnownOnes) {
  EXPECT_EQ(floor_plan_names(), (std::vector<std::string>{"office", "corridors", "ring"}));
  for (const std::string& name : floor_plan_names()) EXPECT_EQ(floor_plan(name).name, name);
  try {
    floor_plan("ofice");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("did you mean 'office'"), std::string::npos) << what;
    EXPECT_NE(what.find("office, corridors, ring"), std::string::npos) << what;
  }
}

TEST(BuildingFloorPlan, SizesAndRoutes) {
  const auto extent = [](const FloorPlan& plan) -> Vector2 {  // not an expression of its locals
    Vector2 lo = plan.walls.front().a, hi = lo;
    for (const WallSegment& w : plan.walls) {
      lo = lo.cwiseMin(w.a).cwiseMin(w.b);
      hi = hi.cwiseMax(w.a).cwiseMax(w.b);
    }
    return hi - lo;
  };
  const FloorPlan office = office_floor_plan(), corridors = corridor_building_floor_plan(), ring = ring_floor_plan();
  EXPECT_EQ(extent(office), Vector2(20.0, 15.0));
  EXPECT_EQ(extent(corridors), Vector2(80.0, 60.0));
  EXPECT_EQ(extent(ring), Vector2(35.0, 25.0));
  EXPECT_GT(lap_length(corridors), 100.0);
  EXPECT_NEAR(lap_length(ring), 110.0, 1e-9);
  // Every route keeps well clear of every wall, door jambs included.
  for (const FloorPlan& plan : {office, corridors, ring}) {
    for (std::size_t i = 0; i < plan.route.size(); ++i) {
      const Vector2 a = plan.route[i], b = plan.route[(i + 1) % plan.route.size()];
      for (int k = 0; k <= 200; ++k)
        ASSERT_GE(distance_to_nearest_wall(plan, a + (b - a) * (k / 200.0)), 0.7 - 1e-9) << plan.name << " leg " << i;
    }
  }
}

// The directions (mod pi) of the walls the beams of a noise-free scan hit: those that pass through
// the point hit (a plan of each of `walls`).
std::vector<double> wall_directions_seen(const FloorPlan& plan, const std::vector<FloorPlan>& walls, const Pose2& pose,
                                         const RangeScanEvent& scan) {
  std::vector<double> directions;
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    const double bearing = pose[2] + scan.bearing(i);
    const double range = cast_ray(plan, pose.head<2>(), bearing);
    if (range >= scan.max_range) continue;
    const Vector2 hit = pose.head<2>() + range * Vector2(std::cos(bearing), std::sin(bearing));
    for (const FloorPlan& wall : walls) {
      if (distance_to_nearest_wall(wall, hit) > 1e-9) continue;
      const Vector2 e = wall.walls.front().b - wall.walls.front().a;
      directions.push_back(std::fmod(std::atan2(e.y(), e.x()) + kPi, kPi));
    }
  }
  return directions;
}

// Whether the walls seen include two at least 45 degrees apart: then a scan fixes both position
// coordinates; along two parallel walls it cannot.
bool fixes_both_coordinates(const std::vector<double>& directions) {
  for (const double a : directions)
    for (const double b : directions) {
      const double apart = std::abs(a - b);
      if (std::min(apart, kPi - apart) >= kPi / 4.0) return true;
    }
  return false;
}

TEST(BuildingFloorPlan, EveryOfficeScanSeesCornersButTheCorridorsHaveABlankStretch) {
  for (const FloorPlan& plan : {office_floor_plan(), corridor_building_floor_plan()}) {
    BuildingSimConfig c = noise_free_laser();
    c.loops = 1;
    const Dataset d = simulate_building(plan, c);
    std::vector<FloorPlan> walls;
    for (const WallSegment& w : plan.walls) walls.push_back(walls_only({w}));
    int blind = 0;
    for (const RangeScanEvent& scan : range_scans(d))
      if (!fixes_both_coordinates(wall_directions_seen(plan, walls, true_pose_at(d, scan.t), scan))) ++blind;
    if (plan.name == "office") {
      EXPECT_EQ(blind, 0);
    } else {
      // The first 19 m of the cross corridor's blank half: about 70 scans.
      EXPECT_GT(blind, 60);
      EXPECT_LT(blind, 90);
    }
  }
}

// ---- Config -----------------------------------------------------------------------------------------

TEST(BuildingSimConfig, JsonRoundTripAndErrors) {
  BuildingSimConfig c;
  c.seed = 9;
  c.loops = 3;
  c.max_turn_rate = deg2rad(30.0);
  c.fov = deg2rad(270.0);
  c.beams = 541;
  const nlohmann::json json = to_json(c);
  EXPECT_EQ(json.at("max_turn_rate_deg_per_s"), 30.0);
  EXPECT_EQ(json.at("fov_deg"), 270.0);
  const BuildingSimConfig back = building_sim_config_from_json(json, "config.json");
  EXPECT_EQ(to_json(back), json);
  EXPECT_THROW(building_sim_config_from_json({{"beam", 3}}, "config.json"), InputError);
  EXPECT_THROW(building_sim_config_from_json({{"beams", 1}}, "config.json"), InputError);
  BuildingSimConfig bad;
  bad.missed_return_probability = 1.5;
  EXPECT_THROW(validate(bad, "test"), InputError);
  EXPECT_THROW(simulate_building(office_floor_plan(), bad), InputError);
}

TEST(BuildingSimConfig, RefusesARouteThroughAWallOrOfOnePoint) {
  FloorPlan plan = walls_only(box(0.0, 0.0, 10.0, 10.0));
  plan.walls.push_back({{5.0, 0.0}, {5.0, 6.0}});
  plan.route = {{2.0, 2.0}, {8.0, 2.0}, {8.0, 8.0}, {2.0, 8.0}};
  EXPECT_THROW(simulate_building(plan), InputError);
  plan.walls.pop_back();
  EXPECT_NO_THROW(simulate_building(plan));
  plan.route = {{2.0, 2.0}};
  EXPECT_THROW(simulate_building(plan), InputError);
}

// ---- The simulation ---------------------------------------------------------------------------------

TEST(BuildingSim, DatasetShape) {
  const FloorPlan plan = office_floor_plan();
  const BuildingSimConfig c;
  const Dataset d = simulate_building(plan, c);
  EXPECT_EQ(d.spec, "building:office");
  EXPECT_EQ(d.name, "office");
  ASSERT_NE(d.motion, nullptr);
  EXPECT_EQ(d.motion->name(), "odometry");
  EXPECT_EQ(d.observation, nullptr);
  EXPECT_TRUE(d.truth.poses_have_heading);
  EXPECT_TRUE(d.truth.landmarks.empty());
  EXPECT_EQ(d.initial_pose, d.truth.poses.front().pose);
  EXPECT_EQ(d.initial_pose, Pose2(5.0, 4.0, 0.0));  // the first waypoint, facing the second
  EXPECT_EQ(d.truth.poses.size(), controls(d).size() + 1);
  // A scan first, at t = 0; every other right after the control of its time.
  ASSERT_TRUE(std::holds_alternative<RangeScanEvent>(d.events.front()));
  for (std::size_t i = 1; i < d.events.size(); ++i) {
    if (const auto* scan = std::get_if<RangeScanEvent>(&d.events[i])) {
      const auto* control = std::get_if<ControlEvent>(&d.events[i - 1]);
      ASSERT_NE(control, nullptr) << "event " << i;
      EXPECT_EQ(scan->t, control->t);
      EXPECT_EQ(scan->ranges.size(), 181u);
      EXPECT_EQ(scan->angle_min, -kPi / 2.0);
      EXPECT_EQ(scan->angle_increment, kPi / 180.0);
      EXPECT_EQ(scan->max_range, 20.0);
      EXPECT_EQ(scan->sensor_offset, Pose2::Zero());
    }
  }
  for (const ControlEvent& control : controls(d)) {
    EXPECT_EQ(control.dt, c.control_period);
    EXPECT_EQ(control.u.size(), 3);
  }
}

TEST(BuildingSim, DeterministicPerSeedAndDifferentBetweenSeeds) {
  const FloorPlan plan = office_floor_plan();
  BuildingSimConfig c;
  c.seed = 7;
  const Dataset a = simulate_building(plan, c), b = simulate_building(plan, c);
  c.seed = 8;
  const Dataset other = simulate_building(plan, c);
  ASSERT_EQ(a.events.size(), b.events.size());
  for (std::size_t i = 0; i < a.events.size(); ++i) {
    if (const auto* u = std::get_if<ControlEvent>(&a.events[i])) {
      EXPECT_EQ(u->u, std::get<ControlEvent>(b.events[i]).u) << "event " << i;
    } else {
      EXPECT_EQ(std::get<RangeScanEvent>(a.events[i]).ranges, std::get<RangeScanEvent>(b.events[i]).ranges);
    }
  }
  // The truth does not depend on the seed: the robot drives the same path.
  ASSERT_EQ(a.truth.poses.size(), other.truth.poses.size());
  EXPECT_EQ(a.truth.poses.back().pose, other.truth.poses.back().pose);
  EXPECT_NE(controls(a)[10].u, controls(other)[10].u);
  EXPECT_NE(range_scans(a)[10].ranges, range_scans(other)[10].ranges);
}

TEST(BuildingSim, TheRobotKeepsClearOfEveryWall) {
  for (const FloorPlan& plan : {office_floor_plan(), corridor_building_floor_plan()}) {
    const Dataset d = simulate_building(plan);
    double clearance = kInf;
    for (const StampedPose& p : d.truth.poses)
      clearance = std::min(clearance, distance_to_nearest_wall(plan, p.pose.head<2>()));
    EXPECT_GT(clearance, 0.5) << plan.name;
  }
}

TEST(BuildingSim, DrivesTheClosedRouteLoopsTimes) {
  const FloorPlan plan = office_floor_plan();
  for (const int loops : {1, 2, 3}) {
    BuildingSimConfig c;
    c.loops = loops;
    const Dataset d = simulate_building(plan, c);
    double travelled = 0.0;
    int visits = 0;  // to the waypoint farthest along the route, counted as the robot comes within 0.2 m
    bool near = false;
    const Vector2 far_corner(19.0, 1.2);
    for (std::size_t i = 1; i < d.truth.poses.size(); ++i) {
      const Vector2 p = d.truth.poses[i].pose.head<2>();
      travelled += (p - d.truth.poses[i - 1].pose.head<2>()).norm();
      const bool now_near = (p - far_corner).norm() < 0.2;
      if (now_near && !near) ++visits;
      near = now_near;
    }
    EXPECT_EQ(visits, loops);
    EXPECT_NEAR(travelled, loops * lap_length(plan), 0.02 * loops * lap_length(plan));
    EXPECT_LT((d.truth.poses.back().pose.head<2>() - plan.route.front()).norm(), 0.05) << loops << " loops";
  }
}

TEST(BuildingSim, NoiseFreeRangesAreTheRaysCastFromTheTruePose) {
  const FloorPlan plan = office_floor_plan();
  BuildingSimConfig c = noise_free_laser();
  c.max_range = 8.0;  // short of the office's length, so that some beams find nothing
  const Dataset d = simulate_building(plan, c);
  int returns = 0, no_returns = 0;
  for (const RangeScanEvent& scan : range_scans(d)) {
    const Pose2& pose = true_pose_at(d, scan.t);
    for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
      const double hit = cast_ray(plan, pose.head<2>(), pose[2] + scan.bearing(i));
      const float expected = static_cast<float>(std::min(hit, scan.max_range));
      ASSERT_EQ(scan.ranges[i], expected) << "scan at t = " << scan.t << ", beam " << i;
      ++(hit < scan.max_range ? returns : no_returns);
    }
  }
  EXPECT_GT(returns, 10000);
  EXPECT_GT(no_returns, 1000);
}

TEST(BuildingSim, RangeNoiseAndMissedReturnsAsConfigured) {
  const FloorPlan plan = office_floor_plan();
  BuildingSimConfig c;
  c.sigma_range = 0.05;
  c.missed_return_probability = 0.2;
  const Dataset d = simulate_building(plan, c);
  double sum = 0.0, squares = 0.0;
  int hits = 0, missed = 0;
  for (const RangeScanEvent& scan : range_scans(d)) {
    const Pose2& pose = true_pose_at(d, scan.t);
    for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
      const double hit = cast_ray(plan, pose.head<2>(), pose[2] + scan.bearing(i));
      if (hit >= c.max_range - 1.0) continue;  // where noise could carry a reading past the maximum
      if (scan.ranges[i] == static_cast<float>(c.max_range)) {
        ++missed;
        continue;
      }
      const double error = scan.ranges[i] - hit;
      sum += error;
      squares += error * error;
      ++hits;
    }
  }
  const int beams = hits + missed;
  ASSERT_GT(beams, 50000);
  // With 60,000 beams the binomial share's standard deviation is 0.0016, the noise's sd's 0.3%.
  EXPECT_NEAR(static_cast<double>(missed) / beams, 0.2, 0.01);
  EXPECT_NEAR(sum / hits, 0.0, 0.002);
  EXPECT_NEAR(std::sqrt(squares / hits), 0.05, 0.0025);
}

TEST(BuildingSim, ScansWhenTheOdometryHasMovedOrTurnedEnough) {
  const FloorPlan plan = office_floor_plan();
  const BuildingSimConfig c;
  const Dataset d = simulate_building(plan, c);
  // The controls chained are the odometry poses (to rounding): every control that brings them
  // scan_distance or scan_rotation from the last scan's is followed by a scan, and no other.
  Pose2 odometry = d.initial_pose, at_scan = d.initial_pose;
  for (std::size_t i = 1; i < d.events.size(); ++i) {
    const auto* control = std::get_if<ControlEvent>(&d.events[i]);
    if (!control) continue;
    odometry = d.motion->predict(odometry, control->u, control->dt);
    const double moved = (odometry.head<2>() - at_scan.head<2>()).norm();
    const double turned = std::abs(wrap_angle(odometry[2] - at_scan[2]));
    const bool scanned = i + 1 < d.events.size() && std::holds_alternative<RangeScanEvent>(d.events[i + 1]);
    if (scanned) {
      EXPECT_TRUE(moved > c.scan_distance - 1e-9 || turned > c.scan_rotation - 1e-9) << "t = " << control->t;
      at_scan = odometry;
    } else {
      EXPECT_TRUE(moved < c.scan_distance + 1e-9 && turned < c.scan_rotation + 1e-9) << "t = " << control->t;
    }
  }
  // A scan every scan_distance to one control step more, and some more where the robot turns.
  const double travelled = c.loops * lap_length(plan);
  const auto scans = static_cast<double>(range_scans(d).size());
  EXPECT_GT(scans, travelled / (c.scan_distance + c.speed * c.control_period));
  EXPECT_LT(scans, 1.2 * travelled / c.scan_distance);
}

TEST(BuildingSim, OdometryErrorsHaveTheConfiguredSpread) {
  // Four laps: about 4,000 increments of each kind, so that the sample variance of the normalised
  // errors lies within 0.1 of 1 with a margin of four of its standard deviations (0.022), while
  // noise 5% too large or small would be off by 0.1.
  const FloorPlan plan = office_floor_plan();
  BuildingSimConfig c;
  c.loops = 4;
  const Dataset d = simulate_building(plan, c);
  const std::vector<ControlEvent> u = controls(d);
  std::vector<double> trans_errors, rot_errors;
  for (std::size_t k = 0; k < u.size(); ++k) {
    const Control truth = OdometryModel::between(d.truth.poses[k].pose, d.truth.poses[k + 1].pose);
    const double trans = truth[1];
    if (trans > 2e-3) {
      trans_errors.push_back((u[k].u[1] - trans) / (c.translation_per_m * trans));
      for (const int i : {0, 2})
        rot_errors.push_back(wrap_angle(u[k].u[i] - truth[i]) /
                             std::hypot(c.rotation_per_rad * truth[i], c.rotation_per_m * trans));
    } else {
      // A turn on the spot: only its rotation is noisy.
      EXPECT_EQ(u[k].u[1], 0.0);
      rot_errors.push_back(wrap_angle(u[k].u[2] - truth[2]) / (c.rotation_per_rad * std::abs(truth[2])));
    }
  }
  const auto expect_standard_normal = [](const std::vector<double>& e, const char* what) {
    ASSERT_GT(e.size(), 4000u) << what;
    double sum = 0.0, squares = 0.0;
    for (const double x : e) {
      sum += x;
      squares += x * x;
    }
    const double n = static_cast<double>(e.size()), mean = sum / n;
    EXPECT_NEAR(mean, 0.0, 0.1) << what;
    EXPECT_NEAR(squares / n - mean * mean, 1.0, 0.1) << what;
  };
  expect_standard_normal(trans_errors, "translation");
  expect_standard_normal(rot_errors, "rotation");
}

TEST(BuildingSim, TurnsOnTheSpotWhereTheRouteDoublesBack) {
  FloorPlan plan = walls_only(box(0.0, 0.0, 10.0, 10.0));
  plan.route = {{2.0, 2.0}, {8.0, 2.0}};  // there and back
  const Dataset d = simulate_building(plan);
  const std::vector<ControlEvent> u = controls(d);
  int on_the_spot = 0;
  for (std::size_t k = 0; k < u.size(); ++k) {
    const Pose2& from = d.truth.poses[k].pose;
    const Pose2& to = d.truth.poses[k + 1].pose;
    if (to.head<2>() != from.head<2>()) continue;
    ++on_the_spot;
    // As fast as the robot can, and the odometry reads no translation either.
    EXPECT_NEAR(std::abs(wrap_angle(to[2] - from[2])), BuildingSimConfig{}.max_turn_rate * 0.1, 1e-12);
    EXPECT_EQ(u[k].u[0], 0.0);
    EXPECT_EQ(u[k].u[1], 0.0);
  }
  EXPECT_GT(on_the_spot, 4);
  EXPECT_LT((d.truth.poses.back().pose.head<2>() - plan.route.front()).norm(), 0.05);
}

TEST(BuildingSim, DeadReckoningDriftsPlausiblyOnTheOffice) {
  // Two laps of 51 m: the default noise leaves the dead reckoning 0.27 to 1.24 m from the truth at
  // the end (seeds 1 to 5, 0.59 m on average; 0.67 m over seeds 1 to 20), enough for scan matching
  // to correct and little enough to close the loop.
  const FloorPlan plan = office_floor_plan();
  double total = 0.0;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    BuildingSimConfig c;
    c.seed = seed;
    const double drift = end_point_drift(simulate_building(plan, c));
    EXPECT_GT(drift, 0.1) << "seed " << seed;
    EXPECT_LT(drift, 3.0) << "seed " << seed;
    total += drift;
  }
  EXPECT_GT(total / 5.0, 0.4);
  EXPECT_LT(total / 5.0, 2.0);
}

TEST(BuildingSim, TheMotionModelStatesTheOdometryNoise) {
  BuildingSimConfig c;
  c.translation_per_m = 0.1;
  c.rotation_per_rad = 0.2;
  c.rotation_per_m = 0.03;
  const Dataset d = simulate_building(office_floor_plan(), c);
  const auto& model = dynamic_cast<const OdometryModel&>(*d.motion);
  const double floor = model.params().min_variance;
  Control u(3);
  u << 0.04, 0.05, -0.03;
  const ControlCovariance m = model.control_noise(u, c.control_period);
  EXPECT_NEAR(m(0, 0), std::pow(0.2 * 0.04, 2) + std::pow(0.03 * 0.05, 2) + floor, 1e-15);
  EXPECT_NEAR(m(1, 1), std::pow(0.1 * 0.05, 2) + floor, 1e-15);
  EXPECT_NEAR(m(2, 2), std::pow(0.2 * 0.03, 2) + std::pow(0.03 * 0.05, 2) + floor, 1e-15);
  EXPECT_LE(floor, 1e-8);
}

}  // namespace slamkit::building_sim_test
