#include "slamkit/pipeline/settings.hpp"

#include <fmt/format.h>

#include <stdexcept>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/names.hpp"

namespace slamkit {
namespace {

/// `layer` without what `above` names, key by key into nested objects: the part of a source that a
/// later source leaves in effect.
nlohmann::json not_overridden(const nlohmann::json& layer, const nlohmann::json& above) {
  if (!above.is_object()) return layer;
  nlohmann::json kept = nlohmann::json::object();
  for (const auto& item : layer.items()) {
    if (!above.contains(item.key())) {
      kept[item.key()] = item.value();
    } else if (item.value().is_object()) {
      nlohmann::json inner = not_overridden(item.value(), above.at(item.key()));
      if (!inner.empty()) kept[item.key()] = std::move(inner);
    }
  }
  return kept;
}

/// The recommendation for `filter`, after checking every filter's entry.
nlohmann::json recommendation_for(FilterKind filter, const nlohmann::json& recommended, const std::string& source) {
  if (recommended.is_null()) return nlohmann::json::object();
  if (!recommended.is_object())
    throw InputError(source, 0, fmt::format("expected the recommended settings as an object by filter name, found {}",
                                            recommended.dump()));
  for (const auto& item : recommended.items()) {
    const std::string where = fmt::format("{} (recommended.{})", source, item.key());
    try {
      parse_filter_kind(item.key());
    } catch (const std::invalid_argument&) {
      throw InputError(source, 0,
                       "in 'recommended': " + unknown_name_message("filter", item.key(), filter_names()));
    }
    if (item.value().is_object() && item.value().contains("filter"))
      throw InputError(where, 0, "a filter's recommended settings cannot choose the filter; remove 'filter'");
    FilterConfig scratch;
    read_filter_settings(item.value(), where, scratch);
  }
  const auto entry = recommended.find(to_string(filter));
  return entry == recommended.end() ? nlohmann::json::object() : *entry;
}

}  // namespace

LayeredSettings layer_settings(const SettingsSources& sources) {
  LayeredSettings result;
  FilterConfig& config = result.config;
  if (const auto filter = sources.explicit_settings.find("filter"); filter != sources.explicit_settings.end())
    read_filter_settings({{"filter", *filter}}, sources.explicit_source, config);
  if (config.filter == FilterKind::kGridFastSlam) config.particles = kGridFastSlamParticles;
  const nlohmann::json recommendation =
      recommendation_for(config.filter, sources.recommended, sources.recommended_source);
  read_filter_settings(recommendation, sources.recommended_source, config);
  nlohmann::json named_later = sources.explicit_settings;
  if (!sources.association.is_null()) {
    read_association_settings(sources.association, sources.association_source, config.association);
    named_later["association"].update(sources.association);
  }
  read_filter_settings(sources.explicit_settings, sources.explicit_source, config);
  validate(config);
  result.recommendation_applied = not_overridden(recommendation, named_later);
  return result;
}

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
  if (const auto it = run_json.find("recommended_settings"); it != run_json.end()) {
    if (!it->is_object() && !it->is_null())
      throw wrong("recommended_settings", "the recommended settings applied (a JSON object, or null)", *it);
    settings.recommended_settings = *it;
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
