#include "slamkit/io/mrclam.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/pose_at.hpp"
#include "slamkit/core/text_reader.hpp"
#include "reader_common.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

// Subjects 1 to kRobots are the robots; the landmarks are numbered after them.
constexpr int kRobots = 5;

// ---- Options ----------------------------------------------------------------------------------------

using namespace option_ranges;
using MrclamReal = RealOption<MrclamOptions>;

// A robot that takes seconds to act on a command is not following its log; the bound also keeps the
// shifted times far inside the range the time checks allow.
constexpr RealRange kCommandDelay{[](double v) { return v >= 0.0 && v <= 10.0; }, ">= 0 and <= 10 (s)"};

const OptionKey<MrclamOptions> kMrclamOptionKeys[] = {
    {"q_v_m2_per_s", MrclamReal{[](MrclamOptions& o) -> double& { return o.motion.q_v; }, kNonNegative}},
    {"q_omega_rad2_per_s", MrclamReal{[](MrclamOptions& o) -> double& { return o.motion.q_omega; }, kNonNegative}},
    {"sigma_range_m", MrclamReal{[](MrclamOptions& o) -> double& { return o.measurement.sigma_range; }, kPositive}},
    {"sigma_bearing_deg",
     MrclamReal{[](MrclamOptions& o) -> double& { return o.measurement.sigma_bearing; }, kPositive, Unit::kDegrees}},
    {"sensor_offset_x_m", MrclamReal{[](MrclamOptions& o) -> double& { return o.measurement.offset_x; }, kFinite}},
    {"sensor_offset_y_m", MrclamReal{[](MrclamOptions& o) -> double& { return o.measurement.offset_y; }, kFinite}},
    {"max_range_m", MrclamReal{[](MrclamOptions& o) -> double& { return o.sensor.max_range; }, kPositive}},
    {"fov_deg", MrclamReal{[](MrclamOptions& o) -> double& { return o.sensor.fov; }, kFieldOfView, Unit::kDegrees}},
    {"scan_window_s", MrclamReal{[](MrclamOptions& o) -> double& { return o.scan_window; }, kNonNegative}},
    {"command_delay_s", MrclamReal{[](MrclamOptions& o) -> double& { return o.command_delay; }, kCommandDelay}},
};

void validate(const MrclamOptions& options, const std::string& source) {
  validate_options<MrclamOptions>(options, source, kMrclamOptionKeys);
}

// ---- Times ------------------------------------------------------------------------------------------

// A Unix time near 1.2e9 s parsed into one double keeps only 0.1 us of resolution, and the difference
// of two such times is off by as much; with the whole seconds apart, the difference is exact to the
// last digit the file gives.
struct UnixTime {
  long seconds = 0;
  double fraction = 0.0;  // same sign as the time

  double minus(const UnixTime& origin) const {
    return static_cast<double>(seconds - origin.seconds) + (fraction - origin.fraction);
  }
};

bool parse_time(std::string_view s, UnixTime& out) {
  const std::size_t dot = s.find('.');
  if (dot == std::string_view::npos || dot == 0 || s.find_first_of("eE") != std::string_view::npos) {
    out.seconds = 0;  // no fraction to split off: any number will do
    return parse_double(s, out.fraction);
  }
  // Appended rather than concatenated with operator+, over which gcc 12 warns falsely (-Wrestrict).
  std::string fraction = "0";
  fraction += s.substr(dot);
  if (!parse_long(s.substr(0, dot), out.seconds) || !parse_double(fraction, out.fraction)) return false;
  if (s.front() == '-') out.fraction = -out.fraction;
  return true;
}

// Times are Unix times (about 1.25e9 s for these logs). A bound far beyond any log's clock keeps the
// difference of two times, whole seconds and fractions alike, inside a long and exact in a double.
UnixTime read_time(const TextReader& in, std::size_t i) {
  UnixTime t;
  if (!parse_time(in.field(i), t))
    in.fail(fmt::format("expected a finite number for the time, found '{}'", in.field(i)));
  if (std::abs(static_cast<double>(t.seconds) + t.fraction) > io_detail::kMaxAbsTime)
    in.fail(fmt::format("expected a Unix time in seconds within +-{:g}, found '{}'", io_detail::kMaxAbsTime, in.field(i)));
  return t;
}

