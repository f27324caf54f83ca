#pragma once
// The "in view" test of association and map management: whether a landmark lies inside the
// sensor's view (SensorLimits: a range and a field of view about the vehicle's heading) widened or
// narrowed by margins. The test is geometric, from where the sensor is and where the landmark is, so
// it means the same whatever the sensor measures (range and bearing, range only, bearing only).
// Association looks for candidates in the view widened by AssociationConfig's margins, because a
// landmark predicted just outside the view may be the one seen at its edge; map management expects
// a landmark to be seen only inside the view narrowed by them (ExistenceRule), because near the edge
// the sensor's noise decides whether it is.
#include <cmath>

#include "slamkit/assoc/association_config.hpp"
#include "slamkit/core/angles.hpp"
#include "slamkit/core/types.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

/// Throws std::invalid_argument unless max_range > 0 and fov > 0.
void validate(const SensorLimits& sensor);

class SensorView {
 public:
  /// The view of `sensor` with its range extended by range_margin [m] and its half-angle by
  /// bearing_margin [rad]; negative margins narrow it. A field of view of 2 pi (to rounding) is a
  /// full circle, whatever the bearing margin.
  SensorView(const SensorLimits& sensor, double range_margin, double bearing_margin);

  /// Whether a landmark at `landmark` is in the view of a sensor at `sensor` whose axis points along
  /// `heading`; false for NaN.
  bool contains(const Vector2& sensor, double heading, const Vector2& landmark) const {
    const Vector2 d = landmark - sensor;
    return contains_polar(d.norm(), wrap_angle(std::atan2(d[1], d[0]) - heading));
  }
  /// The same for the sensor of `model` on a vehicle at x.
  bool contains(const ObservationModel& model, const Pose2& x, const Vector2& landmark) const {
    return contains(model.sensor_position(x), x[2], landmark);
  }
  /// Whether a point at `range` [m] and `bearing` [rad] from the sensor's axis is in the view; false
  /// for NaN.
  bool contains_polar(double range, double bearing) const {
    return range <= reach_ && (full_circle_ || std::abs(bearing) <= half_angle_);
  }
  /// This view with its range shortened by `range` [m] and its half-angle narrowed by `bearing`
  /// [rad] (a full circle stays one): where a landmark whose position relative to the sensor is
  /// uncertain by that much is in view wherever it is.
  SensorView narrowed(double range, double bearing) const {
    SensorView out = *this;
    out.reach_ -= range;
    out.half_angle_ -= bearing;
    return out;
  }
  /// The largest range in view [m].
  double reach() const { return reach_; }

 private:
  double reach_;
  double half_angle_;
  bool full_circle_;
};

/// Where association looks for candidate landmarks: the view widened by the configured margins.
SensorView association_view(const SensorLimits& sensor, const AssociationConfig& config);

}  // namespace slamkit
