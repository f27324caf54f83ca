#include "slamkit/io/course_log.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>
#include <unordered_map>
#include <variant>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/text_reader.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

constexpr const char* kSensorFile = "sensor_data.dat";
constexpr const char* kCourseWorldFile = "world.dat";

// ---- Options ----------------------------------------------------------------------------------------

using namespace option_ranges;
using CourseReal = RealOption<CourseOptions>;

const OptionKey<CourseOptions> kCourseOptionKeys[] = {
    {"alpha_rot_rot", CourseReal{[](CourseOptions& o) -> double& { return o.motion.alpha_rot_rot; }, kNonNegative}},
    {"alpha_rot_trans", CourseReal{[](CourseOptions& o) -> double& { return o.motion.alpha_rot_trans; }, kNonNegative}},
    {"alpha_trans_trans",
     CourseReal{[](CourseOptions& o) -> double& { return o.motion.alpha_trans_trans; }, kNonNegative}},
    {"alpha_trans_rot", CourseReal{[](CourseOptions& o) -> double& { return o.motion.alpha_trans_rot; }, kNonNegative}},
    // A floor of zero would leave a robot standing still with a singular control noise.
    {"min_variance", CourseReal{[](CourseOptions& o) -> double& { return o.motion.min_variance; }, kPositive}},
    {"sigma_range_m", CourseReal{[](CourseOptions& o) -> double& { return o.measurement.sigma_range; }, kPositive}},
    {"sigma_bearing_deg",
     CourseReal{[](CourseOptions& o) -> double& { return o.measurement.sigma_bearing; }, kPositive, Unit::kDegrees}},
    {"max_range_m", CourseReal{[](CourseOptions& o) -> double& { return o.sensor.max_range; }, kPositive}},
    {"fov_deg", CourseReal{[](CourseOptions& o) -> double& { return o.sensor.fov; }, kFieldOfView, Unit::kDegrees}},
    {"step_period_s", CourseReal{[](CourseOptions& o) -> double& { return o.step_period; }, kPositive}},
};

void validate(const CourseOptions& options, const std::string& source) {
  validate_options<CourseOptions>(options, source, kCourseOptionKeys);
}

// ---- Files ------------------------------------------------------------------------------------------

int landmark_id(const TextReader& in, std::size_t field) {
  const long id = in.integer(field, "the landmark id");
  if (id < 1 || id > INT_MAX) in.fail(fmt::format("expected a landmark id from 1 to {}, found {}", INT_MAX, id));
  return static_cast<int>(id);
}

std::vector<Event> read_sensor_data(const fs::path& file, double step_period) {
  if (!fs::exists(file)) throw InputError(file.string(), 0, "missing file");
  TextReader in(file.string());
  std::vector<Event> events;
  long steps = 0;
  double t = 0.0;          // the end of the current step
  bool scan_open = false;  // whether the current step's scan has been started
  while (in.next()) {
    const std::string_view keyword = in.field(0);
    if (keyword == "ODOMETRY") {
      in.expect_fields(4, "ODOMETRY <rot1> <trans> <rot2>");
      // Parsed before the comma initialiser: a throw from inside it trips Eigen's assertion.
      const double rot1 = in.number(1, "rot1"), trans = in.number(2, "trans"), rot2 = in.number(3, "rot2");
      Control u(3);
      u << rot1, trans, rot2;
      ++steps;
      // Multiplied, not summed step by step, so that the times do not accumulate rounding errors.
      t = static_cast<double>(steps) * step_period;
      events.emplace_back(ControlEvent{t, step_period, u});
      scan_open = false;
    } else if (keyword == "SENSOR") {
      in.expect_fields(4, "SENSOR <id> <range> <bearing>");
      if (steps == 0) in.fail("SENSOR line before any ODOMETRY line; expected each step to start with ODOMETRY");
      const int id = landmark_id(in, 1);
      const double range = in.number(2, "the range");
      if (range <= 0.0) in.fail(fmt::format("expected a range > 0, found {}", range));
      const Observation o{Vector2(range, wrap_angle(in.number(3, "the bearing"))), id};
      if (!scan_open) events.emplace_back(ScanEvent{t, {}});
      scan_open = true;
      std::get<ScanEvent>(events.back()).observations.push_back(o);
    } else {
      in.fail(fmt::format("unknown keyword '{}'; expected ODOMETRY or SENSOR", keyword));
    }
  }
  if (steps == 0) throw InputError(file.string(), 0, "no ODOMETRY lines; expected at least one step");
  if (std::none_of(events.begin(), events.end(), [](const Event& e) { return std::holds_alternative<ScanEvent>(e); }))
    throw InputError(file.string(), 0,
                     "no SENSOR lines; expected observations, without which a run is dead reckoning");
  return events;
}

std::vector<Landmark> read_world(const fs::path& file) {
  TextReader in(file.string());
  std::vector<Landmark> landmarks;
  std::unordered_map<int, std::size_t> line_of_id;
  while (in.next()) {
    in.expect_fields(3, "<id> <x> <y>");
    const int id = landmark_id(in, 0);
    if (const auto [it, fresh] = line_of_id.emplace(id, in.line_number()); !fresh)
      in.fail(fmt::format("duplicate landmark id {} (first on line {})", id, it->second));
    landmarks.push_back(Landmark{id, Vector2(in.coordinate(1, "x"), in.coordinate(2, "y")), Matrix2::Zero()});
  }
  if (landmarks.empty()) throw InputError(in.path(), 0, "no landmarks; expected <id> <x> <y> lines (or no file)");
  return landmarks;
}

std::string label(const fs::path& path) {
  const fs::path name = path.filename().empty() ? path.parent_path().filename() : path.filename();
  return name.empty() ? path.string() : name.string();
}

}  // namespace

CourseOptions course_options_from_json(const nlohmann::json& json, const std::string& source) {
  return options_from_json<CourseOptions>(json, source, "the course log options", CourseOptions{}, kCourseOptionKeys);
}

nlohmann::json to_json(const CourseOptions& options) { return options_to_json<CourseOptions>(options, kCourseOptionKeys); }

Dataset read_course_log(const std::string& path, const CourseOptions& options) {
  validate(options, "course log options");
  const fs::path given(path);
  const bool is_dir = fs::is_directory(given);
  const fs::path sensor_file = is_dir ? given / kSensorFile : given;
  const fs::path world_file = sensor_file.parent_path() / kCourseWorldFile;

  Dataset dataset;
  dataset.spec = "course:" + path;
  dataset.name = "course:" + label(is_dir ? given : sensor_file);
  dataset.motion = std::make_shared<const OdometryModel>(options.motion);
  dataset.observation = std::make_shared<const RangeBearingModel>(options.measurement);
  dataset.sensor = options.sensor;
  dataset.initial_pose = Pose2::Zero();
  dataset.events = read_sensor_data(sensor_file, options.step_period);
  if (fs::exists(world_file)) dataset.truth.landmarks = read_world(world_file);
  // The log's ids are the landmarks' identities, numbered as in world.dat: recorded as the truth,
  // they let the evaluation pair a map built without them with the true one.
  dataset.truth.observation_ids = observation_ids(dataset.events);
  return dataset;
}

}  // namespace slamkit