// ---- The files ----------------------------------------------------------------------------------------

// `name` in `dir`, else its gzip-compressed form; an empty path if neither exists. One that is not
// a regular file is returned too, for the reader to refuse by what it is.
fs::path find_file(const fs::path& dir, const std::string& name) {
  for (const fs::path& candidate : {dir / name, dir / (name + ".gz")})
    if (fs::exists(candidate)) return candidate;
  return {};
}

fs::path require_file(const fs::path& dir, const std::string& name) {
  const fs::path file = find_file(dir, name);
  if (file.empty())
    throw InputError((dir / name).string(), 0, fmt::format("missing file (nor is there a {}.gz)", name));
  return file;
}

// Times must not go backwards: scans are grouped and controls are cut in file order.
class MrclamTimeOrder {
 public:
  double check(const TextReader& in, double t) {
    if (t < last_)
      in.fail(fmt::format("time {:.3f} s is earlier than the {:.3f} s of the line before (relative to t0); "
                          "expected times never to decrease",
                          t, last_));
    last_ = t;
    return t;
  }

 private:
  double last_ = -std::numeric_limits<double>::infinity();
};

std::unordered_map<long, int> read_barcodes(const fs::path& file) {
  TextReader in(file.string());
  std::unordered_map<long, int> subject_of;
  std::unordered_map<long, std::size_t> line_of_subject;
  while (in.next()) {
    in.expect_fields(2, "<subject> <barcode>");
    const long subject = in.integer(0, "the subject number");
    if (subject < 1 || subject > INT_MAX)
      in.fail(fmt::format("expected a subject number from 1 to {}, found {}", INT_MAX, subject));
    const long barcode = in.integer(1, "the barcode");
    if (const auto [it, fresh] = line_of_subject.emplace(subject, in.line_number()); !fresh)
      in.fail(fmt::format("duplicate subject {} (first on line {})", subject, it->second));
    if (!subject_of.emplace(barcode, static_cast<int>(subject)).second)
      in.fail(fmt::format("barcode {} is given to two subjects", barcode));
  }
  if (subject_of.empty()) throw InputError(in.path(), 0, "no barcodes; expected <subject> <barcode> lines");
  return subject_of;
}

std::vector<Landmark> read_landmarks(const fs::path& file) {
  TextReader in(file.string());
  std::vector<Landmark> landmarks;
  std::unordered_map<long, std::size_t> line_of_subject;
  while (in.next()) {
    in.expect_fields(5, "<subject> <x> <y> <std_x> <std_y>");
    const long subject = in.integer(0, "the subject number");
    if (subject <= kRobots || subject > INT_MAX)
      in.fail(fmt::format("expected a landmark subject number from {} to {}, found {}", kRobots + 1, INT_MAX,
                          subject));
    if (const auto [it, fresh] = line_of_subject.emplace(subject, in.line_number()); !fresh)
      in.fail(fmt::format("duplicate landmark {} (first on line {})", subject, it->second));
    // The stated standard deviations (a fraction of a millimetre) are checked but not kept: slamkit's
    // truth landmarks carry zero covariance.
    for (std::size_t i = 3; i < 5; ++i)
      if (in.number(i, "a standard deviation") < 0.0) in.fail("expected standard deviations >= 0");
    landmarks.push_back(
        Landmark{static_cast<int>(subject), Vector2(in.coordinate(1, "x"), in.coordinate(2, "y")), Matrix2::Zero()});
  }
  if (landmarks.empty())
    throw InputError(in.path(), 0, "no landmarks; expected <subject> <x> <y> <std_x> <std_y> lines (or no file)");
  return landmarks;
}

struct Command {
  double t;  // relative to the time origin
  Control u;
};

// The odometry rows, the first of which sets the time origin; each command takes effect `delay` after
// its row.
std::vector<Command> read_odometry(const fs::path& file, double delay, UnixTime& origin, MrclamStats& stats) {
  TextReader in(file.string());
  std::vector<Command> rows;
  MrclamTimeOrder order;
  while (in.next()) {
    in.expect_fields(3, "<time> <v> <omega>");
    const UnixTime time = read_time(in, 0);
    if (rows.empty()) origin = time;
    // Parsed before the comma initialiser: a throw from inside it trips Eigen's assertion.
    const double v = in.number(1, "v"), omega = in.number(2, "omega");
    Control u(2);
    u << v, omega;
    rows.push_back(Command{order.check(in, time.minus(origin)) + delay, u});
  }
  stats.odometry_rows = rows.size();
  if (rows.size() < 2)
    throw InputError(in.path(), 0,
                     fmt::format("{} odometry rows; expected at least two, as a command lasts until the next",
                                 rows.size()));
  return rows;
}

