#include "slamkit/io/load_dataset.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <iterator>
#include <string_view>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/io/course_log.hpp"
#include "slamkit/io/mrclam.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/io/victoria_park.hpp"

namespace slamkit {
namespace {

/// A reader; `settings` (nullptr for the shipped defaults) is the JSON of the dataset's settings,
/// `source` names where it came from for error messages.
using Reader = Dataset (*)(const std::string& path, const nlohmann::json* settings, const std::string& source);

struct DatasetKind {
  std::string_view name;
  Reader read;
  /// Where the dataset lives inside a datasets folder ($SLAMKIT_DATA), for specs without a path;
  /// empty if the kind has no standard place.
  std::string_view default_folder;
};

Dataset read_sim(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  if (settings != nullptr)
    throw InputError(source, 0, "a simulator log carries its settings in its params.json; expected no dataset settings");
  return read_sim_log(path);
}

Dataset read_victoria_park_with(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  return settings ? read_victoria_park(path, victoria_park_options_from_json(*settings, source)) : read_victoria_park(path);
}

/// "DIR:robotN" or "DIR/RobotN"; a bare DIR means robot 1.
Dataset read_mrclam_robot(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  std::string normalised = path;
  if (const auto colon = path.rfind(":robot"); colon != std::string::npos)
    normalised = path.substr(0, colon) + "/Robot" + path.substr(colon + 6);
  else if (!std::filesystem::path(path).filename().string().starts_with("Robot"))
    normalised = (std::filesystem::path(path) / "Robot1").string();
  const MrclamRobot robot = parse_mrclam_robot_path(normalised);
  return read_mrclam(robot.dataset_dir, robot.robot,
                     settings ? mrclam_options_from_json(*settings, source) : MrclamOptions{});
}

Dataset read_course(const std::string& path, const nlohmann::json* settings, const std::string& source) {
  return read_course_log(path, settings ? course_options_from_json(*settings, source) : CourseOptions{});
}

// Every reader slamkit has, by the kind that selects it in a "kind:PATH" spec.
constexpr DatasetKind kKinds[] = {
    {"sim", &read_sim, ""},
    {"victoria-park", &read_victoria_park_with, "victoria_park"},
    {"mrclam", &read_mrclam_robot, "mrclam/MRCLAM_Dataset6"},
    {"course", &read_course, ""},
};

std::string kind_names() {
  std::string names;
  for (const DatasetKind& k : kKinds) names += fmt::format("{}{}", names.empty() ? "" : ", ", k.name);
  return names;
}

}  // namespace

std::string datasets_folder() {
  if (const char* env = std::getenv("SLAMKIT_DATA"); env != nullptr && *env != '\0') return env;
  return "../shared/datasets";
}

namespace {

struct ResolvedSpec {
  const DatasetKind* kind;
  std::string path;
};

ResolvedSpec resolve(const std::string& spec) {
  const std::size_t colon = spec.find(':');
  const std::string_view kind = std::string_view(spec).substr(0, colon);
  const auto match = std::find_if(std::begin(kKinds), std::end(kKinds),
                                  [&](const DatasetKind& k) { return k.name == kind; });
  if (match == std::end(kKinds)) {
    if (colon == std::string::npos)
      throw InputError(spec, 0, fmt::format("expected a dataset as KIND:PATH with KIND one of: {}", kind_names()));
    throw InputError(spec, 0, fmt::format("unknown dataset kind '{}'; expected one of: {}", kind, kind_names()));
  }
  std::string path = colon == std::string::npos ? std::string() : spec.substr(colon + 1);
  if (path.empty()) {
    if (match->default_folder.empty()) throw InputError(spec, 0, fmt::format("expected a path after '{}:'", kind));
    // A real dataset named without a path is looked up in the datasets folder.
    path = (std::filesystem::path(datasets_folder()) / match->default_folder).string();
    if (!std::filesystem::exists(path))
      throw InputError(spec, 0,
                       fmt::format("no path given and {} does not exist; set SLAMKIT_DATA to the folder holding "
                                   "{}/ or give {}:PATH",
                                   path, match->default_folder, kind));
  }
  return {match, path};
}

}  // namespace

std::string absolute_dataset_spec(const std::string& spec) {
  const ResolvedSpec resolved = resolve(spec);
  // MRCLAM's ":robotN" suffix selects a robot and is no part of the folder.
  const std::size_t robot = resolved.path.rfind(":robot");
  const std::string folder = robot == std::string::npos ? resolved.path : resolved.path.substr(0, robot);
  const std::string suffix = robot == std::string::npos ? std::string() : resolved.path.substr(robot);
  return fmt::format("{}:{}{}", resolved.kind->name, std::filesystem::absolute(folder).lexically_normal().string(),
                     suffix);
}

Dataset load_dataset(const std::string& spec, const std::string& settings_path) {
  return load_dataset(spec, settings_path.empty() ? nlohmann::json() : read_json_file(settings_path), settings_path);
}

Dataset load_dataset(const std::string& spec, const nlohmann::json& settings, const std::string& source) {
  const ResolvedSpec resolved = resolve(spec);
  Dataset dataset = resolved.kind->read(resolved.path, settings.is_null() ? nullptr : &settings, source);
  dataset.spec = spec;
  return dataset;
}

}  // namespace slamkit
