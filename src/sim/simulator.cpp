#include "slamkit/sim/simulator.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>
#include <string_view>

#include "slamkit/core/checked_integer.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/names.hpp"
#include "slamkit/core/memory_budget.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/core/random_draws.hpp"

namespace slamkit {
namespace {

// ---- Config keys ------------------------------------------------------------------------------------

using namespace option_ranges;
using Real = RealOption<SimulatorConfig>;
// Written only when not 0 (see to_json's comment).
constexpr const char* kRangeOffsetKey = "range_offset_m";
constexpr const char* kRangeScaleErrorKey = "range_scale_error";
constexpr const char* kRangeOutlierProbabilityKey = "range_outlier_probability";
constexpr const char* kRangeOutlierMeanKey = "range_outlier_mean_m";

// Beyond 90 degrees the wheels would point backwards.
constexpr RealRange kSteeringLock{[](double v) { return v > 0.0 && v < kPi / 2.0; }, "> 0 and < 90"};
constexpr RealRange kProbability{[](double v) { return v > 0.0 && v <= 1.0; }, "> 0 and <= 1"};
// Physical limits, generous for any ground vehicle and landmark sensor; beyond them a value is a
// mistake, and one like a speed of 1e-300 or a range of 1e308 would only fail later, obscurely.
constexpr RealRange kSpeed{[](double v) { return v >= 1e-3 && v <= 100.0; }, ">= 0.001 and <= 100 (m/s)"};
constexpr RealRange kLength{[](double v) { return v >= 1e-3 && v <= 100.0; }, ">= 0.001 and <= 100 (m)"};
constexpr RealRange kRange{[](double v) { return v > 0.0 && v <= 1e4; }, "> 0 and <= 10000 (m)"};
constexpr RealRange kPeriod{[](double v) { return v >= 1e-4 && v <= 3600.0; }, ">= 0.0001 and <= 3600 (s)"};
// The filters gate innovations by the measurement noise: with none, every observation is infinitely
// far from every landmark and unknown association starts a landmark for each.
constexpr RealRange kSensorNoise{[](double v) { return v > 0.0 && std::isfinite(v); }, "> 0"};
// Each false detection is drawn, stored and shuffled in; a thousand per scan is already a sensor
// that sees nothing but clutter.
// A radio's offset is metres and its scale error percent; a hundred metres or a half would be a
// sensor measuring something else.
constexpr RealRange kRangeOffset{[](double v) { return std::abs(v) <= 100.0; }, "from -100 to 100 (m)"};
constexpr RealRange kRangeScaleError{[](double v) { return std::abs(v) < 0.5; }, "> -0.5 and < 0.5"};
constexpr RealRange kOutlierProbability{[](double v) { return v >= 0.0 && v <= 1.0; }, ">= 0 and <= 1"};
constexpr RealRange kClutter{[](double v) { return v >= 0.0 && v <= 1000.0; }, ">= 0 and <= 1000"};

const OptionKey<SimulatorConfig> kConfigKeys[] = {
    {"speed_mps", Real{[](SimulatorConfig& c) -> double& { return c.speed; }, kSpeed}},
    {"wheelbase_m", Real{[](SimulatorConfig& c) -> double& { return c.wheelbase; }, kLength}},
    {"max_steer_deg", Real{[](SimulatorConfig& c) -> double& { return c.max_steer; }, kSteeringLock, Unit::kDegrees}},
    {"max_steer_rate_deg_per_s",
     Real{[](SimulatorConfig& c) -> double& { return c.max_steer_rate; }, kPositive, Unit::kDegrees}},
    {"waypoint_tolerance_m", Real{[](SimulatorConfig& c) -> double& { return c.waypoint_tolerance; }, kLength}},
    {"loops", IntegerOption<SimulatorConfig, int>{[](SimulatorConfig& c) -> int& { return c.loops; }, 1}},
    {"sigma_speed_mps", Real{[](SimulatorConfig& c) -> double& { return c.sigma_speed; }, kNonNegative}},
    {"sigma_steer_deg",
     Real{[](SimulatorConfig& c) -> double& { return c.sigma_steer; }, kNonNegative, Unit::kDegrees}},
    {"max_range_m", Real{[](SimulatorConfig& c) -> double& { return c.max_range; }, kRange}},
    {"fov_deg", Real{[](SimulatorConfig& c) -> double& { return c.fov; }, kFieldOfView, Unit::kDegrees}},
    {"sigma_range_m", Real{[](SimulatorConfig& c) -> double& { return c.sigma_range; }, kSensorNoise}},
    {kRangeOffsetKey, Real{[](SimulatorConfig& c) -> double& { return c.range_offset; }, kRangeOffset}},
    {kRangeScaleErrorKey, Real{[](SimulatorConfig& c) -> double& { return c.range_scale_error; }, kRangeScaleError}},
    {kRangeOutlierProbabilityKey,
     Real{[](SimulatorConfig& c) -> double& { return c.range_outlier_probability; }, kOutlierProbability}},
    {kRangeOutlierMeanKey, Real{[](SimulatorConfig& c) -> double& { return c.range_outlier_mean; }, kLength}},
    {"sigma_bearing_deg",
     Real{[](SimulatorConfig& c) -> double& { return c.sigma_bearing; }, kSensorNoise, Unit::kDegrees}},
    {"clutter_rate_per_scan", Real{[](SimulatorConfig& c) -> double& { return c.clutter_rate; }, kClutter}},
    {"detection_probability",
     Real{[](SimulatorConfig& c) -> double& { return c.detection_probability; }, kProbability}},
    {"provide_ids", FlagOption<SimulatorConfig>{[](SimulatorConfig& c) -> bool& { return c.provide_ids; }}},
    {"control_period_s", Real{[](SimulatorConfig& c) -> double& { return c.control_period; }, kPeriod}},
    {"observation_period_s", Real{[](SimulatorConfig& c) -> double& { return c.observation_period; }, kPeriod}},
    {"seed", IntegerOption<SimulatorConfig, std::uint64_t>{[](SimulatorConfig& c) -> std::uint64_t& { return c.seed; }}},
};

// How many control periods make one observation period; 0 if it is not a whole number of them.
long steps_per_observation(const SimulatorConfig& c) {
  const double ratio = c.observation_period / c.control_period;
  const double whole = std::round(ratio);
  return whole >= 1.0 && std::abs(ratio - whole) <= 1e-9 * ratio ? static_cast<long>(whole) : 0;
}

// The one rule between keys; the keys themselves are checked by their table.
void check_periods(const SimulatorConfig& c, const std::string& source) {
  if (steps_per_observation(c) == 0)
    throw InputError(
        source, 0,
        fmt::format("'observation_period_s' must be a whole multiple of 'control_period_s' ({}), found {}",
                    c.control_period, c.observation_period));
}


// ---- Randomness -------------------------------------------------------------------------------------

// Every sample is made from the engine's raw output by the transforms below: the standard library's
// distributions (and std::shuffle) differ between implementations, and a seed must give the same
// dataset with all of them (core/random_draws.hpp).

// Poisson-distributed count: the arrivals of a unit-rate Poisson process within [0, mean]. Unlike
// the textbook product of uniforms against exp(-mean) it does not underflow for large means.
long poisson(double mean, std::mt19937_64& rng) {
  long count = 0;
  for (double t = -std::log(1.0 - uniform01(rng)); t < mean; t -= std::log(1.0 - uniform01(rng))) ++count;
  return count;
}

// Fisher-Yates on two parallel sequences. The modulo's bias, below n / 2^64, is far beyond detection.
template <typename A, typename B>
void shuffle_together(std::vector<A>& a, std::vector<B>& b, std::mt19937_64& rng) {
  for (std::size_t i = a.size(); i > 1; --i) {
    const std::size_t j = static_cast<std::size_t>(rng() % i);
    std::swap(a[i - 1], a[j]);
    std::swap(b[i - 1], b[j]);
  }
}

// ---- Visibility -------------------------------------------------------------------------------------

// Landmarks bucketed in a uniform grid (cells at least a sensor range wide), so a sweep examines
// the landmarks of a few cells rather than the whole map.
class LandmarkGrid {
 public:
  LandmarkGrid(const std::vector<Landmark>& landmarks, double reach) {
    if (landmarks.empty()) return;
    origin_ = landmarks.front().position;
    Vector2 top = origin_;
    for (const Landmark& l : landmarks) {
      origin_ = origin_.cwiseMin(l.position);
      top = top.cwiseMax(l.position);
    }
    // A sensor range far below the map size must not explode the number of cells.
    constexpr double kMaxCellsPerSide = 256.0;
    cell_ = std::max(reach, (top - origin_).maxCoeff() / kMaxCellsPerSide);
    nx_ = static_cast<long>((top.x() - origin_.x()) / cell_) + 1;
    ny_ = static_cast<long>((top.y() - origin_.y()) / cell_) + 1;
    start_.assign(static_cast<std::size_t>(nx_ * ny_ + 1), 0);
    for (const Landmark& l : landmarks) ++start_[cell_index(l.position) + 1];
    for (std::size_t i = 1; i < start_.size(); ++i) start_[i] += start_[i - 1];
    items_.resize(landmarks.size());
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < landmarks.size(); ++i)
      items_[fill[cell_index(landmarks[i].position)]++] = static_cast<int>(i);
  }