// The landmark measurements within the run [0, end], grouped into scans.
std::vector<ScanEvent> read_scans(const fs::path& file, const std::unordered_map<long, int>& subject_of,
                                  const UnixTime& origin, double end, double window, MrclamStats& stats) {
  TextReader in(file.string());
  std::vector<ScanEvent> scans;
  MrclamTimeOrder order;
  while (in.next()) {
    in.expect_fields(4, "<time> <barcode> <range> <bearing>");
    ++stats.measurement_rows;
    const double t = order.check(in, read_time(in, 0).minus(origin));
    const long barcode = in.integer(1, "the barcode");
    const double range = in.number(2, "the range");
    if (range <= 0.0) in.fail(fmt::format("expected a range > 0, found {}", range));
    const double bearing = wrap_angle(in.number(3, "the bearing"));
    const auto subject = subject_of.find(barcode);
    if (subject == subject_of.end()) {
      ++stats.unknown_barcodes;
      continue;
    }
    if (subject->second <= kRobots) {
      ++stats.robot_measurements;
      continue;
    }
    if (t < 0.0 || t > end) {
      ++stats.outside_run;
      continue;
    }
    const Observation o{Vector2(range, bearing), subject->second};
    if (!scans.empty() && t - scans.back().t < window)
      scans.back().observations.push_back(o);
    else
      scans.push_back(ScanEvent{t, {o}});
  }
  if (scans.empty())
    throw InputError(in.path(), 0,
                     fmt::format("no landmark measurement within the run (of {} rows: {} of robots, {} with unknown "
                                 "barcodes, {} outside the odometry's time span); expected observations, without "
                                 "which a run is dead reckoning",
                                 stats.measurement_rows, stats.robot_measurements, stats.unknown_barcodes,
                                 stats.outside_run));
  return scans;
}

std::vector<StampedPose> read_truth_poses(const fs::path& file, const UnixTime& origin) {
  TextReader in(file.string());
  std::vector<StampedPose> poses;
  MrclamTimeOrder order;
  while (in.next()) {
    in.expect_fields(4, "<time> <x> <y> <theta>");
    const double t = order.check(in, read_time(in, 0).minus(origin));
    poses.push_back(
        StampedPose{t, Pose2(in.coordinate(1, "x"), in.coordinate(2, "y"), wrap_angle(in.number(3, "theta")))});
  }
  if (poses.empty()) throw InputError(in.path(), 0, "no poses; expected <time> <x> <y> <theta> lines (or no file)");
  return poses;
}

// The event stream: each command held until the next odometry row, cut at the scans in between.
std::vector<Event> merge(const std::vector<Command>& commands, const std::vector<ScanEvent>& scans,
                         MrclamStats& stats) {
  std::vector<Event> events;
  events.reserve(commands.size() + 2 * scans.size());
  auto scan = scans.begin();
  double now = commands.front().t;
  for (; scan != scans.end() && scan->t <= now; ++scan) events.emplace_back(*scan);
  for (std::size_t k = 0; k + 1 < commands.size(); ++k) {
    const double end = commands[k + 1].t;
    if (end == commands[k].t) {
      ++stats.superseded_odometry_rows;
      continue;
    }
    const Control& u = commands[k].u;
    for (; scan != scans.end() && scan->t <= end; ++scan) {
      if (scan->t > now) {
        events.emplace_back(ControlEvent{scan->t, scan->t - now, u});
        now = scan->t;
      }
      events.emplace_back(*scan);
    }
    if (end > now) {
      events.emplace_back(ControlEvent{end, end - now, u});
      now = end;
    }
  }
  return events;
}

}  // namespace

MrclamOptions mrclam_options_from_json(const nlohmann::json& json, const std::string& source) {
  return options_from_json<MrclamOptions>(json, source, "the MRCLAM options", MrclamOptions{}, kMrclamOptionKeys);
}

