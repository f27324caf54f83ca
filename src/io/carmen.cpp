#include "slamkit/io/carmen.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/coordinates.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/pose_at.hpp"
#include "slamkit/core/random_draws.hpp"
#include "slamkit/core/text_reader.hpp"
#include "slamkit/core/version.hpp"
#include "line_writer.hpp"
#include "reader_common.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

// ---- Options ----------------------------------------------------------------------------------------

using namespace option_ranges;
using CarmenReal = RealOption<CarmenOptions>;
using CarmenSeed = IntegerOption<CarmenOptions, std::uint64_t>;

// The runner's bound on every value a dataset hands it (kMaxAbsValue of pipeline/runner.hpp, which io
// cannot include): beyond it a range is a misread field, and a float could not even hold some.
constexpr double kMaxRangeReading = 1e6;
constexpr RealRange kMaxRangeSetting{[](double v) { return v > 0.0 && v <= kMaxRangeReading; }, "> 0 and <= 1e6"};

const OptionKey<CarmenOptions> kMadeOdometryKeys[] = {
    {"seed", CarmenSeed{[](CarmenOptions& o) -> std::uint64_t& { return o.made_odometry.seed; }}},
    {"translation_per_m",
     CarmenReal{[](CarmenOptions& o) -> double& { return o.made_odometry.translation_per_m; }, kNonNegative}},
    {"translation_per_rad",
     CarmenReal{[](CarmenOptions& o) -> double& { return o.made_odometry.translation_per_rad; }, kNonNegative}},
    {"translation_constant_m",
     CarmenReal{[](CarmenOptions& o) -> double& { return o.made_odometry.translation_constant; }, kNonNegative}},
    {"rotation_per_rad",
     CarmenReal{[](CarmenOptions& o) -> double& { return o.made_odometry.rotation_per_rad; }, kNonNegative}},
    {"rotation_per_m",
     CarmenReal{[](CarmenOptions& o) -> double& { return o.made_odometry.rotation_per_m; }, kNonNegative}},
    {"rotation_constant_rad",
     CarmenReal{[](CarmenOptions& o) -> double& { return o.made_odometry.rotation_constant; }, kNonNegative}},
};

const OptionKey<CarmenOptions> kCarmenMotionKeys[] = {
    {"alpha_rot_rot", CarmenReal{[](CarmenOptions& o) -> double& { return o.motion.alpha_rot_rot; }, kNonNegative}},
    {"alpha_rot_trans", CarmenReal{[](CarmenOptions& o) -> double& { return o.motion.alpha_rot_trans; }, kNonNegative}},
    {"alpha_trans_trans",
     CarmenReal{[](CarmenOptions& o) -> double& { return o.motion.alpha_trans_trans; }, kNonNegative}},
    {"alpha_trans_rot", CarmenReal{[](CarmenOptions& o) -> double& { return o.motion.alpha_trans_rot; }, kNonNegative}},
    // A floor of zero would give a robot standing still a singular control noise.
    {"min_variance", CarmenReal{[](CarmenOptions& o) -> double& { return o.motion.min_variance; }, kPositive}},
};

const OptionKey<CarmenOptions> kCarmenOptionKeys[] = {
    {"poses_are_reference", FlagOption<CarmenOptions>{[](CarmenOptions& o) -> bool& { return o.poses_are_reference; }}},
    {"made_odometry", section(kMadeOdometryKeys)},
    {"motion", section(kCarmenMotionKeys)},
    {"max_range_m", CarmenReal{[](CarmenOptions& o) -> double& { return o.max_range; }, kMaxRangeSetting}},
};

double carmen_squared(double v) { return v * v; }

// ---- Reading lines --------------------------------------------------------------------------------------

// A log time as whole seconds and fraction (both of the time's sign): a Unix time near 1.1e9 s held
// in one double keeps only 0.2 us, and the time origin is kept to the digit the log gives.
struct CarmenTime {
  long seconds = 0;
  double fraction = 0.0;

