#pragma once
// What `slamkit run --config RUN.json` repeats of an earlier run: the filter settings, the dataset
// and the dataset settings its run.json records (io/run_io.hpp writes it). run.json is a file a
// user may edit, so every key read is checked for its kind before use.
#include <nlohmann/json.hpp>
#include <string>

#include "slamkit/pipeline/factory.hpp"

namespace slamkit {

struct RunSettings {
  FilterConfig filter;
  std::string dataset;           // the "kind:PATH" spec
  std::string dataset_settings;  // the settings file the run named; empty for the reader's defaults
  /// The settings themselves (null for the defaults): those run.json recorded, or where it recorded
  /// none (an older run.json), the named file's.
  nlohmann::json dataset_settings_contents;
  /// How errors in the settings name them: run.json and its key, or the file they came from.
  std::string dataset_settings_source;
};

/// Reads a run.json's contents; `source` names it. 'settings' (the keys filter_config_from_json
/// reads) and 'dataset' (a string) are required; 'dataset_settings' is a string and
/// 'dataset_settings_contents' an object or null where present; other keys are left alone. Anything
/// else is an InputError naming `source` and the key.
RunSettings run_settings_from_json(const nlohmann::json& run_json, const std::string& source);

}  // namespace slamkit
