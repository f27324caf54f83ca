#pragma once
// The Victoria Park dataset (ACFR; Guivant and Nebot, IEEE T-RA 17(3), 2001): a car driven for
// 26 minutes through a park in Sydney, with a 180 degree laser, wheel encoder, steering sensor and
// GPS. The landmarks are tree trunks, extracted here from the raw scans with TreeDetector.
//
// This reads ACFR's ASCII release (folder acfr_ascii/), because it is the only release that has the
// raw laser: the .mat release's aa3_lsr2.mat is not available. Its files:
//   DRS.txt               time_s  encoder_speed_m/s  steering_rad        (tab-separated, CRLF)
//   GPS.txt               time_s  north_m  east_m                      (north first; metres from the
//                                                                        first fix)
//   LASER.txt.gz          time_s  then 361 ranges [m], beam k at k * 0.5 deg, 0 = the car's right,
//                         90 deg ahead; 81.91 m means no return. One scan per line.
// Time is in seconds from the first GPS fix. Sensors_manager.txt, the release's merged event order,
// is not needed: it is the time order of the three files, with dead reckoning before a laser scan
// stamped at the same time, which is how the events are merged here.
//
// The dataset:
// - A ControlEvent (encoder speed, steering) per dead-reckoning row, applied over the time since the
//   previous row (the first row: since the start). A scan that falls inside that interval splits it
//   into two events with the same control, so that the filter has predicted to the scan's time when
//   the scan comes.
// - A ScanEvent per laser scan (scans without a tree too): the trees within max_range, as range and
//   vehicle-frame bearing from the laser, without identities. After it, at the same time, a
//   RangeScanEvent with the scan's raw ranges (beam 0 at -90 degrees, 0.5 degrees apart, no offset;
//   readings of 75 m and more are no returns), so that the grid filters (scan-matching,
//   grid-fastslam) map the same log; each filter takes the kind it maps with.
// - Motion: AcfrCarModel, whose state is the laser pose; observation: RangeBearingModel without an
//   offset (the laser is the pose); sensor limits: max_range and a 180 degree field of view.
// - Ground truth: the GPS fixes as positions (x = east, y = north; no heading). The antenna sits at
//   the laser, so GPS and state describe the same point.
// - initial_pose: (0, 0, initial_heading) in the GPS frame, i.e. at the first fix; the heading is
//   not measured (see VictoriaParkOptions::initial_heading).
#include <limits>
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/models/acfr_car.hpp"
#include "slamkit/sensors/tree_detector.hpp"

namespace slamkit {

/// Defaults are the shipped config/victoria-park.json. Angles in radians.
struct VictoriaParkOptions {
  /// Trees farther than this are left out of the scans, as in the literature (UFastSLAM: 30 m).
  double max_range = 30.0;              // m
  double sigma_range = 1.0;             // m
  double sigma_bearing = deg2rad(3.0);  // rad
  /// The car's heading at the first GPS fix, east = 0, counter-clockwise. It is not measured. The
  /// dead reckoning integrated from the first fix fits the GPS best with 35.8 deg over the first
  /// 30 s, while the car drives nearly straight; longer windows fit 37 to 40 deg as the steering
  /// calibration's error builds up. Published code uses 35.5 to 36. The aligned metrics do not
  /// depend on it; a good value makes the unaligned estimate and the GPS comparable by eye.
  double initial_heading = deg2rad(36.0);  // rad
  /// Car geometry and control noise (sigma_speed, sigma_steer).
  AcfrCarModel::Params car;
  TreeDetector::Params detector;
  /// Only events and GPS fixes with start_time <= t <= end_time are kept, for short runs. With a
  /// later start the initial pose is no longer where the car is in the GPS frame; only the aligned
  /// metrics are then meaningful.
  double start_time = 0.0;                                    // s
  double end_time = std::numeric_limits<double>::infinity();  // s
};

/// Reads the options from JSON: keys with units in their names, angles in degrees, all optional
/// (missing keys keep the defaults), the detector's settings in a "tree_detector" object and the
/// car's in "car". An unknown key, a wrong type or an out-of-range value is an InputError naming
/// `source` and the key.
VictoriaParkOptions victoria_park_options_from_json(const nlohmann::json& json, const std::string& source);

/// Reads the dataset from `dir`: the victoria_park folder (the one holding acfr_ascii/) or the
/// acfr_ascii folder itself. Throws InputError naming the file, the line and what was expected for a
/// missing file or a malformed, truncated or out-of-order line.
Dataset read_victoria_park(const std::string& dir, const VictoriaParkOptions& options);
/// The same with the default options.
Dataset read_victoria_park(const std::string& dir);

}  // namespace slamkit