  /// Indices of the landmarks in the cells that overlap the square of half-side `reach` around p.
  void gather(const Vector2& p, double reach, std::vector<int>& out) const {
    out.clear();
    if (nx_ == 0) return;
    const auto span = [&](double lo, double hi, double origin, long n, long& first, long& last) {
      const double a = std::floor((lo - origin) / cell_), b = std::floor((hi - origin) / cell_);
      if (b < 0.0 || a >= static_cast<double>(n)) return false;
      first = static_cast<long>(std::max(a, 0.0));
      last = static_cast<long>(std::min(b, static_cast<double>(n - 1)));
      return true;
    };
    long x0 = 0, x1 = 0, y0 = 0, y1 = 0;
    if (!span(p.x() - reach, p.x() + reach, origin_.x(), nx_, x0, x1) ||
        !span(p.y() - reach, p.y() + reach, origin_.y(), ny_, y0, y1))
      return;
    for (long iy = y0; iy <= y1; ++iy) {
      const std::size_t row = static_cast<std::size_t>(iy * nx_);
      out.insert(out.end(), items_.begin() + static_cast<std::ptrdiff_t>(start_[row + x0]),
                 items_.begin() + static_cast<std::ptrdiff_t>(start_[row + x1 + 1]));
    }
  }

 private:
  std::size_t cell_index(const Vector2& p) const {
    const long ix = static_cast<long>((p.x() - origin_.x()) / cell_);
    const long iy = static_cast<long>((p.y() - origin_.y()) / cell_);
    return static_cast<std::size_t>(iy * nx_ + ix);
  }

