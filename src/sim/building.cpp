#include "slamkit/sim/building.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <vector>

#include "slamkit/core/checked_integer.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/memory_budget.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/core/random_draws.hpp"

namespace slamkit {
namespace {

// ---- Config keys ------------------------------------------------------------------------------------

using BuildingReal = RealOption<BuildingSimConfig>;
// Beyond these a value is a mistake (a robot at 1e-300 m/s would never finish the route).
constexpr RealRange kRobotSpeed{[](double v) { return v >= 1e-3 && v <= 10.0; }, ">= 0.001 and <= 10 (m/s)"};
constexpr RealRange kOdometryPeriod{[](double v) { return v >= 1e-4 && v <= 10.0; }, ">= 0.0001 and <= 10 (s)"};
constexpr RealRange kLaserReach{[](double v) { return v > 0.0 && v <= 1e3; }, "> 0 and <= 1000 (m)"};
constexpr RealRange kShare{[](double v) { return v >= 0.0 && v <= 1.0; }, ">= 0 and <= 1"};

const OptionKey<BuildingSimConfig> kBuildingKeys[] = {
    {"seed", IntegerOption<BuildingSimConfig, std::uint64_t>{[](BuildingSimConfig& c) -> std::uint64_t& {
       return c.seed;
     }}},
    {"loops", IntegerOption<BuildingSimConfig, int>{[](BuildingSimConfig& c) -> int& { return c.loops; }, 1}},
    {"speed_mps", BuildingReal{[](BuildingSimConfig& c) -> double& { return c.speed; }, kRobotSpeed}},
    {"max_turn_rate_deg_per_s", BuildingReal{[](BuildingSimConfig& c) -> double& { return c.max_turn_rate; },
                                             option_ranges::kPositive, Unit::kDegrees}},
    {"control_period_s",
     BuildingReal{[](BuildingSimConfig& c) -> double& { return c.control_period; }, kOdometryPeriod}},
    {"scan_distance_m",
     BuildingReal{[](BuildingSimConfig& c) -> double& { return c.scan_distance; }, option_ranges::kPositive}},
    {"scan_rotation_deg", BuildingReal{[](BuildingSimConfig& c) -> double& { return c.scan_rotation; },
                                       option_ranges::kPositive, Unit::kDegrees}},
    {"beams", IntegerOption<BuildingSimConfig, int>{[](BuildingSimConfig& c) -> int& { return c.beams; }, 2, 100000}},
    {"fov_deg", BuildingReal{[](BuildingSimConfig& c) -> double& { return c.fov; }, option_ranges::kFieldOfView,
                             Unit::kDegrees}},
    {"max_range_m", BuildingReal{[](BuildingSimConfig& c) -> double& { return c.max_range; }, kLaserReach}},
    {"sigma_range_m",
     BuildingReal{[](BuildingSimConfig& c) -> double& { return c.sigma_range; }, option_ranges::kNonNegative}},
    {"missed_return_probability",
     BuildingReal{[](BuildingSimConfig& c) -> double& { return c.missed_return_probability; }, kShare}},
    {"translation_per_m",
     BuildingReal{[](BuildingSimConfig& c) -> double& { return c.translation_per_m; }, option_ranges::kNonNegative}},
    {"rotation_per_rad",
     BuildingReal{[](BuildingSimConfig& c) -> double& { return c.rotation_per_rad; }, option_ranges::kNonNegative}},
    {"rotation_per_m",
     BuildingReal{[](BuildingSimConfig& c) -> double& { return c.rotation_per_m; }, option_ranges::kNonNegative}},
};

// ---- Geometry ---------------------------------------------------------------------------------------

constexpr double kNoHit = std::numeric_limits<double>::infinity();

// How far along `direction` (in its lengths) the ray from `origin` meets the wall, or kNoHit.
// Solves origin + t direction = a + u (b - a) by Cramer's rule.
double ray_to_wall(const WallSegment& wall, const Vector2& origin, const Vector2& direction) {
  const Vector2 e = wall.b - wall.a, f = wall.a - origin;
  const double denominator = direction.x() * e.y() - direction.y() * e.x();
  // Parallel: a wall seen edge-on has no thickness to reflect the beam.
  if (denominator == 0.0) return kNoHit;
  const double t = (f.x() * e.y() - f.y() * e.x()) / denominator;
  const double u = (f.x() * direction.y() - f.y() * direction.x()) / denominator;
  return t > 0.0 && u >= 0.0 && u <= 1.0 ? t : kNoHit;
}

double distance_to_wall(const WallSegment& wall, const Vector2& p) {
  const Vector2 e = wall.b - wall.a;
  const double squared = e.squaredNorm();
  const double u = squared > 0.0 ? std::clamp((p - wall.a).dot(e) / squared, 0.0, 1.0) : 0.0;
  return (wall.a + u * e - p).norm();
}

// A route through a wall would have the robot drive through it.
void check_route(const FloorPlan& plan) {
  const std::vector<Vector2>& route = plan.route;
  if (route.size() < 2)
    throw InputError(fmt::format("floor plan '{}': expected at least 2 waypoints, found {}", plan.name, route.size()));
  for (std::size_t i = 0; i < route.size(); ++i) {
    const Vector2& from = route[i];
    const Vector2& to = route[(i + 1) % route.size()];
    for (const WallSegment& wall : plan.walls) {
      if (ray_to_wall(wall, from, to - from) > 1.0) continue;
      throw InputError(fmt::format(
          "floor plan '{}': the route from waypoint {} ({}, {}) to ({}, {}) crosses the wall from ({}, {}) to ({}, {})",
          plan.name, i + 1, from.x(), from.y(), to.x(), to.y(), wall.a.x(), wall.a.y(), wall.b.x(), wall.b.y()));
    }
  }
}

// ---- Driving ----------------------------------------------------------------------------------------

// The route driven lap after lap and back to its start, by arc length.
class LappedRoute {
 public:
  LappedRoute(const std::vector<Vector2>& route, int loops) {
    for (int lap = 0; lap < loops; ++lap) points_.insert(points_.end(), route.begin(), route.end());
    points_.push_back(route.front());
    arc_.push_back(0.0);
    for (std::size_t i = 1; i < points_.size(); ++i) arc_.push_back(arc_.back() + (points_[i] - points_[i - 1]).norm());
  }

