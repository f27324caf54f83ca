#pragma once
// The landmark-SLAM simulator of the tutorial's reference implementation (Tim Bailey's MATLAB
// EKF-SLAM and FastSLAM simulators): a car-like vehicle drives round the waypoints of a World with a
// rate-limited steering controller, and a range-bearing sensor sees every landmark within range.
// Beyond the reference, the sensor may miss landmarks, report clutter and withhold identities, the
// conditions data association has to cope with. The result is a Dataset: noisy controls and
// observations for the filter, and the ground truth.
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/sim/world.hpp"

namespace slamkit {

/// What the simulated sensor measures of each landmark it sees: range and bearing (the reference
/// simulators' sensor), the range alone (a radio ranging to beacons) or the bearing alone (a camera's
/// azimuth).
enum class SensorKind { kRangeBearing, kRangeOnly, kBearingOnly };

/// "range-bearing", "range-only" or "bearing-only"; throws std::invalid_argument naming the accepted
/// values otherwise.
SensorKind parse_sensor_kind(const std::string& name);
std::string to_string(SensorKind kind);

/// Defaults are those of the reference simulators. Angles in radians.
struct SimulatorConfig {
  // Vehicle and controller.
  double speed = 3.0;                     // m/s, constant
  double wheelbase = 4.0;                 // m
  double max_steer = deg2rad(30.0);       // rad
  double max_steer_rate = deg2rad(20.0);  // rad/s
  double waypoint_tolerance = 1.0;        // m, a waypoint counts as reached this close
  int loops = 2;                          // laps of the route before stopping
  // Control noise: what the filter is told differs from what the vehicle did by this much.
  double sigma_speed = 0.3;           // m/s
  double sigma_steer = deg2rad(3.0);  // rad
  // Sensor. sigma_range applies to a sensor that measures range, sigma_bearing to one that measures
  // bearing.
  SensorKind sensor = SensorKind::kRangeBearing;
  double max_range = 30.0;              // m
  double fov = 2.0 * kPi;               // rad, full opening angle centred on the heading
  double sigma_range = 0.1;             // m
  // A range reads (1 + range_scale_error) d + range_offset for a distance d (RangeCorrection):
  // radio ranging reads long.
  double range_offset = 0.0;  // m
  double range_scale_error = 0.0;
  // Multipath: with this probability a range reads long by a further exponentially distributed
  // excess of mean range_outlier_mean (a radio's signal that arrives by a longer path).
  double range_outlier_probability = 0.0;
  double range_outlier_mean = 5.0;  // m
  double sigma_bearing = deg2rad(1.0);  // rad
  // Detection. The defaults make the reference's ideal detector.
  double clutter_rate = 0.0;           // false detections per scan, mean of a Poisson count
  double detection_probability = 1.0;  // of each landmark in range and field of view, independently
  bool provide_ids = true;             // false: observations carry kUnknownId, the truth keeps the ids
  // Timing.
  double control_period = 0.025;    // s
  double observation_period = 0.2;  // s, a whole multiple of control_period
  std::uint64_t seed = 1;
};

/// The config as JSON: angles in degrees, every key named with its unit (e.g. "sigma_steer_deg");
/// clutter_rate is "clutter_rate_per_scan". "sensor" is written only for a sensor other than range
/// and bearing, "range_offset_m" and "range_scale_error" only when not 0, and the range outliers'
/// keys only when their probability is not 0, so that configs written before they existed read and
/// write as they did.
nlohmann::json to_json(const SimulatorConfig& config);

/// Reads what to_json writes. Missing keys keep their defaults; an unknown key, a value of the wrong
/// type or out of range is an InputError naming `source_name` and the key.
SimulatorConfig simulator_config_from_json(const nlohmann::json& json, const std::string& source_name);
/// Throws an InputError naming `source` and the first setting out of its range, or periods that do
/// not divide (simulate() checks its config so); the CLI checks each of its options with it.
void validate(const SimulatorConfig& config, const std::string& source);

/// Gives `dataset` the motion and observation models and the sensor limits that describe data from
/// a simulator with this config: what a filter should assume when it processes that data.
void set_platform(Dataset& dataset, const SimulatorConfig& config);

/// Runs the simulation. The same world, config and seed give the same dataset, bit for bit: the
/// noise comes from std::mt19937_64 through slamkit's own transforms, not the standard library's
/// distributions, whose algorithms vary between implementations.
///
/// Every control period the steering turns towards the current waypoint (rate- and angle-limited)
/// and the vehicle moves with AckermannModel::predict; the step yields a ControlEvent carrying the
/// control plus Gaussian noise and a truth pose (plus one at t = 0 for the start). Every observation
/// period, right after that step's control, a ScanEvent holds a noisy range-bearing measurement of
/// each landmark within range and field of view that the sensor detects (each with probability
/// detection_probability), and a Poisson number (mean clutter_rate) of false detections spread
/// uniformly over the area in range and field of view. Observations carry the landmark's id, or
/// kUnknownId for clutter and whenever provide_ids is false; truth.observation_ids always has the
/// true ids (kUnknownId for clutter). With clutter or without ids a scan's observations come in a
/// random order, so that neither clutter nor identity shows in the position within the scan; else
/// in the order of world.landmarks. A sweep that yields nothing yields no ScanEvent.
///
/// The vehicle starts at world.start if the world has one, else at the first waypoint facing the
/// second, and drives the waypoints in order `loops` times, heading from the last back to the first
/// between laps. A closed route ends back at the first waypoint, an open one at the last.
///
/// Misses, clutter and the order of a scan have random streams of their own, so with the default
/// detection settings a seed gives the same data as before those settings existed, and changing
/// them leaves the control and measurement noise of a seed unchanged.
///
/// Throws InputError for an invalid config, a world with fewer than 2 waypoints, or a route the
/// vehicle cannot follow (a waypoint inside its turning circle, which it would orbit forever).
Dataset simulate(const World& world, const SimulatorConfig& config);

/// A named world and config, for experiments that should be reproducible by name.
struct Scenario {
  std::string name;
  World world;
  SimulatorConfig config;
};

/// The scenarios, by name:
///   default                 default_world() and the default config
///   loop-closure            loop_closure_world(), one lap
///   cluttered               default_world(), 1 clutter per scan, 90% detection, no ids
///   loop-closure-cluttered  loop-closure with the detection of cluttered
///   sparse                  sparse_world(), a 180 degree field of view, two laps
///   sparse-cluttered        sparse with the detection of cluttered
///   room                    room_world(), once, with an MRCLAM-like robot: 0.15 m/s, turning on the
///                           spot, a 70-degree camera reaching 8 m, 10 Hz controls
///   city                    city_world() (30,000 landmarks, a 72 km route through a 3 km x 3 km
///                           street grid), once, a 180 degree field of view reaching 22 m
/// Throws InputError for an unknown name, listing the known ones.
Scenario scenario(const std::string& name);

/// The names scenario() knows, in the order above.
std::vector<std::string> scenario_names();

/// A family of random worlds (random_world) with one simulator config, so that settings can be
/// chosen on some of its worlds and reported on others (docs/world-families.md). Every family has
/// the geometry of the sparse scenario, the reference simulator's (its vehicle, a 30 m range, a 180
/// degree field of view, 0.1 m and 1 degree noise), and drives its route twice: the second lap
/// re-observes every landmark of the first after a lap of drift. The families:
///   sparse            55 landmarks per km of route, the sparse world's density: about 1.4 in view
///                     per sweep, none in a fifth of the sweeps
///   sparse-cluttered  sparse with the detection of the cluttered scenario (a false detection per
///                     scan on average, 90% detection, no ids)
///   dense             165 per km, about 4 in view
///   dense-cluttered   dense with the detection of cluttered
/// The families with and without clutter share their worlds: a seed gives the same route and
/// landmarks in sparse and sparse-cluttered, and the same route in all four.
struct WorldFamily {
  std::string name;
  RandomWorldOptions world;
  SimulatorConfig config;

  /// The world of `world_seed` (its origin recorded) with the family's config; config.seed, the
  /// noise's, stays 1 for the caller to set.
  Scenario member(std::uint64_t world_seed) const;
};

/// The family called `name`. Throws std::invalid_argument for an unknown name, suggesting the
/// closest known one and listing them all.
WorldFamily world_family(const std::string& name);

/// The names world_family() knows, in the order above.
std::vector<std::string> world_family_names();

}  // namespace slamkit
