#include "slamkit/io/plaza.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <climits>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <unordered_map>
#include <utility>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/text_reader.hpp"
#include "reader_common.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

// ---- Options ----------------------------------------------------------------------------------------

using namespace option_ranges;
using PlazaReal = RealOption<PlazaOptions>;

const OptionKey<PlazaOptions> kPlazaOptionKeys[] = {
    {"alpha_rot_rot", PlazaReal{[](PlazaOptions& o) -> double& { return o.motion.alpha_rot_rot; }, kNonNegative}},
    {"alpha_rot_trans", PlazaReal{[](PlazaOptions& o) -> double& { return o.motion.alpha_rot_trans; }, kNonNegative}},
    {"alpha_trans_trans", PlazaReal{[](PlazaOptions& o) -> double& { return o.motion.alpha_trans_trans; }, kNonNegative}},
    {"alpha_trans_rot", PlazaReal{[](PlazaOptions& o) -> double& { return o.motion.alpha_trans_rot; }, kNonNegative}},
    // A floor of zero would leave the mower standing still with a singular control noise.
    {"min_variance", PlazaReal{[](PlazaOptions& o) -> double& { return o.motion.min_variance; }, kPositive}},
    {"sigma_range_m", PlazaReal{[](PlazaOptions& o) -> double& { return o.measurement.sigma_range; }, kPositive}},
    {"sensor_offset_x_m", PlazaReal{[](PlazaOptions& o) -> double& { return o.measurement.offset_x; }, kFinite}},
    {"sensor_offset_y_m", PlazaReal{[](PlazaOptions& o) -> double& { return o.measurement.offset_y; }, kFinite}},
    {"max_range_m", PlazaReal{[](PlazaOptions& o) -> double& { return o.sensor.max_range; }, kPositive}},
    {"fov_deg", PlazaReal{[](PlazaOptions& o) -> double& { return o.sensor.fov; }, kFieldOfView, Unit::kDegrees}},
};

void validate(const PlazaOptions& options, const std::string& source) {
  validate_options<PlazaOptions>(options, source, kPlazaOptionKeys);
}

// ---- Fields ---------------------------------------------------------------------------------------------

// The files give times as doubles (%.16e), so a time relative to the origin is their difference,
// which loses nothing the file has. A bound far beyond any clock keeps the origin's whole seconds
// inside a long.
double read_time(const TextReader& in) {
  const double t = in.number(0, "the time");
  if (std::abs(t) > io_detail::kMaxAbsTime)
    in.fail(fmt::format("expected a time in seconds within +-{:g}, found '{}'", io_detail::kMaxAbsTime, in.field(0)));
  return t;
}

// R_TD.txt writes its beacon ids as %.16e too ("5.0000000000000000e+000"), so any number that is a
// whole one will do.
int beacon_id(const TextReader& in, std::size_t i) {
  const double v = in.number(i, "the beacon id");
  if (v < 0.0 || v > INT_MAX || v != std::floor(v))
    in.fail(fmt::format("expected a beacon id, a whole number from 0 to {}, found '{}'", INT_MAX, in.field(i)));
  return static_cast<int>(v);
}

// ---- The files ----------------------------------------------------------------------------------------

fs::path require_file(const fs::path& dir, const std::string& name, const std::string& expected) {
  const fs::path file = dir / name;
  if (!fs::exists(file)) throw InputError(file.string(), 0, "missing file; expected " + expected);
  return file;
}

// The first row sets the time origin. The evaluation matches estimates to the truth by time, so its
// times must not decrease.
std::vector<StampedPose> read_truth_poses(const fs::path& file, double& origin) {
  TextReader in(file.string());
  std::vector<StampedPose> poses;
  double previous = -std::numeric_limits<double>::infinity();
  while (in.next()) {
    in.expect_fields(4, "<time> <x> <y> <heading>");
    const double time = read_time(in);
    if (time < previous)
      in.fail(fmt::format("time {} s is earlier than the {} s of the row before; expected times never to decrease",
                          time, previous));
    previous = time;
    if (poses.empty()) origin = time;
    poses.push_back(StampedPose{time - origin, Pose2(in.coordinate(1, "x"), in.coordinate(2, "y"),
                                                     wrap_angle(in.number(3, "the heading")))});
  }
  if (poses.empty()) throw InputError(in.path(), 0, "no poses; expected <time> <x> <y> <heading> lines");
  return poses;
}

std::vector<Landmark> read_beacons(const fs::path& file) {
  TextReader in(file.string());
  std::vector<Landmark> beacons;
  std::unordered_map<int, std::size_t> line_of_id;
  while (in.next()) {
    in.expect_fields(3, "<beacon> <x> <y>");
    const int id = beacon_id(in, 0);
    if (const auto [it, fresh] = line_of_id.emplace(id, in.line_number()); !fresh)
      in.fail(fmt::format("duplicate beacon {} (first on line {})", id, it->second));
    beacons.push_back(Landmark{id, Vector2(in.coordinate(1, "x"), in.coordinate(2, "y")), Matrix2::Zero()});
  }
  if (beacons.empty()) throw InputError(in.path(), 0, "no beacons; expected <beacon> <x> <y> lines");
  return beacons;
}

