#pragma once
// Basic value types shared by every module: poses, controls, observations and the timestamped
// events a dataset reader yields and a filter consumes.
#include <Eigen/Core>
#include <cstddef>
#include <numbers>
#include <variant>
#include <vector>

namespace slamkit {

/// Planar pose (x [m], y [m], heading [rad], heading wrapped to (-pi, pi]).
using Pose2 = Eigen::Vector3d;
using Matrix3 = Eigen::Matrix3d;
using Vector2 = Eigen::Vector2d;
using Matrix2 = Eigen::Matrix2d;

/// Control vectors have a model-dependent size (2 for speed/steer, 3 for odometry) but never more
/// than kMaxControlDim: fixed-capacity storage keeps the filters' hot loops free of allocation.
inline constexpr int kMaxControlDim = 4;
using Control = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxControlDim, 1>;
using ControlJacobian = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxControlDim>;
using ControlCovariance =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxControlDim, kMaxControlDim>;

/// A measurement of one landmark has the observation model's dimension (1 for range only or bearing
/// only, 2 for range and bearing) but never more than kMaxMeasurementDim: fixed-capacity storage,
/// as for controls, so that nothing allocates per observation.
inline constexpr int kMaxMeasurementDim = 3;
using Measurement = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxMeasurementDim, 1>;
using MeasurementCovariance =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxMeasurementDim, kMaxMeasurementDim>;

/// Landmark identity carried by an observation. kUnknownId means the sensor does not say.
inline constexpr int kUnknownId = -1;

/// One landmark measurement, in the terms of the dataset's observation model (range [m] and bearing
/// [rad] in the sensor frame for a range-bearing sensor).
struct Observation {
  Measurement z;
  int id = kUnknownId;
};

/// A control applied from the previous event's time up to `t`.
struct ControlEvent {
  double t = 0.0;
  double dt = 0.0;
  Control u;
};

/// All observations taken at one instant (one sensor sweep).
struct ScanEvent {
  double t = 0.0;
  std::vector<Observation> observations;
};

/// One sweep of a planar range finder (a laser scanner): ranges at evenly spaced bearings, kept whole
/// for the filters that map with them (occupancy grids, scan matching) rather than reduced to
/// landmarks.
struct RangeScanEvent {
  double t = 0.0;
  /// Where the sensor sits on the vehicle (x forward, y left [m], heading [rad]).
  Pose2 sensor_offset = Pose2::Zero();
  double angle_min = 0.0;        // bearing of the first beam in the sensor frame [rad]
  double angle_increment = 0.0;  // between consecutive beams [rad]
  /// A reading at or beyond this is no return: free space up to a cut-off, not an obstacle [m].
  double max_range = 0.0;
  std::vector<float> ranges;  // [m]

  double bearing(std::size_t beam) const { return angle_min + angle_increment * static_cast<double>(beam); }
};

using Event = std::variant<ControlEvent, ScanEvent, RangeScanEvent>;

inline double event_time(const Event& e) {
  return std::visit([](const auto& event) { return event.t; }, e);
}

/// A timestamped pose, e.g. a ground-truth or estimated trajectory sample.
struct StampedPose {
  double t = 0.0;
  Pose2 pose = Pose2::Zero();
};

/// What the sensor can see: landmarks within max_range and within +-fov/2 of the sensor axis.
struct SensorLimits {
  double max_range = 30.0;             // m
  double fov = 2.0 * std::numbers::pi; // rad, full opening angle
};

/// A pose hypothesis with its normalised weight (a particle).
struct WeightedPose {
  Pose2 pose = Pose2::Zero();
  double weight = 0.0;
};

/// A point landmark of a map with a 2x2 covariance (zero for ground truth).
struct Landmark {
  int id = 0;
  Vector2 position = Vector2::Zero();
  Matrix2 covariance = Matrix2::Zero();
};

/// Where a landmark not yet started may lie: one of a range's ring of hypotheses, or a position its
/// observations so far admit, with its weight among its landmark's hypotheses (they sum to one).
struct LandmarkHypothesis {
  Landmark landmark;
  double weight = 0.0;
};

}  // namespace slamkit