  Vector2 origin_ = Vector2::Zero();
  double cell_ = 1.0;
  long nx_ = 0, ny_ = 0;
  std::vector<std::size_t> start_;  // landmarks of cell c are items_[start_[c] .. start_[c + 1])
  std::vector<int> items_;
};

// ---- Steering ----------------------------------------------------------------------------------------

// The reference simulators' controller: turn the wheels towards the waypoint, no faster than the
// steering rate allows and no further than the steering lock.
double steer_towards(const Pose2& pose, const Vector2& target, double steer, const SimulatorConfig& c) {
  const double wanted =
      wrap_angle(std::atan2(target.y() - pose.y(), target.x() - pose.x()) - pose.z() - steer);
  const double max_delta = c.max_steer_rate * c.control_period;
  return std::clamp(steer + std::clamp(wanted, -max_delta, max_delta), -c.max_steer, c.max_steer);
}

// Of the closed route through the waypoints, which bounds an open route's laps too: it sizes buffers.
double route_length(const std::vector<Vector2>& waypoints) {
  double length = (waypoints.front() - waypoints.back()).norm();
  for (std::size_t i = 1; i < waypoints.size(); ++i) length += (waypoints[i] - waypoints[i - 1]).norm();
  return length;
}

constexpr std::string_view kSensorKey = "sensor";

}  // namespace

SensorKind parse_sensor_kind(const std::string& name) {
  if (name == "range-bearing") return SensorKind::kRangeBearing;
  if (name == "range-only") return SensorKind::kRangeOnly;
  if (name == "bearing-only") return SensorKind::kBearingOnly;
  throw std::invalid_argument(unknown_name_message("sensor", name, {"range-bearing", "range-only", "bearing-only"}));
}

