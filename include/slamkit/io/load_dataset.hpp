#pragma once
// Opens any dataset slamkit reads by its "kind:PATH" spec: the one table of dataset kinds, in front
// of the readers of io/.
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "slamkit/core/dataset.hpp"

namespace slamkit {

/// Opens a dataset from a "kind:PATH" spec ("sim:DIR", "victoria-park:DIR", "mrclam:DIR:robotN",
/// "course:DIR"). `settings_path` names a JSON file of the dataset's settings (noise, sensor limits,
/// ...; the shipped ones are config/*.json); empty for the defaults, which equal the shipped files.
/// Throws InputError on a bad spec, file or setting.
Dataset load_dataset(const std::string& spec, const std::string& settings_path = "");

/// The same, with the settings given as JSON (null for the defaults); `source` names them in errors.
/// run.json keeps the settings' contents, so a run can be repeated when the file has moved.
Dataset load_dataset(const std::string& spec, const nlohmann::json& settings, const std::string& source);

/// `spec` with its folder made absolute (and a missing one looked up as load_dataset does), so a run
/// folder names its data in a way that works from any working directory.
std::string absolute_dataset_spec(const std::string& spec);

/// Where datasets named without a path are looked up: $SLAMKIT_DATA if set, else ../shared/datasets
/// (relative to the working directory).
std::string datasets_folder();

}  // namespace slamkit
