#pragma once
// Opens any dataset slamkit reads by its "kind:PATH" spec: the one table of dataset kinds, in front
// of the readers of io/.
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "slamkit/core/dataset.hpp"

namespace slamkit {

/// Opens a dataset from a "kind:PATH" spec ("sim:DIR", "victoria-park:DIR", "mrclam:DIR:robotN",
/// "course:DIR", "plaza:DIR:PlazaN", and the simulated "scenario:NAME:SEED", ... of
/// io/simulated_datasets.hpp). `settings_path` names a JSON file of the dataset's settings
/// (noise, sensor limits, ...; the shipped ones are config/*.json); empty for the defaults, which
/// equal the shipped files. A real dataset without a path ("victoria-park", "mrclam", or
/// "mrclam::robot3" with the robot chosen) is the one in datasets_folder().
/// The settings' "recommended" object is for the filters (recommended_settings), not the reader.
/// Throws InputError on a bad spec, file or setting.
Dataset load_dataset(const std::string& spec, const std::string& settings_path = "");

/// The same, with the settings given as JSON (null for the defaults); `source` names them in errors.
/// run.json keeps the settings' contents, so a run can be repeated when the file has moved.
Dataset load_dataset(const std::string& spec, const nlohmann::json& settings, const std::string& source);

/// Checks the form of a spec without touching the file system: a known kind, a path where the kind
/// has no standard place, for MRCLAM the robot: "DIR:robotN", "DIR:N" or "DIR/RobotN" with N from 1
/// to 5 (a bare DIR is robot 1), and for Plaza the run: "DIR:PlazaN" with N a whole number from 1 (a
/// bare DIR is Plaza1). Throws std::invalid_argument, one line naming what was expected (and the
/// nearest kind to a misspelt one): a usage error, which load_dataset reports as InputError.
void check_dataset_spec(const std::string& spec);

/// The filter settings a dataset needs, by filter name: {"fastslam2": {"pose_sample_fraction": 0.01},
/// ...}, each a partial object of run.json's `settings` keys. They are the "recommended" object of
/// the dataset's settings, or with null settings the kind's built-in recommendation, which the
/// shipped config file repeats (Victoria Park's: an association method for every filter, as the park
/// has no landmark identities; the UKF's additive noise; FastSLAM 2.0's pose sample fraction). An
/// empty object when there are none. Throws InputError naming `source` if "recommended" is not an
/// object; pipeline/settings.hpp checks its contents.
nlohmann::json recommended_settings(const std::string& spec, const nlohmann::json& settings, const std::string& source);

/// `spec` with its folder made absolute (a missing one looked up as load_dataset does), MRCLAM's
/// robot written out as ":robotN" and Plaza's run as ":PlazaN", so a run folder names its data in a
/// way that works from any working directory.
std::string absolute_dataset_spec(const std::string& spec);

/// Where datasets named without a path are looked up: $SLAMKIT_DATA if set, else ../shared/datasets
/// (relative to the working directory).
std::string datasets_folder();

}  // namespace slamkit