  double minus(const CarmenTime& origin) const {
    return static_cast<double>(seconds - origin.seconds) + (fraction - origin.fraction);
  }
  bool operator==(const CarmenTime&) const = default;
};

CarmenTime log_time(const TextReader& in, std::size_t i) {
  const double value = in.number(i, "the timestamp");
  if (std::abs(value) > io_detail::kMaxAbsTime)
    in.fail(fmt::format("expected a timestamp in seconds within +-{:g}, found '{}'", io_detail::kMaxAbsTime,
                        in.field(i)));
  // A plain decimal is split at its point so that the fraction keeps every digit; any other form (an
  // exponent, as CSAIL's 1.13486e+09) holds no more digits than the double.
  const std::string_view s = in.field(i);
  const std::size_t dot = s.find('.');
  if (dot != std::string_view::npos && s.find_first_of("eE") == std::string_view::npos) {
    std::string fraction_text = "0";  // appended: gcc 12 warns falsely (-Wrestrict) over operator+
    fraction_text += s.substr(dot);
    CarmenTime t;
    if (parse_long(s.substr(0, dot), t.seconds) && parse_double(fraction_text, t.fraction)) {
      if (s.front() == '-') t.fraction = -t.fraction;
      return t;
    }
  }
  return CarmenTime{static_cast<long>(std::trunc(value)), value - std::trunc(value)};
}

constexpr const char* kLaserPoseNames[] = {"the laser x", "the laser y", "the laser heading"};
constexpr const char* kRobotPoseNames[] = {"the robot x", "the robot y", "the robot heading"};

Pose2 log_pose(const TextReader& in, std::size_t i, const char* const (&names)[3]) {
  // Parsed before the pose is built: a throw inside Eigen's comma initialiser trips its assertion.
  const double x = in.coordinate(i, names[0]), y = in.coordinate(i + 1, names[1]);
  return Pose2(x, y, wrap_angle(in.number(i + 2, names[2])));
}

// A count of the fields that follow it; at most the line's length, so that sums of counts cannot wrap.
std::size_t count_field(const TextReader& in, std::size_t i, std::string_view what, long min) {
  const long n = in.integer(i, what);
  if (n < min || static_cast<unsigned long>(n) > in.size())
    in.fail(fmt::format("expected {} from {} to the line's {} fields, found {}", what, min, in.size(), n));
  return static_cast<std::size_t>(n);
}

struct LaserLine {
  CarmenTime time;
  Pose2 robot = Pose2::Zero();
  RangeScanEvent scan;  // without its time
};

struct OdomLine {
  CarmenTime time;
  Pose2 robot = Pose2::Zero();
};

// n ranges from field `first` on, into a scan whose max_range is set.
void read_ranges(const TextReader& in, std::size_t first, std::size_t n, RangeScanEvent& scan) {
  // The max range as the float the readings are held in, so that a no-return compares >= it exactly.
  const auto no_return = static_cast<float>(scan.max_range);
  const double raised_from = scan.max_range - kNoReturnTolerance;
  scan.max_range = no_return;
  scan.ranges.resize(n);
  for (std::size_t b = 0; b < n; ++b) {
    const double r = in.number(first + b, "a range");
    if (!(r >= 0.0 && r <= kMaxRangeReading))
      in.fail(fmt::format("expected range {} of {} from 0 to {:g} m, found {}", b + 1, n, kMaxRangeReading,
                          in.field(first + b)));
    scan.ranges[b] = r >= raised_from ? std::max(static_cast<float>(r), no_return) : static_cast<float>(r);
  }
}

// The laser's pose in the robot's frame.
Pose2 laser_offset(const TextReader& in, const Pose2& robot, const Pose2& laser) {
  const double c = std::cos(robot[2]), s = std::sin(robot[2]);
  const Vector2 d = laser.head<2>() - robot.head<2>();
  const Pose2 offset(c * d.x() + s * d.y(), -s * d.x() + c * d.y(), wrap_angle(laser[2] - robot[2]));
  if (!within_coordinates(offset.head<2>()))
    in.fail(fmt::format("expected the laser pose within {:g} m of the robot pose, found it ({}, {}) m away",
                        kMaxAbsCoordinate, offset.x(), offset.y()));
  return offset;
}