std::string to_string(SensorKind kind) {
  switch (kind) {
    case SensorKind::kRangeBearing: return "range-bearing";
    case SensorKind::kRangeOnly: return "range-only";
    case SensorKind::kBearingOnly: return "bearing-only";
  }
  return "range-bearing";
}

void set_platform(Dataset& dataset, const SimulatorConfig& config) {
  dataset.motion = std::make_shared<const AckermannModel>(
      AckermannModel::Params{config.wheelbase, config.sigma_speed, config.sigma_steer});
  switch (config.sensor) {
    case SensorKind::kRangeBearing:
      dataset.observation = std::make_shared<const RangeBearingModel>(
          RangeBearingModel::Params{.sigma_range = config.sigma_range, .sigma_bearing = config.sigma_bearing});
      break;
    case SensorKind::kRangeOnly:
      dataset.observation =
          std::make_shared<const RangeOnlyModel>(RangeOnlyModel::Params{.sigma_range = config.sigma_range});
      break;
    case SensorKind::kBearingOnly:
      dataset.observation =
          std::make_shared<const BearingOnlyModel>(BearingOnlyModel::Params{.sigma_bearing = config.sigma_bearing});
      break;
  }
  dataset.sensor = SensorLimits{config.max_range, config.fov};
}

nlohmann::json to_json(const SimulatorConfig& config) {
  nlohmann::json json = options_to_json<SimulatorConfig>(config, kConfigKeys);
  if (config.sensor != SensorKind::kRangeBearing) json[std::string(kSensorKey)] = to_string(config.sensor);
  if (config.range_offset == 0.0) json.erase(kRangeOffsetKey);
  if (config.range_scale_error == 0.0) json.erase(kRangeScaleErrorKey);
  if (config.range_outlier_probability == 0.0) {
    json.erase(kRangeOutlierProbabilityKey);
    json.erase(kRangeOutlierMeanKey);
  }
  return json;
}

void validate(const SimulatorConfig& c, const std::string& source) {
  validate_options<SimulatorConfig>(c, source, kConfigKeys);
  check_periods(c, source);
}

SimulatorConfig simulator_config_from_json(const nlohmann::json& json, const std::string& source_name) {
  // The sensor is a name, not a number: read apart from the table of numeric keys.
  SimulatorConfig defaults;
  nlohmann::json numeric = json;
  if (json.is_object() && json.contains(kSensorKey)) {
    const nlohmann::json& kind = json.at(std::string(kSensorKey));
    if (!kind.is_string())
      throw InputError(source_name, 0, fmt::format("'sensor' must be a string, found {}", kind.dump()));
    try {
      defaults.sensor = parse_sensor_kind(kind.get<std::string>());
    } catch (const std::invalid_argument& e) {
      throw InputError(source_name, 0, e.what());
    }
    numeric.erase(std::string(kSensorKey));
  }
  const SimulatorConfig config =
      options_from_json<SimulatorConfig>(numeric, source_name, "the simulator config", defaults, kConfigKeys);
  check_periods(config, source_name);
  return config;
}

