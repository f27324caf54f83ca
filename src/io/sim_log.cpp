#include "slamkit/io/sim_log.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <unordered_map>
#include <variant>

#include "slamkit/core/coordinates.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/text_reader.hpp"
#include "slamkit/models/observation_model.hpp"
#include "reader_common.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

constexpr const char* kFormat = "slamkit-sim";
constexpr int kVersion = 1;
constexpr const char* kParamsFile = "params.json";
constexpr const char* kEventsFile = "events.txt";
constexpr const char* kTruthPosesFile = "truth_poses.txt";
constexpr const char* kTruthLandmarksFile = "truth_landmarks.txt";
constexpr const char* kTruthObservationsFile = "truth_observations.txt";
constexpr const char* kSimWorldFile = "world.txt";

// ---- Writing ------------------------------------------------------------------------------------------

// Numbers go out with twelve significant digits: a picometre on a 10 m range, far below any noise
// in the files, while the events of a long run stay within a few megabytes.

using Buffer = fmt::memory_buffer;

template <typename... Values>
void append(Buffer& out, fmt::format_string<Values...> format, Values&&... values) {
  fmt::format_to(std::back_inserter(out), format, std::forward<Values>(values)...);
}

void write_file(const fs::path& path, const Buffer& content) {
  write_file_atomically(path.string(), std::string_view(content.data(), content.size()));
}

// A truth file left in the directory by an earlier log would be read as the truth of this one.
void remove_stale(const fs::path& path) {
  std::error_code error;
  if (!fs::remove(path, error) && error)
    throw InputError(path.string(), 0, "cannot remove: " + error.message());
}

void write_params(const fs::path& path, const Dataset& dataset, const SimulatorConfig& config, const World& world) {
  const Pose2& p = dataset.initial_pose;
  nlohmann::json params = {{"format", kFormat},
                           {"version", kVersion},
                           {"simulator", to_json(config)},
                           {"initial_pose", {p.x(), p.y(), p.z()}}};
  if (world.origin) params["world"] = {{"family", world.origin->family}, {"world_seed", world.origin->seed}};
  Buffer out;
  append(out, "{}\n", params.dump(2));
  write_file(path, out);
}

/// The measurement columns of an obs line for the sensor of `model`: "<range> <bearing>", "<range>"
/// or "<bearing>".
std::string measurement_columns(const ObservationModel& model) {
  const MeasuredRows rows = model.rows();
  return rows.range >= 0 && rows.bearing >= 0 ? "<range> <bearing>" : rows.range >= 0 ? "<range>" : "<bearing>";
}

// events.txt and truth_observations.txt in one pass, as they share their line order.
/// `model` is the one the log's config gives its sensor (set_platform), whose columns it writes.
void write_events(const fs::path& dir, const Dataset& dataset, const ObservationModel& model) {
  const std::vector<std::vector<int>>& true_ids = dataset.truth.observation_ids;
  const bool with_truth = !true_ids.empty();
  Buffer events, truth;
  append(
      events,
      "# slamkit simulator events; units s, m, rad\n"
      "# control <t> <dt> <speed> <steer>   control applied over (t - dt, t]\n"
      "# {:<35}observation of landmark id (-1: unknown)\n"
      "# Consecutive obs lines with the same t form one scan, taken at the end of the control before it.\n",
      "obs <t> <id> " + measurement_columns(model));
  append(truth, "# slamkit true landmark id of each obs line of {}, in the same order\n# <t> <true_id>\n",
         kEventsFile);
  std::size_t scan_index = 0;
  for (const Event& event : dataset.events) {
    if (const auto* c = std::get_if<ControlEvent>(&event)) {
      if (c->u.size() != 2)
        throw std::invalid_argument("write_sim_log: expected (speed, steer) controls, as simulate() makes");
      append(events, "control {:.12g} {:.12g} {:.12g} {:.12g}\n", c->t, c->dt, c->u[0], c->u[1]);
      continue;
    }
    if (std::holds_alternative<RangeScanEvent>(event))
      throw std::invalid_argument("write_sim_log: a simulated log holds landmark scans; range scans go in a CARMEN log");
    const auto& scan = std::get<ScanEvent>(event);
    if (with_truth &&
        (scan_index >= true_ids.size() || true_ids[scan_index].size() != scan.observations.size()))
      throw std::invalid_argument(fmt::format(
          "write_sim_log: the truth's observation ids do not match scan {} of the event stream", scan_index));
    for (std::size_t i = 0; i < scan.observations.size(); ++i) {
      const Observation& o = scan.observations[i];
      if (o.z.size() != model.dim())
        throw std::invalid_argument(fmt::format("write_sim_log: a {} sensor's measurement has {} values, found {}",
                                                model.name(), model.dim(), o.z.size()));
      append(events, "obs {:.12g} {}", scan.t, o.id);
      for (Eigen::Index k = 0; k < o.z.size(); ++k) append(events, " {:.12g}", o.z[k]);
      append(events, "\n");
      if (with_truth) append(truth, "{:.12g} {}\n", scan.t, true_ids[scan_index][i]);
    }
    ++scan_index;
  }
  if (with_truth && scan_index != true_ids.size())
    throw std::invalid_argument(
        fmt::format("write_sim_log: the truth has observation ids for {} scans, the events have {}",
                    true_ids.size(), scan_index));
  write_file(dir / kEventsFile, events);
  if (with_truth)
    write_file(dir / kTruthObservationsFile, truth);
  else
    remove_stale(dir / kTruthObservationsFile);
}

