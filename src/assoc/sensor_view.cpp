#include "slamkit/assoc/sensor_view.hpp"

#include <fmt/format.h>

#include <stdexcept>

#include "slamkit/core/angles.hpp"

namespace slamkit {

void validate(const SensorLimits& sensor) {
  if (!(sensor.max_range > 0.0))
    throw std::invalid_argument(fmt::format("sensor max_range must be > 0, found {}", sensor.max_range));
  if (!(sensor.fov > 0.0)) throw std::invalid_argument(fmt::format("sensor fov must be > 0, found {}", sensor.fov));
}

SensorView::SensorView(const SensorLimits& sensor, double range_margin, double bearing_margin)
    : reach_(sensor.max_range + range_margin),
      half_angle_(0.5 * sensor.fov + bearing_margin),
      // A field of view given as 360 degrees may come out a rounding error short of 2 pi.
      full_circle_(sensor.fov >= 2.0 * kPi - 1e-9) {}

SensorView association_view(const SensorLimits& sensor, const AssociationConfig& config) {
  return SensorView(sensor, config.view_margin_m, config.view_margin_rad);
}

}  // namespace slamkit