Dataset simulate(const World& world, const SimulatorConfig& config) {
  validate(config, "simulator config");
  const std::vector<Vector2>& waypoints = world.waypoints;
  if (waypoints.size() < 2)
    throw InputError(fmt::format("world: expected at least 2 waypoints, found {}", waypoints.size()));

  const double dt = config.control_period;
  const long steps_per_scan = steps_per_observation(config);
  Dataset out;
  out.name = "simulated";
  set_platform(out, config);
  const MotionModel& motion = *out.motion;
  // Which landmarks are in view, and what each would measure without noise, is geometry: its range
  // and bearing, of which the sensor reports its part.
  const RangeBearingModel sight;
  const bool measures_range = config.sensor != SensorKind::kBearingOnly;
  const bool measures_bearing = config.sensor != SensorKind::kRangeOnly;
  const auto measured = [&](double range, double bearing) -> Measurement {
    if (!measures_bearing) return Measurement::Constant(1, range);
    if (!measures_range) return Measurement::Constant(1, bearing);
    return Vector2(range, bearing);
  };
  const Vector2 heading = waypoints[1] - waypoints[0];
  Pose2 pose = world.start.value_or(Pose2(waypoints[0].x(), waypoints[0].y(), std::atan2(heading.y(), heading.x())));
  out.initial_pose = pose;
  out.truth.poses_have_heading = true;
  out.truth.landmarks = world.landmarks;

  const double lap_length = route_length(waypoints);
  const auto expected_steps = checked_integer<std::size_t>(
      1.05 * config.loops * lap_length / (config.speed * dt) + 16.0, "the run's number of control steps");
  // A control event, a true pose, and a scan's share: its event and observations (a dozen landmarks in
  // view and the clutter).
  require_memory(static_cast<double>(expected_steps) *
                     (sizeof(Event) + sizeof(StampedPose) +
                      (sizeof(Event) + (12.0 + config.clutter_rate) * sizeof(Observation)) /
                          static_cast<double>(steps_per_scan)),
                 fmt::format("simulating {} laps of a {:.0f} m route at {} m/s every {} s", config.loops,
                             lap_length, config.speed, dt));
  out.events.reserve(expected_steps + expected_steps / static_cast<std::size_t>(steps_per_scan));
  out.truth.poses.reserve(expected_steps + 1);
  out.truth.poses.push_back(StampedPose{0.0, pose});

  // Separate streams, so that changing the sensor (and with it how many numbers a sweep draws)
  // leaves the control noise of a seed unchanged, and changing the detection settings leaves both
  // noises unchanged. Every landmark in view draws its measurement noise, detected or not, so that
  // the detections of a lower detection probability are a subset of those of a higher one.
  PortableGaussian control_noise(config.seed);
  PortableGaussian sensor_noise(config.seed ^ 0x9e3779b97f4a7c15ULL);
  std::mt19937_64 detection_rng(config.seed ^ 0xbf58476d1ce4e5b9ULL);
  std::mt19937_64 clutter_rng(config.seed ^ 0x94d049bb133111ebULL);
  // Drawn only where ranges have outliers, so that the other streams stay those of the same seed
  // without them.
  std::mt19937_64 outlier_rng(config.seed ^ 0xd6e8feb86659fd93ULL);
  const bool range_outliers = measures_range && config.range_outlier_probability > 0.0;
  // Clutter would otherwise come last in a scan, and map order hints at the identities withheld.
  const bool shuffle_scans = config.clutter_rate > 0.0 || !config.provide_ids;
  const LandmarkGrid grid(world.landmarks, config.max_range);
  std::vector<int> candidates;

  // A waypoint inside the turning circle is orbited forever; give up on one the vehicle has not
  // reached in three times the length of a straight drive plus a full circle. The pose moves along
  // heading + steer, so at full lock it circles with radius L / sin(max_steer).
  const double turn_radius = config.wheelbase / std::sin(config.max_steer);
  const std::size_t n = waypoints.size();
  const std::size_t arrivals_to_finish = static_cast<std::size_t>(config.loops) * n + (world.closed ? 1 : 0);
  std::size_t arrivals = 0;
  long deadline = 0;
  double steer = 0.0;
  for (long k = 1;; ++k) {
    // A start away from the first waypoint gets the same patience as each arrival.
    bool arrived = k == 1;
    while (arrivals < arrivals_to_finish &&
           (waypoints[arrivals % n] - pose.head<2>()).norm() < config.waypoint_tolerance) {
      ++arrivals;
      arrived = true;
    }
    if (arrivals == arrivals_to_finish) break;
    const Vector2& target = waypoints[arrivals % n];
    if (arrived) {
      const double patience =
          3.0 * ((target - pose.head<2>()).norm() + 2.0 * kPi * turn_radius) / config.speed;
      deadline = k + checked_integer<long>(std::ceil(patience / dt), "the steps allowed to reach a waypoint");
    } else if (k > deadline) {
      throw InputError(fmt::format(
          "world: the vehicle cannot reach waypoint {} at ({}, {}); it is {:.1f} m away after {:.0f} s. "
          "Consecutive waypoints must allow for the turning radius of {:.1f} m",
          arrivals % n + 1, target.x(), target.y(), (target - pose.head<2>()).norm(),
          static_cast<double>(k) * dt, turn_radius));
    }

    steer = steer_towards(pose, target, steer, config);
    Control u_true(2);
    u_true << config.speed, steer;
    pose = motion.predict(pose, u_true, dt);
    const double t = static_cast<double>(k) * dt;
    Control u(2);
    u << config.speed + config.sigma_speed * control_noise(), steer + config.sigma_steer * control_noise();
    out.events.emplace_back(ControlEvent{t, dt, u});
    out.truth.poses.push_back(StampedPose{t, pose});

    if (k % steps_per_scan != 0) continue;
    grid.gather(pose.head<2>(), config.max_range, candidates);
    // The grid yields landmarks cell by cell; map order makes a sweep independent of the grid.
    std::sort(candidates.begin(), candidates.end());
    ScanEvent scan{t, {}};
    std::vector<int> true_ids;
    for (const int i : candidates) {
      const Landmark& landmark = world.landmarks[static_cast<std::size_t>(i)];
      const Measurement z = sight.predict(pose, landmark.position);
      if (z[0] > config.max_range || std::abs(z[1]) > config.fov / 2.0) continue;
      // The draws in a fixed order, not as a call's arguments (whose order gcc and clang differ in);
      // bearing first, the order gcc gave the existing logs. A sensor that measures one of the two
      // draws only its noise.
      const double bearing_noise = measures_bearing ? sensor_noise() : 0.0;
      const double range_noise = measures_range ? sensor_noise() : 0.0;
      double range =
          RangeCorrection{config.range_offset, config.range_scale_error}.range(z[0]) + config.sigma_range * range_noise;
      // Both draws for every landmark in view, as for the noise: the same seed then gives the same
      // outliers whatever the detection probability.
      if (range_outliers) {
        const bool outlier = uniform01(outlier_rng) < config.range_outlier_probability;
        const double excess = -config.range_outlier_mean * std::log(1.0 - uniform01(outlier_rng));
        if (outlier) range += excess;
      }
      const double bearing = wrap_angle(z[1] + config.sigma_bearing * bearing_noise);
      if (uniform01(detection_rng) >= config.detection_probability) continue;
      // Only a landmark almost on top of the sensor can come out at a negative range: no real
      // sensor reports one, so it counts as missed.
      if (range <= 0.0) continue;
      scan.observations.push_back(Observation{measured(range, bearing), config.provide_ids ? landmark.id : kUnknownId});
      true_ids.push_back(landmark.id);
    }
    // Uniform over the visible sector: the area within radius r grows as r^2, hence the square root.
    // 1 - u keeps the range above zero, as a sensor reports it. A sensor that measures one of the
    // two reports that one, uniform over its measurement space, as the filters' clutter density has
    // it: a range-only sensor's over [0, max_range], a bearing-only one's over the field of view.
    for (long c = poisson(config.clutter_rate, clutter_rng); c > 0; --c) {
      const double u = 1.0 - uniform01(clutter_rng);
      const double range = config.max_range * (measures_bearing ? std::sqrt(u) : u);
      const double bearing = wrap_angle(config.fov * (uniform01(clutter_rng) - 0.5));
      scan.observations.push_back(Observation{measured(range, bearing), kUnknownId});
      true_ids.push_back(kUnknownId);
    }
    if (scan.observations.empty()) continue;
    if (shuffle_scans) shuffle_together(scan.observations, true_ids, clutter_rng);
    out.events.emplace_back(std::move(scan));
    out.truth.observation_ids.push_back(std::move(true_ids));
  }
  return out;
}