void write_truth(const fs::path& dir, const GroundTruth& truth) {
  Buffer poses, landmarks;
  append(poses, "# slamkit true vehicle poses; units s, m, rad\n# <t> <x> <y> <theta>\n");
  for (const StampedPose& p : truth.poses)
    append(poses, "{:.12g} {:.12g} {:.12g} {:.12g}\n", p.t, p.pose.x(), p.pose.y(), p.pose.z());
  append(landmarks, "# slamkit true landmark positions; units m\n# <id> <x> <y>\n");
  for (const Landmark& l : truth.landmarks)
    append(landmarks, "{} {:.12g} {:.12g}\n", l.id, l.position.x(), l.position.y());
  write_file(dir / kTruthPosesFile, poses);
  write_file(dir / kTruthLandmarksFile, landmarks);
}

// ---- Reading ------------------------------------------------------------------------------------------

/// A number as the log writes it and its reader parses it.
double logged(double value) {
  char text[32];
  const auto end = fmt::format_to_n(text, sizeof(text), "{:.12g}", value).out;
  double parsed = 0.0;
  parse_double(std::string_view(text, static_cast<std::size_t>(end - text)), parsed);
  return parsed;
}

// Times are written rounded to 12 digits, so comparisons of computed times allow for that.
bool same_time(double a, double b) {
  return std::abs(a - b) <= 1e-9 * std::max({1.0, std::abs(a), std::abs(b)});
}

// A JSON value by key, or an error naming the key if it is absent.
const nlohmann::json& member(const nlohmann::json& object, const char* key, const std::string& path) {
  const auto it = object.find(key);
  if (it == object.end()) throw InputError(path, 0, fmt::format("missing key '{}'", key));
  return *it;
}

struct Params {
  SimulatorConfig config;
  Pose2 initial_pose;
};

Params read_params(const fs::path& file) {
  const std::string path = file.string();
  if (!fs::exists(file)) throw InputError(path, 0, "missing file (every simulator log has one)");
  const nlohmann::json j = read_json_file(path);
  if (!j.is_object())
    throw InputError(path, 0, fmt::format("expected a JSON object, found {}", j.type_name()));
  for (const auto& [key, value] : j.items())
    if (key != "format" && key != "version" && key != "simulator" && key != "initial_pose" && key != "world")
      throw InputError(
          path, 0,
          fmt::format("unknown key '{}'; expected format, version, simulator, initial_pose and world", key));
  // The world's origin is a record for people and scripts; reading a log needs only its shape right.
  if (const auto world = j.find("world"); world != j.end()) {
    const bool recorded = world->is_object() && world->size() == 2 && world->contains("family") &&
                          world->at("family").is_string() && world->contains("world_seed") &&
                          world->at("world_seed").is_number_unsigned();
    if (!recorded)
      throw InputError(path, 0,
                       fmt::format("expected \"world\" as {{\"family\": NAME, \"world_seed\": N}}, found {}",
                                   world->dump()));
  }

  const nlohmann::json& format = member(j, "format", path);
  if (!format.is_string() || format.get<std::string>() != kFormat)
    throw InputError(path, 0, fmt::format("expected \"format\": \"{}\", found {}", kFormat, format.dump()));
  const nlohmann::json& version = member(j, "version", path);
  if (!version.is_number_integer() || version.get<long long>() != kVersion)
    throw InputError(
        path, 0,
        fmt::format("unsupported version {}; this build reads version {}", version.dump(), kVersion));

  Params params;
  params.config = simulator_config_from_json(member(j, "simulator", path), path);
  const nlohmann::json& pose = member(j, "initial_pose", path);
  if (!pose.is_array() || pose.size() != 3 ||
      !std::all_of(pose.begin(), pose.end(), [](const nlohmann::json& v) { return v.is_number(); }))
    throw InputError(path, 0,
                     fmt::format("expected \"initial_pose\" as [x, y, theta], found {}", pose.dump()));
  params.initial_pose =
      Pose2(pose[0].get<double>(), pose[1].get<double>(), wrap_angle(pose[2].get<double>()));
  if (!within_coordinates(params.initial_pose.head<2>()))
    throw InputError(path, 0,
                     fmt::format("expected \"initial_pose\" x and y within +-2e6 m, found {}", pose.dump()));
  return params;
}