nlohmann::json to_json(const MrclamOptions& options) { return options_to_json<MrclamOptions>(options, kMrclamOptionKeys); }

Dataset read_mrclam(const std::string& dataset_dir, int robot, const MrclamOptions& options) {
  MrclamStats stats;
  return read_mrclam(dataset_dir, robot, options, stats);
}

Dataset read_mrclam(const std::string& dataset_dir, int robot, const MrclamOptions& options,
                    MrclamStats& stats) {
  const fs::path dir(dataset_dir);
  if (robot < 1 || robot > kRobots)
    throw InputError(dataset_dir, 0, fmt::format("robot number must be 1 to {}, found {}", kRobots, robot));
  if (!fs::is_directory(dir))
    throw InputError(dataset_dir, 0, "not a directory; expected an MRCLAM dataset directory");
  validate(options, "MRCLAM options");
  stats = MrclamStats{};

  const std::string prefix = fmt::format("Robot{}_", robot);
  const auto subject_of = read_barcodes(require_file(dir, "Barcodes.dat"));
  UnixTime origin;
  std::vector<Command> commands =
      read_odometry(require_file(dir, prefix + "Odometry.dat"), options.command_delay, origin, stats);
  // Until the first row takes effect the robot is taken to stand still: nothing says what it did.
  if (options.command_delay > 0.0) commands.insert(commands.begin(), Command{0.0, Control::Zero(2)});
  stats.time_origin = static_cast<double>(origin.seconds) + origin.fraction;
  const double end = commands.back().t;
  stats.duration = end;
  const std::vector<ScanEvent> scans =
      read_scans(require_file(dir, prefix + "Measurement.dat"), subject_of, origin, end, options.scan_window, stats);
  for (const ScanEvent& s : scans) stats.observations += s.observations.size();
  stats.scans = scans.size();

  Dataset dataset;
  dataset.spec = fmt::format("mrclam:{}/Robot{}", dataset_dir, robot);
  dataset.name = fmt::format("mrclam:{}/Robot{}", io_detail::last_component(dataset_dir), robot);
  dataset.motion = std::make_shared<const VelocityModel>(options.motion);
  dataset.observation = std::make_shared<const RangeBearingModel>(options.measurement);
  dataset.sensor = options.sensor;
  dataset.events = merge(commands, scans, stats);
  dataset.time_origin_s = origin.seconds;
  dataset.time_origin_fraction_s = origin.fraction;

  GroundTruth& truth = dataset.truth;
  truth.poses_have_heading = true;
  if (const fs::path file = find_file(dir, "Landmark_Groundtruth.dat"); !file.empty())
    truth.landmarks = read_landmarks(file);
  if (const fs::path file = find_file(dir, prefix + "Groundtruth.dat"); !file.empty()) {
    std::vector<StampedPose> poses = read_truth_poses(file, origin);
    stats.initial_pose_from_truth = pose_at(poses, 0.0, dataset.initial_pose);
    std::erase_if(poses, [&](const StampedPose& p) { return p.t < 0.0 || p.t > end; });
    truth.poses = std::move(poses);
  }
  stats.truth_poses = truth.poses.size();
  // The barcodes identify the landmarks, numbered as in the landmark truth: recorded as the truth,
  // they let the evaluation pair a map built without them with the true one.
  truth.observation_ids = observation_ids(dataset.events);
  return dataset;
}

MrclamRobot parse_mrclam_robot_path(const std::string& path) {
  std::string trimmed = path;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  const fs::path p(trimmed);
  const std::string name = p.filename().string();
  constexpr std::string_view kPrefix = "Robot";
  int robot = 0;
  const char* digits = name.data() + std::min(name.size(), kPrefix.size());
  const auto [ptr, ec] = std::from_chars(digits, name.data() + name.size(), robot);
  if (!name.starts_with(kPrefix) || ec != std::errc() || ptr != name.data() + name.size() || robot < 1 ||
      robot > kRobots)
    throw InputError(path, 0,
                     fmt::format("expected an MRCLAM robot as DATASET_DIR/RobotN with N from 1 to {}", kRobots));
  return MrclamRobot{p.has_parent_path() ? p.parent_path().string() : ".", robot};
}

}  // namespace slamkit
