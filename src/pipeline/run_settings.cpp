#include "slamkit/pipeline/run_settings.hpp"

#include <fmt/format.h>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"

namespace slamkit {

RunSettings run_settings_from_json(const nlohmann::json& run_json, const std::string& source) {
  if (!run_json.is_object())
    throw InputError(source, 0, fmt::format("expected the run.json of a run folder (a JSON object), found {}",
                                            run_json.type_name()));
  const auto member = [&](const char* key) -> const nlohmann::json& {
    const auto it = run_json.find(key);
    if (it == run_json.end())
      throw InputError(source, 0,
                       fmt::format("missing key '{}'; expected the run.json of a run folder (with 'settings' and "
                                   "'dataset')",
                                   key));
    return *it;
  };
  const auto wrong = [&](const char* key, const char* expected, const nlohmann::json& value) {
    return InputError(source, 0, fmt::format("'{}' must be {}, found {}", key, expected, value.dump()));
  };

  RunSettings settings;
  settings.filter = filter_config_from_json(member("settings"), source);
  const nlohmann::json& dataset = member("dataset");
  if (!dataset.is_string() || dataset.get_ref<const std::string&>().empty())
    throw wrong("dataset", "a dataset spec (a string KIND:PATH)", dataset);
  settings.dataset = dataset.get<std::string>();
  if (const auto it = run_json.find("dataset_settings"); it != run_json.end()) {
    if (!it->is_string()) throw wrong("dataset_settings", "the path of a settings file (a string, empty for none)", *it);
    settings.dataset_settings = it->get<std::string>();
  }
  if (const auto it = run_json.find("dataset_settings_contents"); it != run_json.end()) {
    if (!it->is_object() && !it->is_null())
      throw wrong("dataset_settings_contents", "the dataset settings (a JSON object, or null for the defaults)", *it);
    settings.dataset_settings_contents = *it;
    settings.dataset_settings_source = fmt::format("{} (dataset_settings_contents)", source);
  } else if (!settings.dataset_settings.empty()) {
    settings.dataset_settings_contents = read_json_file(settings.dataset_settings);
    settings.dataset_settings_source = settings.dataset_settings;
  }
  return settings;
}

}  // namespace slamkit
