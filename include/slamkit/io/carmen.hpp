#pragma once
// Reader and writer for CARMEN logs (the format of the Radish laser datasets): planar laser scans
// with the odometry pose the robot had when it took each one.
//
// Lines read (whitespace-separated; '#' comments and blank lines skipped; a plain file or .gz):
//
//   FLASER n r1..rn x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
//   ROBOTLASER1 type start_angle fov angular_res max_range accuracy remission_mode n r1..rn
//               m v1..vm laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
//               forward_safety side_safety turn_axis timestamp host logger_timestamp
//   ODOM x y theta tv rv accel timestamp host logger_timestamp
//   PARAM name value ...
// Other message kinds (RLASER, TRUEPOS, NEFF, SYNC, ...) are counted and skipped. A log holding both
// laser kinds (CARMEN's logger writes the same scans as both) is read from its ROBOTLASER1 lines, its
// FLASER lines counted as skipped.
//
// How a log becomes a Dataset: each laser line is one RangeScanEvent, preceded by one ControlEvent
// for the OdometryModel, (rot1, trans, rot2), from the previous laser line's odometry pose to its own
// (the first from the initial pose, so a zero control over dt = 0). GMapping does the same: the
// odometry a scan is matched from is the pose its laser line carries; ODOM lines are read and checked
// but do not drive the filter, as their clock and the laser's need not agree.
//
// FLASER's beams span the front laser's field of view (PARAM laser_front_laser_fov, in radians or,
// above 2 pi, degrees; 180 degrees when the log does not say) from the robot's right: an odd count
// (181, 361) has a beam at each end, fov / (n - 1) apart; an even count (180, 360) is fov / n apart,
// the last beam one step short of the left end. ROBOTLASER1 states its own start angle and spacing.
// The laser's pose relative to the robot's becomes the scan's sensor_offset.
//
// No return: FLASER does not state its max range, so CarmenOptions::max_range is taken; ROBOTLASER1
// states it. A reading within kNoReturnTolerance below the max range is one the log wrote rounded
// down and is raised to it, so that every no-return reads >= RangeScanEvent::max_range (which holds
// the float nearest the max range, as the readings are floats, so that the comparison is exact).
//
// Time: the laser lines' timestamp field. A laser line earlier than the laser line kept before it is
// dropped and counted (CarmenStats::out_of_order). Times are kept as recorded unless the first is
// beyond kShiftTimesFrom (a Unix time): then they are shifted to start at 0, with the first time as
// Dataset::time_origin_s and _fraction_s. A log whose clock gives two consecutive laser lines the
// same time cannot order or pair its scans (of the Radish logs, CSAIL's clock is printed to six
// significant digits, 10 s steps, Freiburg's is all zeros, the Infinite Corridor's stuck at 2^32):
// its scans are then numbered instead, the i-th laser line at t = i s, none dropped
// (CarmenStats::times_from_scan_order).
#include <cstddef>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "slamkit/core/dataset.hpp"
#include "slamkit/models/motion_model.hpp"

