#pragma once
// Reader for the UTIAS Multi-Robot Cooperative Localization and Mapping dataset (MRCLAM; Leung,
// Halpern, Barfoot and Liu, IJRR 30(8), 2011): five differential-drive robots in a 15 m x 8 m room
// with 15 barcoded landmarks, logging commanded velocities and camera range-bearing measurements,
// with motion-capture ground truth. One robot of one dataset directory becomes one Dataset.
//
// Files read from the dataset directory (each may also be gzip-compressed as NAME.gz; the plain file
// is preferred when both exist):
//
//   Barcodes.dat                <subject> <barcode>             subjects 1-5 robots, 6-20 landmarks
//   Landmark_Groundtruth.dat    <subject> <x> <y> <std_x> <std_y>      optional: truth landmarks
//   RobotN_Odometry.dat         <t> <v> <omega>                 commanded velocities, ~67 Hz
//   RobotN_Measurement.dat      <t> <barcode> <range> <bearing>
//   RobotN_Groundtruth.dat      <t> <x> <y> <theta>             optional: truth poses
//
// How the files become a Dataset:
//
// - Time: t = 0 is the robot's first odometry row; every stream is shifted by that same Unix time
//   (MrclamStats::time_origin) as it is parsed, whole seconds apart from their fraction, so relative
//   times carry the file's milliseconds without the 0.1 us rounding of a double near 1.2e9. The run
//   ends at the last odometry row, whose command is dropped: nothing says how long it was held.
//   The truth is cut to the same span.
// - Controls: a command holds until the next odometry row, so the row at t_k gives a ControlEvent
//   (v_k, omega_k) over (t_k + d, t_k+1 + d], for the VelocityModel, d the command delay (the robots
//   act on a command about 0.2 s after logging it: without d, the commanded turn over 0.25 s windows
//   differs from the motion-capture one by 2.6e-3 rad^2/s on robot 2 of Dataset6, with d = 0.2 s by
//   7.4e-4; `slamkit calibrate` measures it). A row with the same time as the next row is held for
//   no time at all and is skipped (counted as superseded).
// - Scans: measurement rows map barcode -> subject through Barcodes.dat; the subject number is the
//   landmark id, matching Landmark_Groundtruth.dat, and also the truth's observation id (a map built
//   without the ids is paired with the true one by its landmarks' origins). Rows seeing another
//   robot, rows with a barcode
//   Barcodes.dat does not list (false detections), and rows outside the run are dropped and counted.
//   One camera frame is logged as rows up to a few milliseconds apart (frames are ~0.23 s apart), so
//   rows within scan_window of the first row of a group form one ScanEvent at that first row's time.
//   A scan taken between two odometry rows splits the held command there, so the filter sees the
//   scan at the pose of its own time rather than that of the last odometry row.
// - Initial pose: the ground-truth pose interpolated at t = 0, so the estimate lives in the truth's
//   frame, as with the simulator. This uses the truth for the start only, the usual practice with
//   this dataset. Without truth covering t = 0 (Dataset1 lost its robot ground truth) the run starts
//   at the origin, and the map frame is the robot's start.
#include <cstddef>
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/models/velocity_model.hpp"