int read_id(const TextReader& in, std::size_t field, long min, const char* what) {
  const long id = in.integer(field, what);
  if (id < min || id > INT_MAX)
    in.fail(fmt::format("expected {} from {} to {}, found {}", what, min, INT_MAX, id));
  return static_cast<int>(id);
}

struct ObsLine {
  double t;
  std::size_t line;
};

void read_events(const fs::path& file, const ObservationModel& model, std::vector<Event>& events,
                 std::vector<ObsLine>& obs_lines) {
  if (!fs::exists(file)) throw InputError(file.string(), 0, "missing file (every simulator log has one)");
  TextReader in(file.string());
  double last_t = -std::numeric_limits<double>::infinity();
  double last_obs_t = last_t;
  bool have_control = false;
  double control_end = 0.0;
  while (in.next()) {
    const std::string_view keyword = in.field(0);
    if (keyword != "control" && keyword != "obs")
      in.fail(fmt::format("unknown keyword '{}'; expected 'control' or 'obs'", keyword));
    const int measured = model.dim();
    if (keyword == "control")
      in.expect_fields(5, "control <t> <dt> <speed> <steer>");
    else
      in.expect_fields(static_cast<std::size_t>(3 + measured), "obs <t> <id> " + measurement_columns(model));
    const double t = in.number(1, "the time");
    if (t < last_t)
      in.fail(fmt::format(
          "time {} is earlier than the {} of the line before; expected times never to decrease", t, last_t));
    last_t = t;

    if (keyword == "control") {
      const double dt = in.number(2, "dt");
      if (dt <= 0.0) in.fail(fmt::format("expected dt > 0, found {}", dt));
      if (have_control && !same_time(t - dt, control_end))
        in.fail(
            fmt::format("control starts at t - dt = {} but the previous control ended at {}; expected each "
                        "control to start where the previous one ended",
                        t - dt, control_end));
      if (t - dt < last_obs_t && !same_time(t - dt, last_obs_t))
        in.fail(
            fmt::format("control over ({}, {}] spans the observations at {} above it; expected a scan to "
                        "follow the control that ends at its time",
                        t - dt, t, last_obs_t));
      // Parsed before the comma initialiser: a throw inside it would trip Eigen's size assertion.
      const double speed = in.number(3, "the speed");
      const double steer = in.number(4, "the steering angle");
      Control u(2);
      u << speed, steer;
      events.emplace_back(ControlEvent{t, dt, u});
      have_control = true;
      control_end = t;
      continue;
    }

    const int id = read_id(in, 2, kUnknownId, "an id");
    const MeasuredRows rows = model.rows();
    Observation o{Measurement(measured), id};
    if (rows.range >= 0) {
      const double range = in.number(3 + static_cast<std::size_t>(rows.range), "the range");
      if (range <= 0.0) in.fail(fmt::format("expected a range > 0, found {}", range));
      o.z[rows.range] = range;
    }
    if (rows.bearing >= 0) o.z[rows.bearing] = wrap_angle(in.number(3 + static_cast<std::size_t>(rows.bearing), "the bearing"));
    auto* scan = events.empty() ? nullptr : std::get_if<ScanEvent>(&events.back());
    if (scan != nullptr && scan->t == t)
      scan->observations.push_back(o);
    else
      events.emplace_back(ScanEvent{t, {o}});
    obs_lines.push_back(ObsLine{t, in.line_number()});
    last_obs_t = t;
  }
  if (events.empty()) throw InputError(file.string(), 0, "no events; expected 'control' and 'obs' lines");
  if (obs_lines.empty())
    throw InputError(file.string(), 0,
                     "no 'obs' lines; expected observations, without which a run is dead reckoning (a world "
                     "with no landmark ever in the sensor's range gives none)");
}