// Which beam spacing fits FLASER was measured on the corrected Radish logs: the end points of
// consecutive scans, each placed by its corrected pose, lie closer together (mean nearest-neighbour
// distance below 0.5 m, and in how many of the scan pairs) with
//                       fov / n                   fov / (n - 1)
//   Intel, 180 beams    0.05323 m, 538 pairs      0.05373 m, 371 pairs
//   ACES, 180 beams     0.06535 m, 293 pairs      0.06613 m, 146 pairs
//   Freiburg, 360       0.07700 m, 1169 pairs     0.07723 m, 834 pairs
//   CSAIL, 361 beams    0.05477 m, 156 pairs      0.05449 m, 249 pairs
// (the first beam at -fov / 2; each split is more than 4.5 standard deviations from even): 1 or 0.5
// degree steps in every log, a beam at each end only for an odd count.
void flaser_geometry(std::size_t n, double fov, RangeScanEvent& scan) {
  if (n == 1) return;  // one beam, straight ahead
  scan.angle_min = -fov / 2.0;
  scan.angle_increment = fov / static_cast<double>(n % 2 == 1 ? n - 1 : n);
}

LaserLine read_flaser(const TextReader& in, double fov, double max_range) {
  const std::size_t n = count_field(in, 1, "the range count", 1);
  in.expect_fields(n + 11, fmt::format("FLASER with {} ranges: FLASER n r1..rn x y theta odom_x odom_y odom_theta "
                                       "timestamp host logger_timestamp",
                                       n));
  LaserLine l;
  l.scan.max_range = max_range;
  read_ranges(in, 2, n, l.scan);
  const Pose2 laser = log_pose(in, n + 2, kLaserPoseNames);
  l.robot = log_pose(in, n + 5, kRobotPoseNames);
  l.time = log_time(in, n + 8);
  in.number(n + 10, "the logger timestamp");
  flaser_geometry(n, fov, l.scan);
  l.scan.sensor_offset = laser_offset(in, l.robot, laser);
  return l;
}

LaserLine read_robotlaser(const TextReader& in) {
  constexpr std::string_view kForm =
      "ROBOTLASER1 type start_angle fov angular_res max_range accuracy remission_mode n r1..rn m v1..vm laser_x "
      "laser_y laser_theta robot_x robot_y robot_theta tv rv forward_safety side_safety turn_axis timestamp host "
      "logger_timestamp";
  const std::size_t n = count_field(in, 8, "the range count", 1);
  if (in.size() < n + 24)
    in.fail(fmt::format("expected at least {} fields ({} ranges: {}), found {}", n + 24, n, kForm, in.size()));
  const std::size_t m = count_field(in, n + 9, "the remission count", 0);
  in.expect_fields(n + m + 24, fmt::format("{} ranges and {} remissions: {}", n, m, kForm));
  LaserLine l;
  in.number(1, "the laser type");
  const double start = in.number(2, "the start angle");
  in.number(3, "the field of view");
  const double step = in.number(4, "the angular resolution");
  const double max_range = in.number(5, "the max range");
  if (std::abs(start) > 2.0 * kPi)
    in.fail(fmt::format("expected a start angle within +-2 pi rad, found {}", in.field(2)));
  // A hair over a turn, for the rounding of a resolution written to a few digits.
  if (std::abs(step) * static_cast<double>(n - 1) > 2.0 * kPi * (1.0 + 1e-6))
    in.fail(fmt::format("expected {} beams {} rad apart to span at most 2 pi rad", n, in.field(4)));
  if (!(max_range > 0.0 && max_range <= kMaxRangeReading))
    in.fail(fmt::format("expected a max range > 0 and <= {:g} m, found {}", kMaxRangeReading, in.field(5)));
  in.number(6, "the accuracy");
  in.number(7, "the remission mode");
  l.scan.angle_min = start;
  l.scan.angle_increment = step;
  l.scan.max_range = max_range;
  read_ranges(in, 9, n, l.scan);
  for (std::size_t i = 0; i < m; ++i) in.number(n + 10 + i, "a remission");
  const std::size_t after = n + m + 10;
  const Pose2 laser = log_pose(in, after, kLaserPoseNames);
  l.robot = log_pose(in, after + 3, kRobotPoseNames);
  constexpr const char* kMotion[] = {"tv", "rv", "the forward safety distance", "the side safety distance",
                                     "the turn axis"};
  for (std::size_t i = 0; i < 5; ++i) in.number(after + 6 + i, kMotion[i]);
  l.time = log_time(in, after + 11);
  in.number(after + 13, "the logger timestamp");
  l.scan.sensor_offset = laser_offset(in, l.robot, laser);
  return l;
}