namespace slamkit {

/// What a filter should assume about an MRCLAM robot. The defaults, also in config/mrclam.json, are
/// `slamkit calibrate` on robots 1-3 of Dataset6 against the motion-capture truth (calib/
/// calibration.hpp says how each is measured; docs/mrclam-calibration.md has the evidence and the
/// check on robots 4-5), rounded to two or three digits:
///
/// - Command delay 0.21 s (robots 1-5 alone: 0.19-0.28 s).
/// - Motion: over the stretches between scans, the commanded motion's along-track error variance per
///   second is q_v = 4.5e-4 m^2/s and its heading error's q_omega = 1.03e-3 rad^2/s; over windows of
///   0.25 s they are 4.8e-5 and 6.2e-4, over 20 s 4.9e-4 and 1.4e-3 (a speed bias of about 3 mm/s
///   and a turn-rate bias of about 4e-3 rad/s build up).
/// - Measurements: per observation the range error's RMS is 0.18 m (0.07 m at 1-2 m, 0.2 m beyond
///   5 m) and the bearing's 0.72 deg, but an error holds over a pass of a landmark (correlation 0.9
///   between consecutive range errors, 0.5 at 5 s): the white noise that gives each pass's mean its
///   error is sigma_range = 0.45 m and sigma_bearing = 1.6 deg. 4 gross outliers of 9,121 left out.
///   No sensor offset lowers either: the camera is modelled at the pose origin.
/// - Sensor: bearings reach 0.59 rad, ranges 8.6 m in Dataset6 (9.3 m in Dataset1).
struct MrclamOptions {
  VelocityModel::Params motion{.q_v = 4.5e-4, .q_omega = 1.03e-3};
  RangeBearingModel::Params measurement{.sigma_range = 0.45, .sigma_bearing = deg2rad(1.6), .offset_x = 0.0,
                                        .offset_y = 0.0};
  SensorLimits sensor{.max_range = 10.0, .fov = deg2rad(70.0)};
  double scan_window = 0.02;   // s: rows less than this after a scan's first row belong to it
  double command_delay = 0.21;  // s: a command takes effect this long after its odometry row
};

/// Reads options from a JSON object with any of the keys q_v_m2_per_s, q_omega_rad2_per_s,
/// sigma_range_m, sigma_bearing_deg, sensor_offset_x_m, sensor_offset_y_m, max_range_m, fov_deg,
/// scan_window_s and command_delay_s; missing keys keep their defaults. An
/// unknown key, a value that is not a number or out of range is an InputError naming `source` and
/// the key.
MrclamOptions mrclam_options_from_json(const nlohmann::json& json, const std::string& source);

/// The options as JSON with the keys mrclam_options_from_json reads.
nlohmann::json to_json(const MrclamOptions& options);

/// What reading one robot found, for the user to check against the dataset's documentation.
struct MrclamStats {
  double time_origin = 0.0;  // Unix time [s] of t = 0, the robot's first odometry row
  double duration = 0.0;     // s, first to last odometry row
  std::size_t odometry_rows = 0;
  std::size_t superseded_odometry_rows = 0;  // same time as the next row: held for no time
  std::size_t measurement_rows = 0;
  std::size_t robot_measurements = 0;    // of another robot: dropped
  std::size_t unknown_barcodes = 0;      // barcode not in Barcodes.dat (false detection): dropped
  std::size_t outside_run = 0;           // landmark rows before the first or after the last odometry row
  std::size_t observations = 0;          // landmark observations kept
  std::size_t scans = 0;
  std::size_t truth_poses = 0;  // within the run
  bool initial_pose_from_truth = false;
};

/// Reads robot `robot` (1 to 5) of the MRCLAM dataset in `dataset_dir` (e.g. .../MRCLAM_Dataset6).
/// The Dataset has the VelocityModel and RangeBearingModel of `options`, name "mrclam:" + the
/// directory's last component + "/RobotN". Throws InputError naming the file and line on a missing
/// or malformed file, a time going backwards, or a robot number out of range.
Dataset read_mrclam(const std::string& dataset_dir, int robot, const MrclamOptions& options = {});
/// The same, also reporting what was read and dropped.
Dataset read_mrclam(const std::string& dataset_dir, int robot, const MrclamOptions& options,
                    MrclamStats& stats);

/// A robot named by a path ".../MRCLAM_Dataset6/Robot3": the dataset directory and the robot number,
/// the form a "mrclam:PATH" dataset spec takes. Throws InputError unless the last path component is
/// Robot1 to Robot5.
struct MrclamRobot {
  std::string dataset_dir;
  int robot = 0;
};
MrclamRobot parse_mrclam_robot_path(const std::string& path);

}  // namespace slamkit