namespace slamkit {

/// Odometry made from a reference trajectory: each increment between consecutive laser poses, as
/// (rot1, trans, rot2), is perturbed by independent zero-mean Gaussian noise with standard deviations
///   sd(rot1)  = sqrt((rotation_per_rad |rot1|)^2 + (rotation_per_m trans)^2 + rotation_constant^2)
///   sd(rot2)  = the same with |rot2|
///   sd(trans) = sqrt((translation_per_m trans)^2 + translation_per_rad^2 (rot1^2 + rot2^2)
///                    + translation_constant^2)
/// and the perturbed increments are chained into the odometry poses, from the same seed always the
/// same (with every standard library: the Gaussians are drawn from the engine's raw output). The
/// terms add as variances, the form OdometryModel assumes, so its alphas can state this noise
/// exactly (odometry_params).
///
/// The defaults (config/radish.json's) put the dead reckoning of the Radish logs 0.7-2.7 m from their
/// reference after SE(2) alignment (position RMSE, seeds 1 to 5): Intel 2.59 1.45 1.09 2.25 1.35,
/// ACES 2.32 1.62 1.90 1.21 2.68, CSAIL 1.39 0.67 0.81 2.28 2.37. The rotation terms are small because
/// (rot1, trans, rot2) inflates a turn on the spot: the few centimetres the reference moves while the
/// robot turns make rot1 and rot2 large and opposite (a third of Intel's increments move under 0.1 m
/// with |rot1| > 0.5 rad), and each is charged rotation_per_rad. With 0.05 rad/rad and 0.02 rad/m, Intel's
/// dead reckoning is 7-15 m off.
struct MadeOdometry {
  std::uint64_t seed = 1;
  double translation_per_m = 0.05;      // m per m
  double translation_per_rad = 0.01;    // m per rad
  double translation_constant = 0.0;    // m per increment
  double rotation_per_rad = 0.005;      // rad per rad
  double rotation_per_m = 0.005;        // rad per m
  double rotation_constant = 0.0;       // rad per increment
};

/// The OdometryModel noise that states `noise`: alpha_rot_rot = rotation_per_rad^2, alpha_rot_trans =
/// rotation_per_m^2, alpha_trans_trans = translation_per_m^2, alpha_trans_rot = translation_per_rad^2,
/// min_variance the larger constant's square (OdometryModel has one floor for all three, so this is
/// exact when the constants are equal or zero; zero constants keep OdometryModel's default floor).
OdometryModel::Params odometry_params(const MadeOdometry& noise);

/// The odometry made from `reference` (poses in order) as MadeOdometry says: the first pose is the
/// reference's own, each next one the previous moved by its perturbed increment (OdometryModel's
/// predict of the increment OdometryModel::between gives).
std::vector<Pose2> make_odometry(const std::vector<Pose2>& reference, const MadeOdometry& noise);

struct CarmenOptions {
  /// The log's poses are a reference (a corrected log): the truth is its laser lines' robot poses,
  /// and the odometry the filter is given is made from them through `made_odometry`, starting at
  /// the first of them (so estimate and truth share a frame). A reference log beside it is not read.
  bool poses_are_reference = false;
  MadeOdometry made_odometry;
  /// The noise the filter assumes for the odometry (OdometryModel's alphas).
  OdometryModel::Params motion;
  /// Max range assumed where the log does not state one (FLASER) [m]. The Radish logs write no
  /// return as 81.83 (Intel), 81.91 (CSAIL, Freiburg) or 50.00 (ACES, whose real readings end at
  /// 49.7 m): 80 catches the first three; ACES needs 50 (config/radish.json).
  double max_range = 80.0;
};

/// Reads options from a JSON object (the dataset settings file): keys poses_are_reference (bool),
/// made_odometry {seed, translation_per_m, translation_per_rad, translation_constant_m,
/// rotation_per_rad, rotation_per_m, rotation_constant_rad}, motion {alpha_rot_rot, alpha_rot_trans,
/// alpha_trans_trans, alpha_trans_rot, min_variance}, max_range_m. Missing keys keep their defaults;
/// an unknown key or a value of the wrong type or range is an InputError naming `source` and the key.
CarmenOptions carmen_options_from_json(const nlohmann::json& settings, const std::string& source);
/// The options as JSON with the keys carmen_options_from_json reads.
nlohmann::json to_json(const CarmenOptions& options);

/// A reading this close below the max range is a no-return written rounded down [m]: the logs give
/// ranges to the centimetre.
inline constexpr double kNoReturnTolerance = 0.005;
/// A first laser time at or beyond this [s] (about 11.6 days, longer than any log runs) is a date:
/// the times are shifted to start at 0.
inline constexpr double kShiftTimesFrom = 1e6;

struct CarmenStats {
  std::size_t laser_lines = 0;  // of the kind read (ROBOTLASER1 where the log has any, else FLASER)
  std::size_t odom_lines = 0;
  std::size_t skipped_lines = 0;  // other message kinds, and FLASER lines beside ROBOTLASER1 ones
  /// Laser lines dropped because their time was before the previous kept laser line's (documented
  /// skip).
  std::size_t out_of_order = 0;
  std::size_t scans = 0;       // laser lines kept: the dataset's RangeScanEvents
  std::size_t no_returns = 0;  // readings at or beyond their scan's max range
  /// The log's clock gave two consecutive laser lines the same time, so the scans were numbered.
  bool times_from_scan_order = false;
  std::size_t truth_poses = 0;
  /// The reference log beside the log that became the truth; empty if none was read.
  std::string reference_path;
};

/// Reads `path` (plain or .gz). A reference trajectory beside it, `<stem>.reference.log` (or .gz) for
/// `<stem>.log[.gz]` (of another name, the stem is the name without .gz), becomes the truth: the robot
/// poses of its laser lines, or of its ODOM lines if it has no laser lines, on the log's clock (the
/// same time origin; numbered as the log's laser lines, which it must then match in number, when the
/// log's scans are numbered), those out of order dropped. Throws InputError naming the file and line
/// for a malformed line: a wrong field count (a truncated line, a range count that does not match the
/// ranges), a number that is not one or not finite, a negative range; naming the file for a log
/// without laser lines.
Dataset read_carmen(const std::string& path, const CarmenOptions& options = {}, CarmenStats* stats = nullptr);

/// Writes `dataset` (ControlEvents for the OdometryModel and RangeScanEvents) as a plain-text CARMEN
/// log of ROBOTLASER1 lines, with an ODOM line after each control, the odometry poses chained from the
/// dataset's initial pose; and, when the dataset has truth poses, the reference log beside it
/// (`<stem>.reference.log`, ODOM lines of the truth at the scan times, interpolated where needed;
/// removed, with a .gz one, when it has none, so no stale truth is read back). Times are written in
/// the source's clock (plus Dataset::time_origin_s). read_carmen gives back the same events to 1e-6
/// where the dataset has one control before each scan, as read_carmen makes them (several are
/// merged into one); the controls come back as OdometryModel::between gives them. Throws
/// std::invalid_argument, before writing, for other events or non-finite values, and InputError if a
/// file cannot be written.
void write_carmen(const std::string& path, const Dataset& dataset);

}  // namespace slamkit