OdomLine read_odom(const TextReader& in) {
  in.expect_fields(10, "ODOM x y theta tv rv accel timestamp host logger_timestamp");
  OdomLine o;
  o.robot = log_pose(in, 1, kRobotPoseNames);
  in.number(4, "tv");
  in.number(5, "rv");
  in.number(6, "accel");
  o.time = log_time(in, 7);
  in.number(9, "the logger timestamp");
  return o;
}

// The one PARAM that says what FLASER does not: the front laser's field of view.
void read_param(const TextReader& in, double& front_fov) {
  in.expect_fields(3, std::numeric_limits<std::size_t>::max(), "PARAM name value ...");
  if (in.field(1) != "laser_front_laser_fov") return;
  double fov = in.number(2, "the front laser's field of view");
  // CARMEN's ini files give it in degrees (180), some logs in radians (CSAIL's 3.14159): no laser's
  // field of view is a few degrees, so a value above a turn in radians is degrees.
  constexpr double kTurn = 2.0 * kPi * (1.0 + 1e-9);
  if (fov > kTurn) fov = deg2rad(fov);
  if (!(fov > 0.0 && fov <= kTurn))
    in.fail(fmt::format("expected laser_front_laser_fov > 0 and <= 2 pi (rad) or <= 360 (deg), found {}",
                        in.field(2)));
  front_fov = fov;
}

struct CarmenLog {
  std::vector<LaserLine> flaser, robotlaser;
  std::vector<OdomLine> odom;
  std::size_t skipped = 0;

  // CARMEN's logger writes each scan as both kinds; ROBOTLASER1 states its geometry.
  std::vector<LaserLine>& laser() { return robotlaser.empty() ? flaser : robotlaser; }
  std::size_t skipped_lines() const { return skipped + (robotlaser.empty() ? 0 : flaser.size()); }
};

CarmenLog read_carmen_file(const std::string& path, double flaser_max_range) {
  TextReader in(path);
  CarmenLog log;
  double front_fov = kPi;
  while (in.next()) {
    const std::string_view kind = in.field(0);
    if (kind == "FLASER")
      log.flaser.push_back(read_flaser(in, front_fov, flaser_max_range));
    else if (kind == "ROBOTLASER1")
      log.robotlaser.push_back(read_robotlaser(in));
    else if (kind == "ODOM")
      log.odom.push_back(read_odom(in));
    else if (kind == "PARAM")
      read_param(in, front_fov);
    else
      ++log.skipped;
  }
  return log;
}

// ---- Time -----------------------------------------------------------------------------------------------

// How a log's times become the dataset's: shifted by the origin, or the laser lines numbered.
struct CarmenClock {
  bool numbered = false;
  CarmenTime origin;
};

CarmenClock choose_clock(const std::vector<LaserLine>& lines) {
  CarmenClock clock;
  for (std::size_t k = 1; k < lines.size(); ++k)
    if (lines[k].time == lines[k - 1].time) {
      clock.numbered = true;
      return clock;
    }
  const CarmenTime& first = lines.front().time;
  if (std::abs(static_cast<double>(first.seconds) + first.fraction) >= kShiftTimesFrom) clock.origin = first;
  return clock;
}

