#pragma once
// The "in view" test of association and map management: whether a landmark's predicted measurement
// (range, bearing, the terms in which SensorLimits are given) lies inside the sensor's view widened
// or narrowed by margins. Association looks for candidates in the view widened by
// AssociationConfig's margins, because a landmark predicted just outside the view may be the one seen
// at its edge; map management expects a landmark to be seen only inside the view narrowed by them
// (ExistenceRule), because near the edge the sensor's noise decides whether it is.
#include <cmath>

#include "slamkit/assoc/association_config.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

/// Throws std::invalid_argument unless max_range > 0 and fov > 0.
void validate(const SensorLimits& sensor);

class SensorView {
 public:
  /// The view of `sensor` with its range extended by range_margin [m] and its half-angle by
  /// bearing_margin [rad]; negative margins narrow it. A field of view of 2 pi (to rounding) is a
  /// full circle, whatever the bearing margin.
  SensorView(const SensorLimits& sensor, double range_margin, double bearing_margin);

  /// Whether a predicted measurement (range, bearing) lies in the view; false for NaN.
  bool contains(const Vector2& z) const {
    return z[0] <= reach_ && (full_circle_ || std::abs(z[1]) <= half_angle_);
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
