#pragma once
// Angle helpers. Every angle slamkit stores or compares is wrapped to (-pi, pi], so innovations and
// errors are always the short way round.
#include <cmath>
#include <numbers>

namespace slamkit {

inline constexpr double kPi = std::numbers::pi;

/// Wraps an angle to (-pi, pi].
inline double wrap_angle(double a) {
  if (a > -kPi && a <= kPi) return a;  // the common case costs one comparison pair
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

inline constexpr double deg2rad(double d) { return d * kPi / 180.0; }
inline constexpr double rad2deg(double r) { return r * 180.0 / kPi; }

}  // namespace slamkit
