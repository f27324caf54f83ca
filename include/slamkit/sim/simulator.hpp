#pragma once
// The landmark-SLAM simulator of the tutorial's reference implementation (Tim Bailey's MATLAB
// EKF-SLAM and FastSLAM simulators): a car-like vehicle drives round the waypoints of a World with a
// rate-limited steering controller, and a range-bearing sensor sees every landmark within range.
// The result is a Dataset: noisy controls and observations for the filter, and the ground truth.
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "slamkit/angles.hpp"
#include "slamkit/io/dataset.hpp"
#include "slamkit/sim/world.hpp"

namespace slamkit {

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
  // Sensor.
  double max_range = 30.0;              // m
  double fov = 2.0 * kPi;               // rad, full opening angle centred on the heading
  double sigma_range = 0.1;             // m
  double sigma_bearing = deg2rad(1.0);  // rad
  // Timing.
  double control_period = 0.025;    // s
  double observation_period = 0.2;  // s, a whole multiple of control_period
  std::uint64_t seed = 1;
};

/// The config as JSON: angles in degrees, every key named with its unit (e.g. "sigma_steer_deg").
nlohmann::json to_json(const SimulatorConfig& config);

/// Reads what to_json writes. Missing keys keep their defaults; an unknown key, a value of the wrong
/// type or out of range is an InputError naming `source_name` and the key.
SimulatorConfig simulator_config_from_json(const nlohmann::json& json, const std::string& source_name);

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
/// period, right after that step's control, a ScanEvent holds a noisy range-bearing measurement,
/// with its true id, of each landmark within range and field of view; a sweep that sees nothing
/// yields no ScanEvent. The run ends when the vehicle gets back to the first waypoint after the
/// last lap.
///
/// Throws InputError for an invalid config, a world with fewer than 2 waypoints, or a route the
/// vehicle cannot follow (a waypoint inside its turning circle, which it would orbit forever).
Dataset simulate(const World& world, const SimulatorConfig& config);

}  // namespace slamkit
