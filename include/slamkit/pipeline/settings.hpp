#pragma once
// Where a run's filter settings come from. Each source is a partial object of run.json's `settings`
// keys (the association's nested under "association") and overrides what it names; lowest first:
//   1. the defaults (FilterConfig{});
//   2. the dataset's recommendation for the chosen filter (io's recommended_settings: what a real
//      dataset needs, e.g. Victoria Park's association method and FastSLAM 2.0's pose sample
//      fraction);
//   3. an association settings file (`slamkit run --assoc-config`), run.json's settings.association;
//   4. the explicit settings (the command line's flags).
// The result is validated once, whole. run.json records it with the recommended settings that took
// effect, so `--config run.json` repeats a run without consulting any source again
// (run_settings_from_json; run.json is a file a user may edit, so every key it reads is checked).
#include <nlohmann/json.hpp>
#include <string>

#include "slamkit/pipeline/factory.hpp"

namespace slamkit {

struct SettingsSources {
  /// By filter name, as recommended_settings gives it; an empty object (or null) for none.
  nlohmann::json recommended = nlohmann::json::object();
  std::string recommended_source;
  /// The association settings file's contents; null for none.
  nlohmann::json association;
  std::string association_source;
  /// Settings given one by one; "filter" among them chooses the filter, and so the recommendation.
  nlohmann::json explicit_settings = nlohmann::json::object();
  std::string explicit_source = "the command line";
};

struct LayeredSettings {
  FilterConfig config;
  /// The recommended settings that took effect (those no later source named), as a partial settings
  /// object: what run.json and the console report. Empty when none did.
  nlohmann::json recommendation_applied = nlohmann::json::object();
};

/// Layers the sources over the defaults. A source that cannot be read (an unknown key, a value of the
/// wrong kind, an unknown name; in the recommendation also a key that is no filter name, or a filter's
/// entry naming "filter") is an InputError naming it; every filter's recommendation is checked, not
/// only the chosen one's. Settings that no filter runs with together throw std::invalid_argument from
/// validate(FilterConfig).
LayeredSettings layer_settings(const SettingsSources& sources);

/// What `slamkit run --config RUN.json` repeats of an earlier run.
struct RunSettings {
  FilterConfig filter;
  std::string dataset;           // the "kind:PATH" spec
  std::string dataset_settings;  // the settings file the run named; empty for the reader's defaults
  /// The settings themselves (null for the defaults): those run.json recorded, or where it recorded
  /// none (an older run.json), the named file's.
  nlohmann::json dataset_settings_contents;
  /// How errors in the settings name them: run.json and its key, or the file they came from.
  std::string dataset_settings_source;
  /// The recommended settings the run applied, recorded again as they were (null for none).
  nlohmann::json recommended_settings;
};

/// Reads a run.json's contents; `source` names it. 'settings' (the keys filter_config_from_json
/// reads) and 'dataset' (a string) are required; 'dataset_settings' is a string,
/// 'dataset_settings_contents' and 'recommended_settings' an object or null where present; other
/// keys are left alone. Anything else is an InputError naming `source` and the key.
RunSettings run_settings_from_json(const nlohmann::json& run_json, const std::string& source);

}  // namespace slamkit
