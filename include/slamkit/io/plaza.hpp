#pragma once
// Reader for the CMU Plaza range-only data sets (J. Djugash, B. Hamner, S. Roth, "Navigating with
// Ranging Radios: Five Data Sets with Ground Truth", JFR 26(9), 2009), in the text form GTSAM's
// examples ship them: an autonomous lawn mower driving round a plaza with odometry and a radio that
// measures its range (no bearing) to four ultra-wideband beacons, with ground truth. One run
// (Plaza1, Plaza2, ...) of a folder becomes one Dataset.
//
// Files read from the folder, for a run R (whitespace-separated numbers; GTSAM's DR and TD files are
// %.16e with a trailing tab and CRLF line ends):
//
//   R_DR.txt   <t> <distance> <heading change>      the motion since the row before [s, m, rad]
//   R_TD.txt   <t> <sender> <beacon> <range>        one range [m] to one beacon; the sender (2 on
//                                                   every row of Plaza1) is checked and not kept
//   R_GT.txt   <t> <x> <y> <heading>                ground truth [s, m, m, rad]: one row at the pose
//                                                   the first DR row moves from, then one per DR row
//   R_TL.txt   <beacon> <x> <y>                     the beacons' surveyed positions [m]
//
// GTSAM ships R_DR.txt and R_TD.txt; R_GT.txt and R_TL.txt are the GT and TL variables of its
// R_.mat written out as text (docs/datasets.md).
//
// How the files become a Dataset:
//
// - Time: t = 0 is the first ground-truth row, the pose the first DR row moves from; every stream is
//   shifted by that time (PlazaStats::time_origin, Dataset::time_origin_s and _fraction_s). The
//   run ends at the last DR row; range rows outside [0, end] are dropped and counted, and the truth
//   is cut to the same span.
// - Controls: DR row k becomes a ControlEvent at t_k over t_k - t_(k-1) (t_0 = 0) with the
//   OdometryModel control (dtheta/2, d, dtheta/2), the midpoint approximation of the step's arc. DR
//   times must increase.
// - Scans: the ranges with one timestamp form one ScanEvent, one Observation per range: a 1-D
//   measurement whose id is the beacon id (so identities are known), which must be a beacon of
//   R_TL.txt. The raw ranges are kept: they carry a bias of about +2.8 m that nothing here removes.
//   The TD rows need not be in time order (Plaza1's jump back twice, by 64 s and 50 s, into spans
//   already covered, and those rows fit the ground truth at their stated times), so they are sorted
//   by time, rows at the same time in file order.
// - Events merge in time order, a control before a scan at the same time: a scan is taken at the
//   pose of the last DR row at or before it, at most one DR period (about 0.2 s) earlier.
// - Truth: the GT poses and the TL beacons as landmarks (ids the beacon ids); the ranges' ids are
//   also the truth's observation ids. GT's heading is DR's heading changes summed from GT's first
//   row (to 1e-13 rad in Plaza1): the odometry's own heading, in GT's frame, rather than an
//   independent measurement. initial_pose is the first GT row.
#include <cstddef>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

/// What a filter should assume about a Plaza run. The defaults, also config/plaza.json:
///
/// - Motion: OdometryModel noise under which the dead-reckoned displacement over 30 s (150 DR rows)
///   of Plaza1, in the frame of the window's first GT pose, has a median position NEES against GT of
///   1.4 (the chi-square median for 2 degrees of freedom is 1.39); over 5 s 2.7, over 100 s 0.25, as
///   the error grows slower than a random walk. Over 1 s the median is 16: differences of 4-5 cm
///   there are more likely GT's own noise than the odometry's. The floor on the variance keeps the
///   noise of the long stops positive definite.
/// - Measurement: sigma_range 1.2 m, the spread of Plaza1's ranges about their +2.8 m bias (1.4826
///   times the median absolute deviation of range minus true distance). It does not cover the bias.
/// - Sensor: ranges reach 75.0 m in Plaza1; the radio has no field of view.
struct PlazaOptions {
  OdometryModel::Params motion{.alpha_rot_rot = 0.01,
                               .alpha_rot_trans = 1e-4,
                               .alpha_trans_trans = 2.5e-3,
                               .alpha_trans_rot = 1e-4,
                               .min_variance = 1e-6};
  RangeOnlyModel::Params measurement{.sigma_range = 1.2, .offset_x = 0.0, .offset_y = 0.0};
  SensorLimits sensor{.max_range = 80.0, .fov = 2.0 * kPi};
};

/// Reads options from a JSON object with any of the keys alpha_rot_rot, alpha_rot_trans,
/// alpha_trans_trans, alpha_trans_rot, min_variance (the OdometryModel's, in rad^2 and m^2 per rad^2
/// or m^2 of motion), sigma_range_m, sensor_offset_x_m, sensor_offset_y_m, max_range_m and fov_deg;
/// missing keys keep their defaults. An unknown key, a value that is not a number or out of range
/// is an InputError naming `source` and the key.
PlazaOptions plaza_options_from_json(const nlohmann::json& json, const std::string& source);

/// The options as JSON with the keys plaza_options_from_json reads.
nlohmann::json to_json(const PlazaOptions& options);

/// What reading one run found, for the user to check against the data set's documentation.
struct PlazaStats {
  double time_origin = 0.0;  // s, the first GT row's time in the files' clock: t = 0
  double duration = 0.0;     // s, t = 0 to the last DR row
  std::size_t odometry_rows = 0;
  std::size_t range_rows = 0;
  std::size_t reordered_range_rows = 0;  // earlier than the row before them in the file
  std::size_t outside_run = 0;           // before t = 0 or after the last DR row: dropped
  std::size_t observations = 0;          // ranges kept
  std::size_t scans = 0;
  std::size_t truth_poses = 0;  // within the run
  std::size_t beacons = 0;
};

/// The run read when a spec names none.
inline constexpr const char* kPlazaDefaultRun = "Plaza1";

/// The run named `given` as its files spell it, "PlazaN": "plaza" in any case followed by a whole
/// number N from 1 without leading zeros. Nothing for any other name.
std::optional<std::string> plaza_run_name(std::string_view given);

/// Reads run `run` ("Plaza1"; see plaza_run_name) of the Plaza folder `dir`. The Dataset has the
/// OdometryModel and RangeOnlyModel of `options`, name "plaza:" + the run. Throws InputError naming
/// the file and line on a missing, empty or malformed file (a field that is not a number, a wrong
/// field count), DR or GT times going backwards, a beacon of R_TD.txt that R_TL.txt lacks, or a
/// run name of another form.
Dataset read_plaza(const std::string& dir, const std::string& run = kPlazaDefaultRun, const PlazaOptions& options = {});
/// The same, also reporting what was read and dropped.
Dataset read_plaza(const std::string& dir, const std::string& run, const PlazaOptions& options, PlazaStats& stats);

}  // namespace slamkit
