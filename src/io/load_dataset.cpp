#include "slamkit/io/load_dataset.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string_view>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/names.hpp"
#include "slamkit/io/carmen.hpp"
#include "slamkit/io/course_log.hpp"
#include "slamkit/io/mrclam.hpp"
#include "slamkit/io/plaza.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/io/simulated_datasets.hpp"
#include "slamkit/io/victoria_park.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

constexpr int kMrclamRobots = 5;
constexpr const char* kRecommendedKey = "recommended";

/// A reader; `settings` (nullptr for the shipped defaults) is the JSON of the dataset's settings
/// without its recommendation, `source` names where it came from for error messages.
using Reader = Dataset (*)(const std::string& path, const nlohmann::json* settings, const std::string& source);

struct DatasetKind {
  std::string_view name;
  Reader read;
  /// Where the dataset lives inside a datasets folder ($SLAMKIT_DATA), for specs without a path;
  /// empty if the kind has no standard place.
  std::string_view default_folder;
  /// The filter settings the dataset needs when it is read with its default settings (the shipped
  /// config file holds the same under "recommended"); JSON text, empty for none.
  std::string_view recommended;
};

Dataset read_sim(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  if (settings != nullptr)
    throw InputError(source, 0, "a simulator log carries its settings in its params.json; expected no dataset settings");
  return read_sim_log(path);
}

Dataset read_victoria_park_with(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  return settings ? read_victoria_park(path, victoria_park_options_from_json(*settings, source)) : read_victoria_park(path);
}

/// MRCLAM's robot selection in a spec's path: "DIR:robotN" or "DIR:N" ("robot" in any case),
/// "DIR/RobotN", or a bare DIR for robot 1. Throws std::invalid_argument on any other robot.
MrclamRobot select_mrclam_robot(const std::string& path) {
  if (const auto colon = path.rfind(':'); colon != std::string::npos) {
    const std::string given = path.substr(colon + 1);
    std::string_view digits = given;
    if (digits.size() >= 5 && std::equal(digits.begin(), digits.begin() + 5, "robot",
                                         [](char a, char b) { return std::tolower(static_cast<unsigned char>(a)) == b; }))
      digits.remove_prefix(5);
    const std::string expected =
        fmt::format("expected a robot from 1 to {} as DIR:robotN, DIR:N or DIR/RobotN", kMrclamRobots);
    if (digits.empty()) throw std::invalid_argument(fmt::format("no robot number in '{}'; {}", given, expected));
    int robot = 0;
    const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), robot);
    if (error != std::errc() || end != digits.data() + digits.size() || robot < 1 || robot > kMrclamRobots)
      throw std::invalid_argument(fmt::format("no MRCLAM robot '{}'; {}", given, expected));
    return {path.substr(0, colon), robot};
  }
  std::string trimmed = path;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  if (!fs::path(trimmed).filename().string().starts_with("Robot")) return {path, 1};
  try {
    return parse_mrclam_robot_path(trimmed);
  } catch (const InputError& e) {
    throw std::invalid_argument(e.what());
  }
}

Dataset read_mrclam_robot(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  const MrclamRobot robot = select_mrclam_robot(path);
  return read_mrclam(robot.dataset_dir, robot.robot,
                     settings ? mrclam_options_from_json(*settings, source) : MrclamOptions{});
}

struct PlazaRun {
  std::string dir;
  std::string run;  // as its files spell it
};

/// Plaza's run in a spec's path: "DIR:PlazaN" ("plaza" in any case) or a bare DIR for Plaza1. Throws
/// std::invalid_argument on any other run name.
PlazaRun select_plaza_run(const std::string& path) {
  const auto colon = path.rfind(':');
  if (colon == std::string::npos) return {path, kPlazaDefaultRun};
  const std::string given = path.substr(colon + 1);
  const std::optional<std::string> run = plaza_run_name(given);
  if (!run)
    throw std::invalid_argument(fmt::format(
        "no Plaza run '{}'; expected a run as DIR:PlazaN with N a whole number from 1 (a bare DIR is {})", given,
        kPlazaDefaultRun));
  return {path.substr(0, colon), *run};
}

