#include "slamkit/io/victoria_park.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/text_reader.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

constexpr const char* kAsciiFolder = "acfr_ascii";
constexpr const char* kDrFile = "DRS.txt";
constexpr const char* kGpsFile = "GPS.txt";
constexpr const char* kLaserFile = "LASER.txt.gz";
constexpr std::size_t kBeams = 361;
// Readings of 75 m and more are not returns: ACFR's own code ignores them, and 81.91 m (the largest
// 13-bit value in cm) is what the log holds for no return at all.
constexpr double kLaserMaxRange = 75.0;

// ---- Options ------------------------------------------------------------------------------------

using namespace option_ranges;
using Key = OptionKey<VictoriaParkOptions>;
using VictoriaParkReal = RealOption<VictoriaParkOptions>;

const Key kCarKeys[] = {
    {"wheelbase_m", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.car.wheelbase; }, kPositive}},
    {"encoder_offset_m", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.car.encoder_offset; }, kNonNegative}},
    {"laser_forward_m", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.car.laser_forward; }, kFinite}},
    {"laser_left_m", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.car.laser_left; }, kFinite}},
};

const Key kDetectorKeys[] = {
    {"max_beam_range_m",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.detector.max_beam_range; }, kPositive}},
    {"segment_range_jump_m",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.detector.segment_range_jump; }, kPositive}},
    {"segment_angle_gap_deg",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.detector.segment_angle_gap; }, kPositive,
          Unit::kDegrees}},
    {"clutter_distance_m",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.detector.clutter_distance; }, kNonNegative}},
    {"clutter_lookahead", IntegerOption<VictoriaParkOptions, int>{
                              [](VictoriaParkOptions& o) -> int& { return o.detector.clutter_lookahead; }}},
    {"occlusion_angle_deg",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.detector.occlusion_angle; }, kNonNegative,
          Unit::kDegrees}},
    {"max_extent_m", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.detector.max_extent; }, kPositive}},
    {"min_range_m", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.detector.min_range; }, kNonNegative}},
    {"edge_margin_deg",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.detector.edge_margin; }, kNonNegative, Unit::kDegrees}},
    {"max_depth_ratio",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.detector.max_depth_ratio; }, kPositive}},
};

const Key kVictoriaParkOptionKeys[] = {
    {"max_range_m", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.max_range; }, kPositive}},
    {"sigma_speed_mps", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.car.sigma_speed; }, kNonNegative}},
    {"sigma_steer_deg",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.car.sigma_steer; }, kNonNegative, Unit::kDegrees}},
    {"sigma_range_m", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.sigma_range; }, kNonNegative}},
    {"sigma_bearing_deg",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.sigma_bearing; }, kNonNegative, Unit::kDegrees}},
    {"initial_heading_deg",
     VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.initial_heading; }, kFinite, Unit::kDegrees}},
    {"start_time_s", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.start_time; }, kNonNegative}},
    {"end_time_s", VictoriaParkReal{[](VictoriaParkOptions& o) -> double& { return o.end_time; }, kNonNegativeOrInfinite}},
    {"car", section(kCarKeys)},
    {"tree_detector", section(kDetectorKeys)},
};

void check_time_window(const VictoriaParkOptions& options, const std::string& source) {
  if (options.end_time < options.start_time)
    throw InputError(source, 0,
                     fmt::format("'end_time_s' ({}) must not be before 'start_time_s' ({})", options.end_time,
                                 options.start_time));
}

void validate(const VictoriaParkOptions& options, const std::string& source) {
  validate_options<VictoriaParkOptions>(options, source, kVictoriaParkOptionKeys);
  check_time_window(options, source);
}

// ---- Files --------------------------------------------------------------------------------------

