#pragma once
// Simulated buildings for laser SLAM: a floor plan of wall segments, a differential-drive robot that
// follows a route of waypoints through it, and a planar laser whose beams are cast against the walls,
// with range noise, a maximum range and missed returns, and odometry noise. The result is a Dataset of
// ControlEvents (OdometryModel) and RangeScanEvents with the true trajectory.
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/dataset.hpp"

namespace slamkit {

struct WallSegment {
  Vector2 a = Vector2::Zero();
  Vector2 b = Vector2::Zero();
};

/// Walls and the route a robot drives through them (closed: the last waypoint leads back to the
/// first), starting at the first waypoint facing the second.
struct FloorPlan {
  std::string name;
  std::vector<WallSegment> walls;
  std::vector<Vector2> route;
};

/// A built-in office of 20 m x 15 m: a corridor ringing two rooms and ringed by eight, furnished, with
/// doorways every few metres; the route (51 m) drives the ring and circles a table in one room.
FloorPlan office_floor_plan();
/// A large building (80 m x 60 m) with 2.5 m corridors between four blocks of rooms; the route is
/// one loop of 270 m, with a blank stretch where a forward laser of 20 m sees only two parallel walls
/// for 19 m.
FloorPlan corridor_building_floor_plan();
/// The office's loop made large (35 m x 25 m): a 2.5 m corridor round a block of offices, the route
/// one lap of 110 m, the offices always on the robot's left. The hard case of docs/grid-mapping.md:
/// scan matching alone drifts here.
FloorPlan ring_floor_plan();
/// "office", "corridors" or "ring"; throws std::invalid_argument naming the accepted values otherwise.
FloorPlan floor_plan(const std::string& name);
std::vector<std::string> floor_plan_names();

/// The JSON keys (to_json, building_sim_config_from_json) are the fields' names with their units:
/// speed_mps, max_turn_rate_deg_per_s, control_period_s, scan_distance_m, scan_rotation_deg, fov_deg,
/// max_range_m, sigma_range_m; the others as named here.
struct BuildingSimConfig {
  std::uint64_t seed = 1;
  int loops = 2;                       // laps of the route
  double speed = 0.5;                  // m/s
  double max_turn_rate = deg2rad(45);  // rad/s
  double control_period = 0.1;         // s between odometry readings
  /// A scan is taken when the robot has moved this far or turned this much since the last one (as
  /// the Radish logs were kept), and at the start.
  double scan_distance = 0.25;          // m
  double scan_rotation = deg2rad(15.0);  // rad
  // Laser.
  int beams = 181;
  double fov = kPi;                  // rad, centred on the heading
  double max_range = 20.0;           // m: beyond it, the reading is max_range (no return)
  double sigma_range = 0.01;         // m
  double missed_return_probability = 0.01;  // per beam: reads max_range
  // Odometry noise, as made odometry's (io/carmen.hpp MadeOdometry), per control period: each true
  // increment (rot1, trans, rot2) is perturbed with sd(rot)^2 = (rotation_per_rad rot)^2 +
  // (rotation_per_m trans)^2 and sd(trans) = translation_per_m trans. The sd is proportional to each
  // increment, so the variance gained per metre is proportional to the increment's length: halving
  // the control period halves it.
  double translation_per_m = 0.05;
  double rotation_per_rad = 0.05;
  double rotation_per_m = 0.02;
};

/// Throws an InputError naming `source` and the first setting out of its range.
void validate(const BuildingSimConfig& config, const std::string& source);
nlohmann::json to_json(const BuildingSimConfig& config);
/// Reads what to_json writes; missing keys keep their defaults, an unknown key or a value of the
/// wrong type or out of range is an InputError naming `source_name` and the key.
BuildingSimConfig building_sim_config_from_json(const nlohmann::json& json, const std::string& source_name);

/// Drives the plan's route and records what the robot's odometry and laser say. Deterministic in
/// config.seed, bit for bit with every standard library (the draws are slamkit's own transforms of
/// std::mt19937_64, as in simulate()).
///
/// The robot starts at the first waypoint facing the second and follows the closed route `loops`
/// times by pure pursuit (a look-ahead point 0.3 m, or three control steps, ahead along the route),
/// slowing down where the turn rate would exceed max_turn_rate and turning on the spot where the
/// look-ahead point is behind it; it stops back at the first waypoint. Every control period it
/// yields a ControlEvent for the OdometryModel: the controls between consecutive odometry poses,
/// which chain the noisy true increments, so dead reckoning drifts. A RangeScanEvent (the laser at
/// the robot's centre) follows at t = 0 and right after each control that ends where the odometry
/// has moved scan_distance or turned scan_rotation since the last scan.
///
/// Dataset: spec "building:<plan name>", name the plan's name, initial_pose the true start (the
/// estimate lives in the truth's frame); the truth holds the true pose at t = 0 and at every control,
/// with headings, and no landmarks; motion an OdometryModel that states the odometry noise exactly
/// (alpha_rot_rot = rotation_per_rad^2, alpha_rot_trans = rotation_per_m^2, alpha_trans_trans =
/// translation_per_m^2, alpha_trans_rot = 0, the default variance floor), observation null, sensor
/// the laser's max_range and fov.
///
/// Throws InputError for an invalid config, a route of fewer than 2 waypoints, one that crosses a
/// wall, or one the robot cannot follow.
Dataset simulate_building(const FloorPlan& plan, const BuildingSimConfig& config = {});

/// The distance from `origin` along `bearing` (world frame) to the nearest wall, or +infinity. Walls
/// have no thickness: a ray along a wall's own line does not see it.
double cast_ray(const FloorPlan& plan, const Vector2& origin, double bearing);

/// The distance from `p` to the nearest wall (+infinity for a plan without walls): the clearance a
/// route or a trajectory keeps.
double distance_to_nearest_wall(const FloorPlan& plan, const Vector2& p);

}  // namespace slamkit
