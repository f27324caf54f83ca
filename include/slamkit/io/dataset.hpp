#pragma once
// A dataset, whatever its origin: the time-ordered event stream a filter consumes, the models and
// sensor limits that fit the platform that recorded it, and the ground truth where there is one.
// Readers (simulator logs, real logs) all produce this; filters and evaluation only see this.
#include <memory>
#include <string>
#include <vector>

#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/types.hpp"

namespace slamkit {

struct GroundTruth {
  std::vector<StampedPose> poses;
  /// False where the truth has positions only (GPS): then no pose NEES is computed.
  bool poses_have_heading = true;
  std::vector<Landmark> landmarks;
  /// For the i-th ScanEvent of the stream, the true landmark id of each of its observations, in
  /// order (kUnknownId for a false detection). Empty when the truth does not say.
  std::vector<std::vector<int>> observation_ids;

  bool empty() const { return poses.empty() && landmarks.empty(); }
};

struct Dataset {
  std::string spec;  // how the user named it, e.g. "sim:out/demo/sim"
  std::string name;  // short label for titles
  std::vector<Event> events;
  std::shared_ptr<const MotionModel> motion;
  std::shared_ptr<const ObservationModel> observation;
  SensorLimits sensor;
  Pose2 initial_pose = Pose2::Zero();
  GroundTruth truth;
};

/// Opens a dataset from a "kind:PATH" spec ("sim:DIR", "victoria-park:DIR", "mrclam:DIR:robotN",
/// "course:DIR"). `settings_path` names a JSON file of the dataset's settings (noise, sensor limits,
/// ...; the shipped ones are config/*.json); empty for the defaults, which equal the shipped files.
/// Throws InputError on a bad spec, file or setting.
Dataset load_dataset(const std::string& spec, const std::string& settings_path = "");

/// Where datasets named without a path are looked up: $SLAMKIT_DATA if set, else ../shared/datasets
/// (relative to the working directory).
std::string datasets_folder();

}  // namespace slamkit