// The acfr_ascii folder, given it or the victoria_park folder above it.
fs::path ascii_folder(const std::string& dir) {
  const fs::path given(dir);
  if (fs::is_directory(given / kAsciiFolder)) return given / kAsciiFolder;
  if (fs::exists(given / kDrFile)) return given;
  if (!fs::is_directory(given))
    throw InputError(dir, 0, "no such folder; expected the Victoria Park dataset folder");
  throw InputError(dir, 0,
                   fmt::format("expected the Victoria Park folder (holding {}/) or the {} folder itself "
                               "(holding {}, {} and {})",
                               kAsciiFolder, kAsciiFolder, kDrFile, kGpsFile, kLaserFile));
}

std::string required_file(const fs::path& folder, const char* name) {
  const fs::path path = folder / name;
  if (!fs::exists(path)) throw InputError(path.string(), 0, "missing file (part of ACFR's ASCII release)");
  return path.string();
}

// Each file's times must increase line by line: the events are merged on them.
template <typename Reader>
void expect_later(const Reader& in, double t, double previous, bool first) {
  if (!first && !(t > previous))
    in.fail(fmt::format("expected the time to increase, found {} after {}", t, previous));
}

struct DrRow {
  double t;
  double speed;
  double steer;
};

std::vector<DrRow> read_dr(const std::string& path) {
  TextReader in(path);
  std::vector<DrRow> rows;
  while (in.next()) {
    in.expect_fields(3, "time_s speed_m/s steering_rad");
    const DrRow row{in.number(0, "the time"), in.number(1, "the speed"), in.number(2, "the steering angle")};
    expect_later(in, row.t, rows.empty() ? 0.0 : rows.back().t, rows.empty());
    rows.push_back(row);
  }
  if (rows.empty()) throw InputError(path, 0, "no dead-reckoning rows; expected lines of time_s speed_m/s steering_rad");
  return rows;
}

std::vector<StampedPose> read_gps(const std::string& path) {
  TextReader in(path);
  std::vector<StampedPose> fixes;
  while (in.next()) {
    in.expect_fields(3, "time_s north_m east_m");
    const double t = in.number(0, "the time");
    const double north = in.coordinate(1, "the north coordinate");
    const double east = in.coordinate(2, "the east coordinate");
    expect_later(in, t, fixes.empty() ? 0.0 : fixes.back().t, fixes.empty());
    fixes.push_back({t, Pose2(east, north, 0.0)});
  }
  if (fixes.empty()) throw InputError(path, 0, "no GPS fixes; expected lines of time_s north_m east_m");
  return fixes;
}

/// One line of the laser log, as the two kinds of scan the filters map with.
struct LaserScan {
  ScanEvent trees;        // the trees the detector finds, for the landmark filters
  RangeScanEvent ranges;  // the raw ranges, for the grid filters
};

std::vector<LaserScan> read_laser(const std::string& path, const VictoriaParkOptions& options) {
  const TreeDetector detector(options.detector);
  TextReader in(path);
  std::vector<LaserScan> scans;
  std::vector<double> ranges(kBeams);
  while (in.next()) {
    in.expect_fields(kBeams + 1, "time_s and 361 ranges");
    const double t = in.number(0, "the time");
    expect_later(in, t, scans.empty() ? 0.0 : scans.back().trees.t, scans.empty());
    for (std::size_t k = 0; k < kBeams; ++k) {
      ranges[k] = in.number(k + 1, "a range");
      if (ranges[k] < 0.0)
        in.fail(fmt::format("expected a range >= 0 m, found {} (beam {})", ranges[k], k + 1));
    }
    LaserScan scan;
    scan.trees.t = t;
    for (const Tree& tree : detector.detect(ranges))
      if (tree.range <= options.max_range)
        scan.trees.observations.push_back({Vector2(tree.range, tree.bearing), kUnknownId});
    // The state is the laser's pose, so the scan has no offset; beam 0 points to the car's right.
    scan.ranges.t = t;
    scan.ranges.angle_min = -kPi / 2.0;
    scan.ranges.angle_increment = deg2rad(0.5);
    scan.ranges.max_range = kLaserMaxRange;
    scan.ranges.ranges.assign(ranges.begin(), ranges.end());
    scans.push_back(std::move(scan));
  }
  if (scans.empty()) throw InputError(path, 0, "no laser scans; expected one line per scan: time_s and 361 ranges");
  return scans;
}

