#pragma once
// Reader for the landmark-SLAM log format of the widely used robot-mapping course exercises
// (sensor_data.dat and world.dat): an odometry-driven robot with a range-bearing sensor that
// identifies its landmarks.
//
//   sensor_data.dat   one block per time step:
//                       ODOMETRY <rot1> <trans> <rot2>        the motion of the step [rad, m, rad]
//                       SENSOR <id> <range> <bearing>         zero or more observations [m, rad]
//                     landmark ids start at 1; the bearing is relative to the robot's heading.
//   world.dat         <id> <x> <y>                             the true landmarks (optional)
//
// The format has no timestamps: step k (1-based) ends at t = k * step_period, its ODOMETRY line
// becoming a ControlEvent over ((k - 1) step_period, k step_period] and its SENSOR lines one
// ScanEvent at the same t (no ScanEvent for a step without SENSOR lines). The robot starts at the
// origin, facing along x, at t = 0. There is no truth for the poses; world.dat, when present, gives
// the true landmarks. The SENSOR ids are the landmarks' identities, so they are also the truth's
// observation ids: a map built without them is paired with world.dat by its landmarks' origins.
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

/// What a filter should assume about a course log, whose files say nothing of their noise. The
/// defaults (also config/course.json) are the OdometryModel's own and a loose 0.1 m / 5 deg sensor,
/// which is what examples/course was generated with; the sensor limits are wide enough to see the
/// whole of a room-sized world.
struct CourseOptions {
  OdometryModel::Params motion;
  RangeBearingModel::Params measurement{.sigma_range = 0.1, .sigma_bearing = deg2rad(5.0), .offset_x = 0.0,
                                        .offset_y = 0.0};
  SensorLimits sensor{.max_range = 50.0, .fov = 2.0 * kPi};
  double step_period = 0.1;  // s, the time one step of the log stands for
};

/// Reads options from a JSON object with any of the keys alpha_rot_rot, alpha_rot_trans,
/// alpha_trans_trans, alpha_trans_rot, min_variance (the OdometryModel's, in rad^2 and m^2 per rad^2
/// or m^2 of motion), sigma_range_m, sigma_bearing_deg, max_range_m, fov_deg and step_period_s;
/// missing keys keep their defaults. An unknown key, a value that is not a number or out of range is
/// an InputError naming `source` and the key.
CourseOptions course_options_from_json(const nlohmann::json& json, const std::string& source);

/// The options as JSON with the keys course_options_from_json reads.
nlohmann::json to_json(const CourseOptions& options);

/// Reads a course log. `path` is the directory holding sensor_data.dat (and world.dat, if there is
/// one), or the path of the sensor data file itself with world.dat beside it. The Dataset has the
/// OdometryModel and RangeBearingModel of `options`, name "course:" + the directory's (or file's)
/// name. Throws InputError naming the file and line on an unknown keyword, a wrong field count, a
/// number that is not finite, a SENSOR line before any ODOMETRY line, a duplicate landmark in
/// world.dat, or a missing sensor data file.
Dataset read_course_log(const std::string& path, const CourseOptions& options = {});

}  // namespace slamkit