namespace {

struct ScenarioEntry {
  const char* name;
  World (*world)();
  bool loop;       // one lap: a loop-closure route is driven once
  bool cluttered;  // the detection of the data-association experiments
  bool forward_sensor;  // the 180 degree field of view of the reference simulator's example
  bool indoor;          // the MRCLAM-like robot of room_world
  double max_range;     // m, the sensor's reach; 0: the config's default
};

const ScenarioEntry kScenarios[] = {
    {"default", &default_world, false, false, false, false, 0.0},
    {"loop-closure", &loop_closure_world, true, false, false, false, 0.0},
    {"cluttered", &default_world, false, true, false, false, 0.0},
    {"loop-closure-cluttered", &loop_closure_world, true, true, false, false, 0.0},
    {"sparse", &sparse_world, false, false, true, false, 0.0},
    {"sparse-cluttered", &sparse_world, false, true, true, false, 0.0},
    {"room", &room_world, true, false, false, true, 0.0},
    // A street's landmarks ahead, about ten at a time.
    {"city", &city_world, true, false, true, false, 22.0},
};

// The reference simulator's example looks ahead of the vehicle only.
void use_forward_sensor(SimulatorConfig& c) { c.fov = deg2rad(180.0); }

// The detection of the data-association experiments.
void use_cluttered_detection(SimulatorConfig& c) {
  c.clutter_rate = 1.0;
  c.detection_probability = 0.9;
  c.provide_ids = false;
}

struct FamilyEntry {
  const char* name;
  double landmarks_per_km;
  bool cluttered;
};

// The sparse world's density (35 landmarks on 640 m), and three times that.
constexpr double kSparsePerKm = 55.0, kDensePerKm = 165.0;
const FamilyEntry kFamilies[] = {
    {"sparse", kSparsePerKm, false},
    {"sparse-cluttered", kSparsePerKm, true},
    {"dense", kDensePerKm, false},
    {"dense-cluttered", kDensePerKm, true},
};

template <typename Entry, std::size_t N>
std::vector<std::string> names_of(const Entry (&table)[N]) {
  std::vector<std::string> names;
  for (const Entry& e : table) names.emplace_back(e.name);
  return names;
}

}  // namespace