void read_truth_poses(const fs::path& file, std::vector<StampedPose>& poses) {
  TextReader in(file.string());
  double last_t = -std::numeric_limits<double>::infinity();
  while (in.next()) {
    in.expect_fields(4, "<t> <x> <y> <theta>");
    const double t = in.number(0, "the time");
    if (t < last_t) in.fail(fmt::format("time {} is earlier than the {} of the line before", t, last_t));
    last_t = t;
    poses.push_back(
        StampedPose{t, Pose2(in.coordinate(1, "x"), in.coordinate(2, "y"), wrap_angle(in.number(3, "theta")))});
  }
}

void read_truth_landmarks(const fs::path& file, std::vector<Landmark>& landmarks) {
  TextReader in(file.string());
  std::unordered_map<int, std::size_t> line_of_id;
  while (in.next()) {
    in.expect_fields(3, "<id> <x> <y>");
    const int id = read_id(in, 0, 0, "a landmark id");
    if (const auto [it, fresh] = line_of_id.emplace(id, in.line_number()); !fresh)
      in.fail(fmt::format("duplicate landmark id {} (first on line {})", id, it->second));
    landmarks.push_back(Landmark{id, Vector2(in.coordinate(1, "x"), in.coordinate(2, "y")), Matrix2::Zero()});
  }
}

// The true ids, checked line by line against the obs lines of events.txt and grouped like its scans.
void read_truth_observations(const fs::path& file, const std::vector<Event>& events,
                             const std::vector<ObsLine>& obs_lines, std::vector<std::vector<int>>& ids) {
  TextReader in(file.string());
  std::vector<int> flat;
  flat.reserve(obs_lines.size());
  while (in.next()) {
    in.expect_fields(2, "<t> <true_id>");
    if (flat.size() == obs_lines.size())
      in.fail(fmt::format("more lines than the {} obs lines of {}; expected one line per obs line",
                          obs_lines.size(), kEventsFile));
    const ObsLine& obs = obs_lines[flat.size()];
    const double t = in.number(0, "the time");
    if (!same_time(t, obs.t))
      in.fail(fmt::format("time {} differs from the {} of the matching obs line ({}:{})", t, obs.t,
                          kEventsFile, obs.line));
    flat.push_back(read_id(in, 1, kUnknownId, "a true id"));
  }
  if (flat.size() != obs_lines.size())
    throw InputError(file.string(), 0,
                     fmt::format("has {} observations, expected {}: one per obs line of {}", flat.size(),
                                 obs_lines.size(), kEventsFile));
  auto next = flat.begin();
  for (const Event& event : events) {
    if (const auto* scan = std::get_if<ScanEvent>(&event)) {
      const auto end = next + static_cast<std::ptrdiff_t>(scan->observations.size());
      ids.emplace_back(next, end);
      next = end;
    }
  }
}

}  // namespace

void write_sim_log(const std::string& dir, const Dataset& dataset, const SimulatorConfig& config,
                   const World& world) {
  const fs::path root(dir);
  std::error_code error;
  fs::create_directories(root, error);
  if (error) throw InputError(dir, 0, "cannot create directory: " + error.message());
  write_params(root / kParamsFile, dataset, config, world);
  Dataset platform;
  set_platform(platform, config);
  write_events(root, dataset, *platform.observation);
  if (!dataset.truth.empty()) {
    write_truth(root, dataset.truth);
  } else {
    remove_stale(root / kTruthPosesFile);
    remove_stale(root / kTruthLandmarksFile);
  }
  write_world((root / kSimWorldFile).string(), world);
}