  double length() const { return arc_.back(); }

  Vector2 at(double s) const {
    const std::size_t i = segment_of(s);
    const double span = arc_[i + 1] - arc_[i];
    if (span == 0.0) return points_[i];
    return points_[i] + (std::clamp(s, arc_[i], arc_[i + 1]) - arc_[i]) / span * (points_[i + 1] - points_[i]);
  }

  /// The arc length within [from, to] of the route's point nearest p; the first of equals, so that
  /// where the route passes a place twice the robot keeps to the pass it is on.
  double nearest(const Vector2& p, double from, double to) const {
    double best_s = from, best = (at(from) - p).squaredNorm();
    for (std::size_t i = segment_of(from); i + 1 < points_.size() && arc_[i] <= to; ++i) {
      const double span = arc_[i + 1] - arc_[i];
      if (span == 0.0) continue;
      const Vector2 direction = (points_[i + 1] - points_[i]) / span;
      const double lo = std::max(from, arc_[i]), hi = std::min(to, arc_[i + 1]);
      const double s = std::clamp(arc_[i] + (p - points_[i]).dot(direction), lo, hi);
      const double d = (points_[i] + (s - arc_[i]) * direction - p).squaredNorm();
      if (d < best) {
        best = d;
        best_s = s;
      }
    }
    return best_s;
  }

 private:
  std::size_t segment_of(double s) const {
    const auto after = std::upper_bound(arc_.begin(), arc_.end(), s);
    const auto i = static_cast<std::size_t>(std::max<std::ptrdiff_t>(after - arc_.begin() - 1, 0));
    return std::min(i, points_.size() - 2);
  }