Scenario scenario(const std::string& name) {
  const auto entry = std::find_if(std::begin(kScenarios), std::end(kScenarios),
                                  [&](const ScenarioEntry& e) { return name == e.name; });
  if (entry == std::end(kScenarios))
    throw InputError(unknown_name_message("scenario", name, scenario_names()));
  Scenario s{entry->name, entry->world(), SimulatorConfig{}};
  if (entry->loop) s.config.loops = 1;
  if (entry->forward_sensor) use_forward_sensor(s.config);
  if (entry->indoor) {
    // A slow robot that turns on the spot, a camera with a 70-degree view and 8 m of range, and a
    // turn rate error of about 2e-3 rad^2/s, MRCLAM's size.
    s.config.speed = 0.15;
    s.config.wheelbase = 0.25;
    s.config.max_steer = deg2rad(60.0);
    s.config.max_steer_rate = deg2rad(120.0);
    s.config.waypoint_tolerance = 0.3;
    s.config.sigma_speed = 0.03;
    s.config.sigma_steer = deg2rad(15.0);
    s.config.max_range = 8.0;
    s.config.fov = deg2rad(70.0);
    s.config.sigma_range = 0.1;
    s.config.sigma_bearing = deg2rad(1.0);
    s.config.control_period = 0.1;
  }
  if (entry->cluttered) use_cluttered_detection(s.config);
  if (entry->max_range > 0.0) s.config.max_range = entry->max_range;
  return s;
}

std::vector<std::string> scenario_names() { return names_of(kScenarios); }

Scenario WorldFamily::member(std::uint64_t world_seed) const {
  Scenario s{fmt::format("{} world {}", name, world_seed), random_world(world, world_seed), config};
  s.world.origin = WorldOrigin{name, world_seed};
  return s;
}

WorldFamily world_family(const std::string& name) {
  const auto entry = std::find_if(std::begin(kFamilies), std::end(kFamilies),
                                  [&](const FamilyEntry& e) { return name == e.name; });
  if (entry == std::end(kFamilies)) {
    throw std::invalid_argument(unknown_name_message("world family", name, world_family_names()));
  }
  WorldFamily family{entry->name, RandomWorldOptions{}, SimulatorConfig{}};
  family.world.landmarks_per_km = entry->landmarks_per_km;
  use_forward_sensor(family.config);
  if (entry->cluttered) use_cluttered_detection(family.config);
  return family;
}

std::vector<std::string> world_family_names() { return names_of(kFamilies); }

}  // namespace slamkit