// Each time on the clock, or nothing for one earlier than the last kept one (counted in `dropped`).
std::vector<std::optional<double>> clock_times(const std::vector<CarmenTime>& times, const CarmenClock& clock,
                                               std::size_t& dropped) {
  std::vector<std::optional<double>> out;
  out.reserve(times.size());
  double last = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < times.size(); ++k) {
    const double t = clock.numbered ? static_cast<double>(k) : times[k].minus(clock.origin);
    if (t < last) {
      ++dropped;
      out.emplace_back();
      continue;
    }
    last = t;
    out.emplace_back(t);
  }
  return out;
}

// ---- Files ----------------------------------------------------------------------------------------------

// `<stem>` of `<stem>.log` or `<stem>.log.gz` (of any other name, the name without .gz).
std::string log_stem(const fs::path& file) {
  std::string name = file.filename().string();
  for (const std::string_view suffix : {std::string_view(".gz"), std::string_view(".log")})
    if (name.size() > suffix.size() && name.ends_with(suffix)) name.resize(name.size() - suffix.size());
  return name;
}

fs::path reference_path(const fs::path& log) { return log.parent_path() / (log_stem(log) + ".reference.log"); }

std::vector<StampedPose> read_reference(const std::string& path, const CarmenClock& clock, std::size_t log_lines,
                                        double max_range) {
  CarmenLog ref = read_carmen_file(path, max_range);
  const std::vector<LaserLine>& lines = ref.laser();
  std::vector<CarmenTime> times;
  std::vector<Pose2> poses;
  for (const LaserLine& l : lines) {
    times.push_back(l.time);
    poses.push_back(l.robot);
  }
  if (lines.empty())
    for (const OdomLine& o : ref.odom) {
      times.push_back(o.time);
      poses.push_back(o.robot);
    }
  if (poses.empty()) throw InputError(path, 0, "no poses; expected a reference log of laser or ODOM lines");
  if (clock.numbered && lines.size() != log_lines)
    throw InputError(path, 0,
                     fmt::format("{} laser lines; expected {}, one per laser line of the log beside it, whose "
                                 "clock cannot pair them by time (it gives two consecutive scans the same time)",
                                 lines.size(), log_lines));
  std::size_t dropped = 0;
  const std::vector<std::optional<double>> t = clock_times(times, clock, dropped);
  std::vector<StampedPose> truth;
  for (std::size_t k = 0; k < poses.size(); ++k)
    if (t[k]) truth.push_back(StampedPose{*t[k], poses[k]});
  return truth;
}

// ---- Writing --------------------------------------------------------------------------------------------

// The writer's counterpart of the reader's checks, run before a file is created.
[[noreturn]] void refuse_to_write(const std::string& path, const std::string& message) {
  throw std::invalid_argument("cannot write " + path + ": " + message);
}