// Each row is the motion since the row before, the first row's since the first ground-truth row
// (the origin), so the times must increase from there.
std::vector<ControlEvent> read_odometry(const fs::path& file, double origin) {
  TextReader in(file.string());
  std::vector<ControlEvent> controls;
  double previous = origin;
  while (in.next()) {
    in.expect_fields(3, "<time> <distance> <heading change>");
    const double time = read_time(in);
    if (time <= previous)
      in.fail(controls.empty()
                  ? fmt::format("time {} s is not after the {} s of the first ground-truth row; expected the "
                                "odometry to start after it, as the first row is the motion from that pose",
                                time, origin)
                  : fmt::format("time {} s is not after the {} s of the row before; expected times to increase, "
                                "as each row is the motion since the row before",
                                time, previous));
    // Parsed before the comma initialiser: a throw from inside it trips Eigen's assertion.
    const double distance = in.number(1, "the distance"), turn = in.number(2, "the heading change");
    // The midpoint approximation: a row gives the distance and the net turn, not the path, so the
    // mower is taken to turn half of it, drive the distance straight and turn the rest. On an arc the
    // chord does point along the heading halfway through the turn; it is shorter than the distance
    // by a factor 1 - turn^2 / 24, under 0.1% for Plaza1's largest turn in one row (0.15 rad).
    Control u(3);
    u << turn / 2, distance, turn / 2;
    const double t = time - origin;
    controls.push_back(ControlEvent{t, controls.empty() ? t : t - controls.back().t, u});
    previous = time;
  }
  if (controls.empty())
    throw InputError(in.path(), 0, "no odometry; expected <time> <distance> <heading change> lines");
  return controls;
}

// The ranges within the run [0, end], sorted by time and grouped into one scan per time.
std::vector<ScanEvent> read_scans(const fs::path& file, const std::vector<Landmark>& beacons,
                                  const fs::path& beacon_file, double origin, double end, PlazaStats& stats) {
  struct Range {
    double t;
    int beacon;
    double range;
  };
  std::vector<int> beacon_ids;
  for (const Landmark& b : beacons) beacon_ids.push_back(b.id);

  TextReader in(file.string());
  std::vector<Range> ranges;
  double previous = -std::numeric_limits<double>::infinity();
  while (in.next()) {
    in.expect_fields(4, "<time> <sender> <beacon> <range>");
    ++stats.range_rows;
    const double time = read_time(in);
    if (time < previous) ++stats.reordered_range_rows;
    previous = time;
    in.number(1, "the sender id");  // checked, not kept: 2 on every row of Plaza1
    const int beacon = beacon_id(in, 2);
    if (std::find(beacon_ids.begin(), beacon_ids.end(), beacon) == beacon_ids.end())
      in.fail(fmt::format("beacon {} is not in {}; expected one of its beacons: {}", beacon,
                          beacon_file.filename().string(), fmt::join(beacon_ids, ", ")));
    const double range = in.number(3, "the range");
    if (range <= 0.0) in.fail(fmt::format("expected a range > 0, found {}", range));
    const double t = time - origin;
    if (t < 0.0 || t > end) {
      ++stats.outside_run;
      continue;
    }
    ranges.push_back(Range{t, beacon, range});
  }
  if (stats.range_rows == 0)
    throw InputError(in.path(), 0, "no ranges; expected <time> <sender> <beacon> <range> lines");
  if (ranges.empty())
    throw InputError(in.path(), 0,
                     fmt::format("no range within the run (all {} rows are before the first ground-truth row or after "
                                 "the last odometry row); expected observations, without which a run is dead reckoning",
                                 stats.range_rows));

  // The file need not be in time order (plaza.hpp says why that is data, not damage). Stable, so that
  // ranges stamped alike keep the file's order within their scan.
  std::stable_sort(ranges.begin(), ranges.end(), [](const Range& a, const Range& b) { return a.t < b.t; });
  std::vector<ScanEvent> scans;
  for (const Range& r : ranges) {
    const Observation o{Measurement::Constant(1, r.range), r.beacon};
    if (scans.empty() || scans.back().t != r.t)
      scans.push_back(ScanEvent{r.t, {o}});
    else
      scans.back().observations.push_back(o);
  }
  return scans;
}

// Time order; a control before a scan at its time, so that the scan is taken where the control ends.
std::vector<Event> merge(std::vector<ControlEvent> controls, std::vector<ScanEvent> scans) {
  std::vector<Event> events;
  events.reserve(controls.size() + scans.size());
  auto scan = scans.begin();
  for (ControlEvent& c : controls) {
    for (; scan != scans.end() && scan->t < c.t; ++scan) events.emplace_back(std::move(*scan));
    events.emplace_back(std::move(c));
  }
  for (; scan != scans.end(); ++scan) events.emplace_back(std::move(*scan));
  return events;
}

}  // namespace

