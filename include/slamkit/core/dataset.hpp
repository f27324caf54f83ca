#pragma once
// A dataset, whatever its origin: the time-ordered event stream a filter consumes, the models and
// sensor limits that fit the platform that recorded it, and the ground truth where there is one.
// Readers (simulator logs, real logs) all produce this; filters and evaluation only see this. The
// models are only named here: a module that calls them includes slamkit/models.
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "slamkit/core/types.hpp"

namespace slamkit {

class MotionModel;
class ObservationModel;

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

/// The ids the observations of `events` carry, per ScanEvent, in the form of
/// GroundTruth::observation_ids: the truth of a log whose ids are the landmarks' true identities.
inline std::vector<std::vector<int>> observation_ids(const std::vector<Event>& events) {
  std::vector<std::vector<int>> ids;
  for (const Event& event : events) {
    if (const auto* scan = std::get_if<ScanEvent>(&event)) {
      std::vector<int>& scan_ids = ids.emplace_back();
      for (const Observation& o : scan->observations) scan_ids.push_back(o.id);
    }
  }
  return ids;
}

struct Dataset {
  std::string spec;  // how the user named it, e.g. "sim:out/demo/sim"
  std::string name;  // short label for titles
  std::vector<Event> events;
  std::shared_ptr<const MotionModel> motion;
  std::shared_ptr<const ObservationModel> observation;
  SensorLimits sensor;
  Pose2 initial_pose = Pose2::Zero();
  GroundTruth truth;
  /// The source's time of the dataset's t = 0 [s] where the reader shifts times to start near 0
  /// (MRCLAM: the Unix time of the first odometry row); 0 where times are kept as recorded. Whole
  /// seconds and the fraction apart, so the offset stays exact to the digit the file gives.
  long time_origin_s = 0;
  double time_origin_fraction_s = 0.0;
};

}  // namespace slamkit