void check_writable(const std::string& path, const Dataset& dataset) {
  const OdometryModel model;
  Pose2 pose = dataset.initial_pose;
  double previous = -std::numeric_limits<double>::infinity();
  const auto check_pose = [&](std::size_t i) {
    if (!within_coordinates(pose.head<2>()) || !std::isfinite(pose.z()))
      refuse_to_write(path, fmt::format("the odometry pose at event {} is not finite or beyond +-{:g} m", i,
                                        kMaxAbsCoordinate));
  };
  check_pose(0);
  for (std::size_t i = 0; i < dataset.events.size(); ++i) {
    const Event& event = dataset.events[i];
    const double t = event_time(event);
    // The reader drops a laser line earlier than the one before; the written log must keep them all.
    if (!(t >= previous && std::abs(t) <= io_detail::kMaxAbsTime))
      refuse_to_write(path, fmt::format("event {} has time {}; expected finite times that never decrease", i, t));
    previous = t;
    if (const auto* control = std::get_if<ControlEvent>(&event)) {
      if (control->u.size() != 3 || !control->u.allFinite())
        refuse_to_write(path, fmt::format("event {} is not a finite control (rot1, trans, rot2) of the odometry "
                                          "model; expected odometry controls only",
                                          i));
      pose = model.predict(pose, control->u, control->dt);
      check_pose(i);
    } else if (const auto* scan = std::get_if<RangeScanEvent>(&event)) {
      const double span = std::abs(scan->angle_increment) * static_cast<double>(scan->ranges.size());
      const bool ranges_ok = std::all_of(scan->ranges.begin(), scan->ranges.end(),
                                         [](float r) { return r >= 0.0F && r <= kMaxRangeReading; });
      if (scan->ranges.empty() || !ranges_ok || !(std::abs(scan->angle_min) <= 2.0 * kPi) || !(span <= 2.0 * kPi) ||
          !(scan->max_range > 0.0 && scan->max_range <= kMaxRangeReading) ||
          !within_coordinates(scan->sensor_offset.head<2>()) || !std::isfinite(scan->sensor_offset.z()))
        refuse_to_write(path, fmt::format("range scan at event {} has no ranges or values a log cannot hold", i));
    } else {
      refuse_to_write(path, fmt::format("event {} holds landmark observations; expected laser scans only", i));
    }
  }
  if (std::none_of(dataset.events.begin(), dataset.events.end(),
                   [](const Event& e) { return std::holds_alternative<RangeScanEvent>(e); }))
    refuse_to_write(path, "no range scans; a log without laser lines cannot be read");
  const std::vector<StampedPose>& truth = dataset.truth.poses;
  for (std::size_t i = 0; i < truth.size(); ++i)
    if (!std::isfinite(truth[i].t) || !within_coordinates(truth[i].pose.head<2>()) ||
        !std::isfinite(truth[i].pose.z()) || (i > 0 && truth[i].t < truth[i - 1].t))
      refuse_to_write(path, fmt::format("truth pose {} is not finite or earlier than the one before", i));
}

// A time in the source's clock: the dataset's plus its origin, whole seconds apart from the fraction
// so that a Unix time keeps every digit.
void write_carmen_time(LineWriter& out, double t, const Dataset& dataset) {
  if (dataset.time_origin_s == 0 && dataset.time_origin_fraction_s == 0.0) {
    out.fixed(t, 9);
    return;
  }
  double whole = std::floor(t + dataset.time_origin_fraction_s);
  long long nanoseconds = std::llround((t + dataset.time_origin_fraction_s - whole) * 1e9);
  if (nanoseconds == 1'000'000'000) {
    whole += 1.0;
    nanoseconds = 0;
  }
  const long long seconds = dataset.time_origin_s + static_cast<long long>(whole);
  if (seconds < 0) {  // no log of a negative Unix time is known; the double will do
    out.fixed(static_cast<double>(dataset.time_origin_s) + dataset.time_origin_fraction_s + t, 9);
    return;
  }
  out.integer(seconds).text(fmt::format(".{:09}", nanoseconds));
}

void write_carmen_pose(LineWriter& out, const Pose2& p) {
  out.fixed(p.x(), 9).text(" ").fixed(p.y(), 9).text(" ").fixed(p.z(), 9);
}

void write_odom_line(LineWriter& out, const Pose2& pose, double t, const Dataset& dataset) {
  out.text("ODOM ");
  write_carmen_pose(out, pose);
  out.text(" 0 0 0 ");
  write_carmen_time(out, t, dataset);
  out.text(" slamkit ");
  write_carmen_time(out, t, dataset);
  out.end_line();
}

void write_robotlaser_line(LineWriter& out, const RangeScanEvent& scan, const Pose2& robot, const Dataset& dataset) {
  const std::size_t n = scan.ranges.size();
  // Type 0 (a SICK LMS), accuracy and remission mode 0: the scan does not say.
  out.text("ROBOTLASER1 0 ").fixed(scan.angle_min, 12).text(" ");
  out.fixed(scan.angle_increment * static_cast<double>(n - 1), 12).text(" ").fixed(scan.angle_increment, 12);
  // Nine significant digits give back the very float.
  out.text(" ").general(scan.max_range, 9).text(" 0 0 ").integer(static_cast<long long>(n));
  for (const float r : scan.ranges) out.text(" ").general(r, 9);
  out.text(" 0 ");
  const double c = std::cos(robot.z()), s = std::sin(robot.z());
  const Pose2& o = scan.sensor_offset;
  write_carmen_pose(out, Pose2(robot.x() + c * o.x() - s * o.y(), robot.y() + s * o.x() + c * o.y(),
                        wrap_angle(robot.z() + o.z())));
  out.text(" ");
  write_carmen_pose(out, robot);
  out.text(" 0 0 0 0 0 ");
  write_carmen_time(out, scan.t, dataset);
  out.text(" slamkit ");
  write_carmen_time(out, scan.t, dataset);
  out.end_line();
}