Dataset read_plaza_run(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  const PlazaRun run = select_plaza_run(path);
  return read_plaza(run.dir, run.run, settings ? plaza_options_from_json(*settings, source) : PlazaOptions{});
}

Dataset read_course(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  return read_course_log(path, settings ? course_options_from_json(*settings, source) : CourseOptions{});
}

Dataset read_carmen_log(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  return read_carmen(path, settings ? carmen_options_from_json(*settings, source) : CarmenOptions{});
}

Dataset read_scenario(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  return simulate_dataset("scenario", path, settings, source);
}

Dataset read_family(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  return simulate_dataset("family", path, settings, source);
}

Dataset read_building(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  return simulate_dataset("building", path, settings, source);
}

// Every reader slamkit has, by the kind that selects it in a "kind:PATH" spec. Victoria Park has no
// landmark identities, so every filter needs an association method there; the UKF's additive noise
// and FastSLAM 2.0's pose sample fraction were chosen on it (docs/choosing.md has the numbers).
constexpr DatasetKind kKinds[] = {
    {"sim", &read_sim, "", ""},
    {"victoria-park", &read_victoria_park_with, "victoria_park",
     R"({"ekf": {"association": {"method": "jcbb"}},
         "ukf": {"association": {"method": "jcbb"}, "ukf_noise": "additive"},
         "eif": {"association": {"method": "jcbb"}},
         "seif": {"association": {"method": "jcbb"}},
         "eseif": {"association": {"method": "jcbb"}},
         "tjtf": {"association": {"method": "jcbb"}},
         "fastslam1": {"association": {"method": "nn"}},
         "fastslam2": {"association": {"method": "nn"}, "pose_sample_fraction": 0.01}})"},
    {"mrclam", &read_mrclam_robot, "mrclam/MRCLAM_Dataset6", ""},
    {"course", &read_course, "", ""},
    {"plaza", &read_plaza_run, "plaza_range_only", ""},
    {"carmen", &read_carmen_log, "", ""},
    {"scenario", &read_scenario, "", ""},
    {"family", &read_family, "", ""},
    {"building", &read_building, "", ""},
};

std::vector<std::string> kind_names() {
  std::vector<std::string> names;
  for (const DatasetKind& k : kKinds) names.emplace_back(k.name);
  return names;
}

struct ParsedSpec {
  const DatasetKind* kind;
  std::string path;  // empty: the kind's place in the datasets folder
};

/// The spec's form alone, without the file system; std::invalid_argument when it is wrong.
ParsedSpec parse_spec(const std::string& spec) {
  const std::size_t colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  const auto match = std::find_if(std::begin(kKinds), std::end(kKinds),
                                  [&](const DatasetKind& k) { return k.name == kind; });
  if (match == std::end(kKinds)) {
    if (colon == std::string::npos)
      throw std::invalid_argument(fmt::format("'{}' is not a dataset spec; expected KIND:PATH with KIND one of: {}{}",
                                              spec, fmt::join(kind_names(), ", "), did_you_mean(kind, kind_names())));
    throw std::invalid_argument(unknown_name_message("dataset kind", kind, kind_names()));
  }
  const std::string path = colon == std::string::npos ? std::string() : spec.substr(colon + 1);
  if (path.starts_with(':') && match->read != &read_mrclam_robot && match->read != &read_plaza_run)
    throw std::invalid_argument(fmt::format(
        "'{}': KIND::NAME chooses a robot or run of the datasets folder's copy, which only mrclam and plaza "
        "have; expected {}:PATH",
        spec, kind));
  if (path.empty() && match->default_folder.empty())
    throw std::invalid_argument(fmt::format("expected a path after '{}:'", kind));
  if (is_simulated_kind(kind)) check_simulated_spec(kind, path);
  if (match->read == &read_mrclam_robot && !path.empty()) select_mrclam_robot(path);
  if (match->read == &read_plaza_run && !path.empty()) select_plaza_run(path);
  return {match, path};
}