Dataset as_logged(Dataset dataset) {
  if (!dataset.observation) throw std::invalid_argument("as_logged: the dataset has no observation model");
  const std::vector<std::vector<int>>& ids = dataset.truth.observation_ids;
  const bool with_ids = !ids.empty();
  const MeasuredRows rows = dataset.observation->rows();
  // Compacted in place: `kept` events (and their scans' ids) stay, in order, at the front.
  std::size_t kept = 0, kept_scans = 0, scan_index = 0;
  // Moves an event to the front; moving onto itself would empty it.
  const auto keep = [&](std::size_t i) {
    if (kept != i) dataset.events[kept] = std::move(dataset.events[i]);
    ++kept;
  };
  for (std::size_t i = 0; i < dataset.events.size(); ++i) {
    Event& event = dataset.events[i];
    if (auto* c = std::get_if<ControlEvent>(&event)) {
      c->t = logged(c->t);
      c->dt = logged(c->dt);
      for (Eigen::Index k = 0; k < c->u.size(); ++k) c->u[k] = logged(c->u[k]);
      keep(i);
      continue;
    }
    auto* scan = std::get_if<ScanEvent>(&event);
    if (scan == nullptr) throw std::invalid_argument("as_logged: a simulated log holds landmark scans only");
    const std::size_t index = scan_index++;
    if (with_ids && (index >= ids.size() || ids[index].size() != scan->observations.size()))
      throw std::invalid_argument(
          fmt::format("as_logged: the truth's observation ids do not match scan {} of the event stream", index));
    if (scan->observations.empty()) continue;  // no line to go on
    scan->t = logged(scan->t);
    for (Observation& o : scan->observations) {
      for (Eigen::Index k = 0; k < o.z.size(); ++k) o.z[k] = logged(o.z[k]);
      if (rows.bearing >= 0) o.z[rows.bearing] = wrap_angle(o.z[rows.bearing]);
    }
    // The reader makes one scan of consecutive obs lines with the same time.
    auto* previous = kept == 0 ? nullptr : std::get_if<ScanEvent>(&dataset.events[kept - 1]);
    if (previous != nullptr && previous->t == scan->t) {
      previous->observations.insert(previous->observations.end(), scan->observations.begin(), scan->observations.end());
      if (with_ids)
        dataset.truth.observation_ids[kept_scans - 1].insert(dataset.truth.observation_ids[kept_scans - 1].end(),
                                                             ids[index].begin(), ids[index].end());
      continue;
    }
    if (with_ids && kept_scans != index)
      dataset.truth.observation_ids[kept_scans] = std::move(dataset.truth.observation_ids[index]);
    ++kept_scans;
    keep(i);
  }
  if (with_ids && scan_index != ids.size())
    throw std::invalid_argument(fmt::format("as_logged: the truth has observation ids for {} scans, the events have {}",
                                            ids.size(), scan_index));
  dataset.events.resize(kept);
  if (with_ids) dataset.truth.observation_ids.resize(kept_scans);
  dataset.initial_pose.z() = wrap_angle(dataset.initial_pose.z());
  for (StampedPose& p : dataset.truth.poses)
    p = StampedPose{logged(p.t), Pose2(logged(p.pose.x()), logged(p.pose.y()), wrap_angle(logged(p.pose.z())))};
  for (Landmark& l : dataset.truth.landmarks) l.position = Vector2(logged(l.position.x()), logged(l.position.y()));
  return dataset;
}

Dataset read_sim_log(const std::string& dir) {
  const fs::path root(dir);
  if (!fs::is_directory(root))
    throw InputError(dir, 0, "not a directory; expected a simulator log directory");
  const Params params = read_params(root / kParamsFile);
  Dataset dataset;
  dataset.spec = "sim:" + dir;
  dataset.name = "sim:" + io_detail::last_component(dir);
  set_platform(dataset, params.config);
  dataset.initial_pose = params.initial_pose;

  std::vector<ObsLine> obs_lines;
  read_events(root / kEventsFile, *dataset.observation, dataset.events, obs_lines);
  GroundTruth& truth = dataset.truth;
  truth.poses_have_heading = true;
  if (fs::exists(root / kTruthPosesFile)) read_truth_poses(root / kTruthPosesFile, truth.poses);
  if (fs::exists(root / kTruthLandmarksFile))
    read_truth_landmarks(root / kTruthLandmarksFile, truth.landmarks);
  if (fs::exists(root / kTruthObservationsFile))
    read_truth_observations(root / kTruthObservationsFile, dataset.events, obs_lines, truth.observation_ids);
  return dataset;
}

}  // namespace slamkit