void write_carmen_header(LineWriter& out, const Dataset& dataset, std::string_view what) {
  out.text(fmt::format("# {} of {}, written by slamkit {}", what, dataset.name, version()));
  out.end_line();
  out.text("# message formats defined: PARAM ODOM ROBOTLASER1");
  out.end_line();
  out.text("PARAM logger_writer slamkit 0 slamkit 0");
  out.end_line();
}

}  // namespace

// ---- Public ---------------------------------------------------------------------------------------------

CarmenOptions carmen_options_from_json(const nlohmann::json& settings, const std::string& source) {
  return options_from_json<CarmenOptions>(settings, source, "the CARMEN options", CarmenOptions{}, kCarmenOptionKeys);
}

nlohmann::json to_json(const CarmenOptions& options) {
  return options_to_json<CarmenOptions>(options, kCarmenOptionKeys);
}

OdometryModel::Params odometry_params(const MadeOdometry& noise) {
  OdometryModel::Params p;
  p.alpha_rot_rot = carmen_squared(noise.rotation_per_rad);
  p.alpha_rot_trans = carmen_squared(noise.rotation_per_m);
  p.alpha_trans_trans = carmen_squared(noise.translation_per_m);
  p.alpha_trans_rot = carmen_squared(noise.translation_per_rad);
  const double floor = carmen_squared(std::max(noise.rotation_constant, noise.translation_constant));
  if (floor > 0.0) p.min_variance = floor;
  return p;
}

std::vector<Pose2> make_odometry(const std::vector<Pose2>& reference, const MadeOdometry& noise) {
  std::vector<Pose2> odometry;
  if (reference.empty()) return odometry;
  odometry.reserve(reference.size());
  odometry.push_back(reference.front());
  PortableGaussian normal(noise.seed);
  const OdometryModel model;
  for (std::size_t k = 1; k < reference.size(); ++k) {
    const Control u = OdometryModel::between(reference[k - 1], reference[k]);
    const double rot1 = u[0], trans = u[1], rot2 = u[2];
    const auto rotation_sd = [&](double rot) {
      return std::sqrt(carmen_squared(noise.rotation_per_rad * rot) + carmen_squared(noise.rotation_per_m * trans) +
                       carmen_squared(noise.rotation_constant));
    };
    const double trans_sd = std::sqrt(carmen_squared(noise.translation_per_m * trans) +
                                      carmen_squared(noise.translation_per_rad) * (rot1 * rot1 + rot2 * rot2) +
                                      carmen_squared(noise.translation_constant));
    Control noisy(3);
    // One draw per statement, so the order is fixed.
    noisy[0] = rot1 + rotation_sd(rot1) * normal();
    noisy[1] = trans + trans_sd * normal();
    noisy[2] = rot2 + rotation_sd(rot2) * normal();
    odometry.push_back(model.predict(odometry.back(), noisy, 0.0));
  }
  return odometry;
}