  std::vector<Vector2> points_;
  std::vector<double> arc_;  // arc_[i]: the route's length up to points_[i]
};

struct Twist {
  double speed = 0.0;      // m/s
  double turn_rate = 0.0;  // rad/s
};

// Pure pursuit: the arc through the look-ahead point, at full speed unless that turns faster than
// the robot can, then slower along the same arc (a differential drive can); a point behind the
// robot is faced first by turning on the spot.
Twist pursue(const Pose2& pose, const Vector2& target, const BuildingSimConfig& c) {
  const Vector2 to = target - pose.head<2>();
  const double alpha = wrap_angle(std::atan2(to.y(), to.x()) - pose[2]);
  if (std::abs(alpha) > kPi / 2.0)
    return {0.0, std::clamp(alpha / c.control_period, -c.max_turn_rate, c.max_turn_rate)};
  const double curvature = 2.0 * std::sin(alpha) / to.norm();
  const double speed = std::min(c.speed, c.max_turn_rate / std::abs(curvature));
  return {speed, speed * curvature};
}

// The exact motion along the arc: the chord, along the heading halfway through the turn.
Pose2 drive(const Pose2& pose, const Twist& twist, double dt) {
  const double half_turn = 0.5 * twist.turn_rate * dt;
  const double chord =
      std::abs(half_turn) < 1e-9 ? twist.speed * dt : twist.speed * dt * std::sin(half_turn) / half_turn;
  const double along = pose[2] + half_turn;
  return Pose2(pose[0] + chord * std::cos(along), pose[1] + chord * std::sin(along),
               wrap_angle(pose[2] + twist.turn_rate * dt));
}

// The odometry's reading of a true increment (rot1, trans, rot2): each part perturbed by the noise
// the config states, its terms added as variances (OdometryModel's form), three draws always, in
// this order.
Control noisy_increment(const Control& truth, const BuildingSimConfig& c, PortableGaussian& noise) {
  const double trans = truth[1];
  const auto rotation_sd = [&](double rot) {
    const double turning = c.rotation_per_rad * rot, driving = c.rotation_per_m * trans;
    return std::sqrt(turning * turning + driving * driving);
  };
  const double rot1_noise = noise(), trans_noise = noise(), rot2_noise = noise();
  Control u(3);
  u << truth[0] + rotation_sd(truth[0]) * rot1_noise, trans + c.translation_per_m * trans * trans_noise,
      truth[2] + rotation_sd(truth[2]) * rot2_noise;
  return u;
}

// ---- Laser ------------------------------------------------------------------------------------------

class Laser {
 public:
  Laser(const FloorPlan& plan, const BuildingSimConfig& c) : plan_(plan), c_(c) {}

  RangeScanEvent sweep(double t, const Pose2& pose, PortableGaussian& range_noise, std::mt19937_64& misses) const {
    RangeScanEvent scan;
    scan.t = t;
    scan.angle_min = -c_.fov / 2.0;
    scan.angle_increment = c_.fov / static_cast<double>(c_.beams - 1);
    scan.max_range = c_.max_range;
    scan.ranges.resize(static_cast<std::size_t>(c_.beams));
    for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
      const double hit = cast_ray(plan_, pose.head<2>(), pose[2] + scan.bearing(i));
      // Both draws for every beam, hit or not, so that what one beam sees leaves the others' noise.
      const double noise = range_noise();
      const bool missed = uniform01(misses) < c_.missed_return_probability;
      const double range =
          missed || hit >= c_.max_range ? c_.max_range : std::clamp(hit + c_.sigma_range * noise, 0.0, c_.max_range);
      scan.ranges[i] = static_cast<float>(range);
    }
    return scan;
  }

 private:
  const FloorPlan& plan_;
  const BuildingSimConfig& c_;
};

}  // namespace

void validate(const BuildingSimConfig& config, const std::string& source) {
  validate_options<BuildingSimConfig>(config, source, kBuildingKeys);
}

nlohmann::json to_json(const BuildingSimConfig& config) {
  return options_to_json<BuildingSimConfig>(config, kBuildingKeys);
}

BuildingSimConfig building_sim_config_from_json(const nlohmann::json& json, const std::string& source_name) {
  return options_from_json<BuildingSimConfig>(json, source_name, "the building simulator config", BuildingSimConfig{},
                                              kBuildingKeys);
}

double cast_ray(const FloorPlan& plan, const Vector2& origin, double bearing) {
  const Vector2 direction(std::cos(bearing), std::sin(bearing));
  double nearest = kNoHit;
  for (const WallSegment& wall : plan.walls) nearest = std::min(nearest, ray_to_wall(wall, origin, direction));
  return nearest;
}

double distance_to_nearest_wall(const FloorPlan& plan, const Vector2& p) {
  double nearest = kNoHit;
  for (const WallSegment& wall : plan.walls) nearest = std::min(nearest, distance_to_wall(wall, p));
  return nearest;
}