bool in_window(double t, const VictoriaParkOptions& o) { return t >= o.start_time && t <= o.end_time; }

// Merges dead reckoning and scans in time order; see the header for how controls are cut at scans.
std::vector<Event> merge(const std::vector<DrRow>& dr, std::vector<LaserScan>& scans,
                         const VictoriaParkOptions& o) {
  std::vector<Event> events;
  events.reserve(dr.size() + 3 * scans.size());
  double previous = o.start_time;
  std::size_t next_scan = 0;
  const auto control = [&](double t, const DrRow& row) {
    Control u(2);
    u << row.speed, row.steer;
    events.emplace_back(ControlEvent{t, t - previous, u});
    previous = t;
  };
  const auto emit_scan = [&] {
    LaserScan& scan = scans[next_scan++];
    if (!in_window(scan.trees.t, o)) return;
    events.emplace_back(std::move(scan.trees));
    events.emplace_back(std::move(scan.ranges));
  };
  for (const DrRow& row : dr) {
    if (!in_window(row.t, o)) continue;
    // A scan stamped with the same time as a row comes after the row's control.
    while (next_scan < scans.size() && scans[next_scan].trees.t < row.t) {
      if (scans[next_scan].trees.t > previous) control(scans[next_scan].trees.t, row);
      emit_scan();
    }
    control(row.t, row);
  }
  while (next_scan < scans.size()) emit_scan();
  return events;
}

}  // namespace

VictoriaParkOptions victoria_park_options_from_json(const nlohmann::json& json, const std::string& source) {
  const VictoriaParkOptions options =
      options_from_json<VictoriaParkOptions>(json, source, "the Victoria Park options", {}, kVictoriaParkOptionKeys);
  check_time_window(options, source);
  return options;
}

Dataset read_victoria_park(const std::string& dir, const VictoriaParkOptions& options) {
  validate(options, "Victoria Park options");
  const fs::path folder = ascii_folder(dir);
  const std::vector<DrRow> dr = read_dr(required_file(folder, kDrFile));
  std::vector<StampedPose> gps = read_gps(required_file(folder, kGpsFile));
  const std::string laser_path = required_file(folder, kLaserFile);
  std::vector<LaserScan> scans = read_laser(laser_path, options);
  const std::size_t scans_read = scans.size();

  Dataset data;
  data.spec = "victoria-park:" + dir;
  data.name = "Victoria Park";
  data.events = merge(dr, scans, options);
  // Without a single tree the run would be dead reckoning, reported as if it were SLAM.
  const bool observed = std::any_of(data.events.begin(), data.events.end(), [](const Event& e) {
    const auto* scan = std::get_if<ScanEvent>(&e);
    return scan != nullptr && !scan->observations.empty();
  });
  if (!observed)
    throw InputError(laser_path, 0,
                     fmt::format("no tree within max_range_m ({} m) in any of its {} scans between start_time_s ({} "
                                 "s) and end_time_s ({} s); expected observations, without which a run is dead "
                                 "reckoning",
                                 options.max_range, scans_read, options.start_time, options.end_time));
  data.motion = std::make_shared<const AcfrCarModel>(options.car);
  RangeBearingModel::Params sensor;
  sensor.sigma_range = options.sigma_range;
  sensor.sigma_bearing = options.sigma_bearing;
  data.observation = std::make_shared<const RangeBearingModel>(sensor);
  data.sensor = SensorLimits{options.max_range, kPi};
  data.initial_pose = Pose2(0.0, 0.0, wrap_angle(options.initial_heading));
  std::erase_if(gps, [&](const StampedPose& p) { return !in_window(p.t, options); });
  data.truth.poses = std::move(gps);
  data.truth.poses_have_heading = false;
  return data;
}

Dataset read_victoria_park(const std::string& dir) { return read_victoria_park(dir, VictoriaParkOptions{}); }

}  // namespace slamkit