Dataset read_carmen(const std::string& path, const CarmenOptions& options, CarmenStats* stats_out) {
  validate_options<CarmenOptions>(options, "CARMEN options", kCarmenOptionKeys);
  CarmenStats stats;
  CarmenLog log = read_carmen_file(path, options.max_range);
  std::vector<LaserLine>& lines = log.laser();
  stats.laser_lines = lines.size();
  stats.odom_lines = log.odom.size();
  stats.skipped_lines = log.skipped_lines();
  if (lines.empty())
    throw InputError(path, 0,
                     fmt::format("no laser lines (of {} ODOM and {} other lines); expected a CARMEN log with FLASER "
                                 "or ROBOTLASER1 lines",
                                 stats.odom_lines, stats.skipped_lines));

  const CarmenClock clock = choose_clock(lines);
  stats.times_from_scan_order = clock.numbered;
  std::vector<CarmenTime> times;
  for (const LaserLine& l : lines) times.push_back(l.time);
  const std::vector<std::optional<double>> t = clock_times(times, clock, stats.out_of_order);
  std::vector<StampedPose> robot;
  std::vector<RangeScanEvent> scans;
  for (std::size_t k = 0; k < lines.size(); ++k) {
    if (!t[k]) continue;
    robot.push_back(StampedPose{*t[k], lines[k].robot});
    scans.push_back(std::move(lines[k].scan));
    scans.back().t = *t[k];
    for (const float r : scans.back().ranges) stats.no_returns += r >= scans.back().max_range;
  }
  stats.scans = scans.size();

  Dataset dataset;
  dataset.spec = "carmen:" + path;
  dataset.name = "carmen:" + log_stem(path);
  dataset.motion = std::make_shared<const OdometryModel>(options.motion);
  const RangeScanEvent& first = scans.front();
  const double span = std::abs(first.angle_increment) * static_cast<double>(first.ranges.size());
  dataset.sensor = SensorLimits{first.max_range, span > 0.0 ? std::min(span, 2.0 * kPi) : 2.0 * kPi};
  dataset.time_origin_s = clock.origin.seconds;
  dataset.time_origin_fraction_s = clock.origin.fraction;

  std::vector<Pose2> odometry;
  for (const StampedPose& p : robot) odometry.push_back(p.pose);
  GroundTruth& truth = dataset.truth;
  truth.poses_have_heading = true;
  if (options.poses_are_reference) {
    odometry = make_odometry(odometry, options.made_odometry);
    truth.poses = robot;
  } else {
    for (const fs::path& ref : {reference_path(path), fs::path(reference_path(path).string() + ".gz")})
      if (fs::exists(ref)) {
        truth.poses = read_reference(ref.string(), clock, lines.size(), options.max_range);
        stats.reference_path = ref.string();
        break;
      }
  }
  stats.truth_poses = truth.poses.size();
  dataset.initial_pose = odometry.front();

  dataset.events.reserve(2 * scans.size());
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const double dt = k == 0 ? 0.0 : scans[k].t - scans[k - 1].t;
    const Pose2& from = k == 0 ? dataset.initial_pose : odometry[k - 1];
    dataset.events.emplace_back(ControlEvent{scans[k].t, dt, OdometryModel::between(from, odometry[k])});
    dataset.events.emplace_back(std::move(scans[k]));
  }
  if (stats_out != nullptr) *stats_out = std::move(stats);
  return dataset;
}

void write_carmen(const std::string& path, const Dataset& dataset) {
  check_writable(path, dataset);
  const OdometryModel model;
  {
    LineWriter out(path);
    write_carmen_header(out, dataset, "CARMEN log");
    Pose2 pose = dataset.initial_pose;
    for (const Event& event : dataset.events) {
      if (const auto* control = std::get_if<ControlEvent>(&event)) {
        pose = model.predict(pose, control->u, control->dt);
        write_odom_line(out, pose, control->t, dataset);
      } else {
        write_robotlaser_line(out, std::get<RangeScanEvent>(event), pose, dataset);
      }
    }
    out.finish();
  }
  const fs::path reference = reference_path(path);
  std::error_code ignored;
  fs::remove(reference.string() + ".gz", ignored);
  if (dataset.truth.poses.empty()) {
    fs::remove(reference, ignored);
    return;
  }
  LineWriter out(reference.string());
  write_carmen_header(out, dataset, "Reference poses at the scans");
  for (const Event& event : dataset.events) {
    Pose2 pose;
    if (const auto* scan = std::get_if<RangeScanEvent>(&event); scan && pose_at(dataset.truth.poses, scan->t, pose))
      write_odom_line(out, pose, scan->t, dataset);
  }
  out.finish();
}

}  // namespace slamkit