Dataset simulate_building(const FloorPlan& plan, const BuildingSimConfig& c) {
  validate(c, "building simulator config");
  check_route(plan);
  const double dt = c.control_period;

  // Sized before the laps' route is built: a million loops is one clear error, not bad_alloc. Every
  // waypoint may cost a quarter turn at the full turn rate, with a scan every scan_rotation of it.
  double lap = 0.0;
  for (std::size_t i = 0; i < plan.route.size(); ++i)
    lap += (plan.route[(i + 1) % plan.route.size()] - plan.route[i]).norm();
  const double turning = static_cast<double>(c.loops) * static_cast<double>(plan.route.size()) * kPi / 2.0;
  const double seconds = static_cast<double>(c.loops) * lap / c.speed + turning / c.max_turn_rate;
  const double scans = static_cast<double>(c.loops) * lap / c.scan_distance + turning / c.scan_rotation + 1.0;
  require_memory((seconds / dt) * (sizeof(Event) + sizeof(StampedPose)) +
                     scans * (sizeof(Event) + static_cast<double>(c.beams) * sizeof(float)),
                 fmt::format("simulating {} laps of the {:.0f} m route of floor plan '{}'", c.loops, lap, plan.name));
  // Far more than the route needs: only a route the robot cannot follow gets there.
  const long max_steps = checked_integer<long>(3.0 * seconds / dt + 100.0, "the run's number of control steps");
  const LappedRoute route(plan.route, c.loops);
  // Beyond a few steps ahead, or the robot would overshoot it between two controls.
  const double lookahead = std::max(0.3, 3.0 * c.speed * dt);
  const double search = lookahead + 2.0 * c.speed * dt;
  const Vector2 finish = plan.route.front();

  Dataset out;
  out.spec = "building:" + plan.name;
  out.name = plan.name;
  OdometryModel::Params noise_model;
  noise_model.alpha_rot_rot = c.rotation_per_rad * c.rotation_per_rad;
  noise_model.alpha_rot_trans = c.rotation_per_m * c.rotation_per_m;
  noise_model.alpha_trans_trans = c.translation_per_m * c.translation_per_m;
  noise_model.alpha_trans_rot = 0.0;
  const auto odometry_model = std::make_shared<const OdometryModel>(noise_model);
  out.motion = odometry_model;
  out.sensor = SensorLimits{c.max_range, c.fov};
  const Vector2 heading = plan.route[1] - plan.route[0];
  Pose2 pose(finish.x(), finish.y(), std::atan2(heading.y(), heading.x()));
  out.initial_pose = pose;
  out.truth.poses_have_heading = true;
  out.events.reserve(static_cast<std::size_t>(seconds / dt + scans));
  out.truth.poses.reserve(static_cast<std::size_t>(seconds / dt) + 1);

  // The laser's streams apart from the odometry's, so that changing the laser leaves a seed's drift.
  PortableGaussian odometry_noise(c.seed);
  PortableGaussian range_noise(c.seed ^ 0x9e3779b97f4a7c15ULL);
  std::mt19937_64 misses(c.seed ^ 0xbf58476d1ce4e5b9ULL);
  const Laser laser(plan, c);

  out.truth.poses.push_back(StampedPose{0.0, pose});
  out.events.emplace_back(laser.sweep(0.0, pose, range_noise, misses));
  Pose2 odometry = pose, odometry_at_scan = pose;
  double progress = 0.0;
  for (long k = 1;; ++k) {
    progress = route.nearest(pose.head<2>(), progress, progress + search);
    const double aim = progress + lookahead;
    if (aim >= route.length() && (finish - pose.head<2>()).norm() <= 0.5 * c.speed * dt) break;
    if (k > max_steps) {
      throw InputError(fmt::format("floor plan '{}': the robot cannot follow the route; after {:.0f} s it is {:.1f} m "
                                   "along the {:.1f} m of {} laps",
                                   plan.name, static_cast<double>(k) * dt, progress, route.length(), c.loops));
    }
    const Pose2 next = drive(pose, pursue(pose, route.at(aim), c), dt);
    const Pose2 next_odometry =
        odometry_model->predict(odometry, noisy_increment(OdometryModel::between(pose, next), c, odometry_noise), dt);
    const double t = static_cast<double>(k) * dt;
    out.events.emplace_back(ControlEvent{t, dt, OdometryModel::between(odometry, next_odometry)});
    out.truth.poses.push_back(StampedPose{t, next});
    pose = next;
    odometry = next_odometry;
    // The robot knows only its odometry, so that is what decides when it has moved enough.
    if ((odometry.head<2>() - odometry_at_scan.head<2>()).norm() >= c.scan_distance ||
        std::abs(wrap_angle(odometry[2] - odometry_at_scan[2])) >= c.scan_rotation) {
      out.events.emplace_back(laser.sweep(t, pose, range_noise, misses));
      odometry_at_scan = odometry;
    }
  }
  return out;
}

}  // namespace slamkit