PlazaOptions plaza_options_from_json(const nlohmann::json& json, const std::string& source) {
  return options_from_json<PlazaOptions>(json, source, "the Plaza options", PlazaOptions{}, kPlazaOptionKeys);
}

nlohmann::json to_json(const PlazaOptions& options) { return options_to_json<PlazaOptions>(options, kPlazaOptionKeys); }

std::optional<std::string> plaza_run_name(std::string_view given) {
  constexpr std::string_view kPrefix = "plaza";
  if (given.size() <= kPrefix.size() ||
      !std::equal(kPrefix.begin(), kPrefix.end(), given.begin(),
                  [](char a, char b) { return a == std::tolower(static_cast<unsigned char>(b)); }))
    return std::nullopt;
  const std::string_view digits = given.substr(kPrefix.size());
  int number = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), number);
  if (error != std::errc() || end != digits.data() + digits.size() || digits.front() == '0' || number < 1)
    return std::nullopt;
  return "Plaza" + std::string(digits);
}

Dataset read_plaza(const std::string& dir, const std::string& run, const PlazaOptions& options) {
  PlazaStats stats;
  return read_plaza(dir, run, options, stats);
}

Dataset read_plaza(const std::string& dir, const std::string& run, const PlazaOptions& options, PlazaStats& stats) {
  const std::optional<std::string> name = plaza_run_name(run);
  if (!name)
    throw InputError(dir, 0, fmt::format("no Plaza run '{}'; expected PlazaN with N a whole number from 1, e.g. {}",
                                         run, kPlazaDefaultRun));
  const fs::path folder(dir);
  if (!fs::is_directory(folder))
    throw InputError(dir, 0, fmt::format("not a directory; expected a Plaza folder holding {}_DR.txt, {}_TD.txt, "
                                         "{}_GT.txt and {}_TL.txt",
                                         *name, *name, *name, *name));
  validate(options, "Plaza options");
  stats = PlazaStats{};

  // GTSAM ships the odometry and the ranges as text, the truth only inside its .mat file.
  const std::string from_mat = fmt::format(" of {}_.mat, written out as text (docs/datasets.md)", *name);
  double origin = 0.0;
  std::vector<StampedPose> poses =
      read_truth_poses(require_file(folder, *name + "_GT.txt", "the ground-truth poses, the GT variable" + from_mat),
                       origin);
  const fs::path beacon_file =
      require_file(folder, *name + "_TL.txt", "the beacon positions, the TL variable" + from_mat);
  std::vector<Landmark> beacons = read_beacons(beacon_file);
  std::vector<ControlEvent> controls = read_odometry(
      require_file(folder, *name + "_DR.txt", "the odometry, <time> <distance> <heading change>"), origin);
  const double end = controls.back().t;
  std::vector<ScanEvent> scans =
      read_scans(require_file(folder, *name + "_TD.txt", "the ranges, <time> <sender> <beacon> <range>"), beacons,
                 beacon_file, origin, end, stats);

  stats.time_origin = origin;
  stats.duration = end;
  stats.odometry_rows = controls.size();
  stats.scans = scans.size();
  for (const ScanEvent& s : scans) stats.observations += s.observations.size();
  stats.beacons = beacons.size();

  Dataset dataset;
  dataset.spec = fmt::format("plaza:{}:{}", dir, *name);
  dataset.name = "plaza:" + *name;
  dataset.motion = std::make_shared<const OdometryModel>(options.motion);
  dataset.observation = std::make_shared<const RangeOnlyModel>(options.measurement);
  dataset.sensor = options.sensor;
  dataset.events = merge(std::move(controls), std::move(scans));
  // Whole seconds and fraction, as Dataset keeps every reader's origin; both carry the time's sign.
  dataset.time_origin_s = static_cast<long>(std::trunc(origin));
  dataset.time_origin_fraction_s = origin - std::trunc(origin);
  // The estimate starts in the truth's frame, as with the simulator and MRCLAM: the truth is used
  // for the start only.
  dataset.initial_pose = poses.front().pose;

  GroundTruth& truth = dataset.truth;
  truth.poses_have_heading = true;
  // GT written out of the .mat may carry times to six decimals (Plaza1_GT.txt does), which puts its
  // row for the last DR row up to half a microsecond after it.
  constexpr double kTruthTimeResolution = 1e-6;  // s
  std::erase_if(poses, [&](const StampedPose& p) { return p.t > end + kTruthTimeResolution; });
  truth.poses = std::move(poses);
  stats.truth_poses = truth.poses.size();
  truth.landmarks = std::move(beacons);
  // The beacon ids are the landmarks' identities, numbered as in the beacon truth: recorded as the
  // truth, they let the evaluation pair a map built without them with the true one.
  truth.observation_ids = observation_ids(dataset.events);
  return dataset;
}

}  // namespace slamkit