/// parse_spec, its errors as bad input naming the spec (a spec read from a run.json is data).
ParsedSpec parse_recorded_spec(const std::string& spec) {
  try {
    return parse_spec(spec);
  } catch (const std::invalid_argument& e) {
    throw InputError(spec, 0, e.what());
  }
}

/// The spec with its path filled in: a real dataset named without one ("mrclam", or "mrclam::robot3"
/// with a robot chosen) is looked up in the datasets folder.
ParsedSpec resolve(const std::string& spec) {
  ParsedSpec resolved = parse_recorded_spec(spec);
  if (resolved.path.empty() || resolved.path.starts_with(':')) {
    const std::string folder = (fs::path(datasets_folder()) / resolved.kind->default_folder).string();
    resolved.path = folder + resolved.path;
    if (!fs::exists(folder))
      throw InputError(spec, 0,
                       fmt::format("no path given and {} does not exist; set SLAMKIT_DATA to the folder holding "
                                   "{}/ or give {}:PATH",
                                   folder, resolved.kind->default_folder, resolved.kind->name));
  }
  return resolved;
}

}  // namespace

std::string datasets_folder() {
  if (const char* env = std::getenv("SLAMKIT_DATA"); env != nullptr && *env != '\0') return env;
  return "../shared/datasets";
}

void check_dataset_spec(const std::string& spec) { parse_spec(spec); }

std::string absolute_dataset_spec(const std::string& spec) {
  const ParsedSpec resolved = resolve(spec);
  // A simulated dataset's "path" is its name and seeds.
  if (is_simulated_kind(std::string(resolved.kind->name))) return spec;
  // MRCLAM's robot and Plaza's run are no part of the folder; they are written out, so run.json
  // names them even when the spec left robot 1 or Plaza1 implicit.
  if (resolved.kind->read == &read_mrclam_robot) {
    const MrclamRobot robot = select_mrclam_robot(resolved.path);
    return fmt::format("{}:{}:robot{}", resolved.kind->name,
                       fs::absolute(robot.dataset_dir).lexically_normal().string(), robot.robot);
  }
  if (resolved.kind->read == &read_plaza_run) {
    const PlazaRun run = select_plaza_run(resolved.path);
    return fmt::format("{}:{}:{}", resolved.kind->name, fs::absolute(run.dir).lexically_normal().string(), run.run);
  }
  return fmt::format("{}:{}", resolved.kind->name, fs::absolute(resolved.path).lexically_normal().string());
}

nlohmann::json recommended_settings(const std::string& spec, const nlohmann::json& settings, const std::string& source) {
  if (settings.is_null()) {
    const std::string_view builtin = parse_recorded_spec(spec).kind->recommended;
    return builtin.empty() ? nlohmann::json::object() : nlohmann::json::parse(builtin);
  }
  if (!settings.is_object() || !settings.contains(kRecommendedKey)) return nlohmann::json::object();
  const nlohmann::json& recommended = settings.at(kRecommendedKey);
  if (!recommended.is_object())
    throw InputError(source, 0,
                     fmt::format("'{}' must be an object of filter settings by filter name, found {}", kRecommendedKey,
                                 recommended.dump()));
  return recommended;
}

Dataset load_dataset(const std::string& spec, const std::string& settings_path) {
  return load_dataset(spec, settings_path.empty() ? nlohmann::json() : read_json_file(settings_path), settings_path);
}

Dataset load_dataset(const std::string& spec, const nlohmann::json& settings, const std::string& source) {
  const ParsedSpec resolved = resolve(spec);
  const nlohmann::json* reader_settings = settings.is_null() ? nullptr : &settings;
  // The recommendation is for the filters (recommended_settings); the reader sees the rest.
  nlohmann::json without_recommendation;
  if (settings.is_object() && settings.contains(kRecommendedKey)) {
    without_recommendation = settings;
    without_recommendation.erase(kRecommendedKey);
    reader_settings = &without_recommendation;
  }
  Dataset dataset = resolved.kind->read(resolved.path, reader_settings, source);
  dataset.spec = spec;
  return dataset;
}

}  // namespace slamkit
