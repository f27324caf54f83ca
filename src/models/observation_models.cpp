#include <cmath>

#include "slamkit/core/angles.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

Vector2 RangeBearingModel::sensor_position(const Pose2& x) const {
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  return Vector2(x[0] + p_.offset_x * c - p_.offset_y * s, x[1] + p_.offset_x * s + p_.offset_y * c);
}

namespace {
// Range and bearing of m from a sensor at `sensor` on a vehicle heading `heading`.
Vector2 seen_from(const Vector2& sensor, double heading, const Vector2& m) {
  const Vector2 d = m - sensor;
  return Vector2(d.norm(), wrap_angle(std::atan2(d[1], d[0]) - heading));
}
}  // namespace

Vector2 RangeBearingModel::predict(const Pose2& x, const Vector2& m) const { return seen_from(sensor_position(x), x[2], m); }

void RangeBearingModel::predict_many(const Pose2& x, std::span<const Vector2> m, std::span<Vector2> z) const {
  const Vector2 sensor = sensor_position(x);
  for (std::size_t i = 0; i < m.size(); ++i) z[i] = seen_from(sensor, x[2], m[i]);
}

void RangeBearingModel::jacobians(const Pose2& x, const Vector2& m, Matrix23& hx, Matrix2& hm) const {
  const Vector2 d = m - sensor_position(x);
  const double q = d.squaredNorm(), r = std::sqrt(q);
  hm << d[0] / r, d[1] / r,  //
      -d[1] / q, d[0] / q;
  // The sensor position moves with the heading when it is mounted off the pose origin.
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  const Vector2 dp_dtheta(-p_.offset_x * s - p_.offset_y * c, p_.offset_x * c - p_.offset_y * s);
  hx.leftCols<2>() = -hm;
  hx.col(2) = -hm * dp_dtheta;
  hx(1, 2) -= 1.0;
}

Matrix2 RangeBearingModel::noise() const {
  return Vector2(p_.sigma_range * p_.sigma_range, p_.sigma_bearing * p_.sigma_bearing).asDiagonal();
}

Vector2 RangeBearingModel::residual(const Vector2& z, const Vector2& zhat) const {
  return Vector2(z[0] - zhat[0], wrap_angle(z[1] - zhat[1]));
}

Vector2 RangeBearingModel::inverse(const Pose2& x, const Vector2& z) const {
  const double a = x[2] + z[1];
  return sensor_position(x) + z[0] * Vector2(std::cos(a), std::sin(a));
}

void RangeBearingModel::inverse_jacobians(const Pose2& x, const Vector2& z, Matrix23& gx,
                                          Matrix2& gz) const {
  const double a = x[2] + z[1], ca = std::cos(a), sa = std::sin(a);
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  gx << 1.0, 0.0, -p_.offset_x * s - p_.offset_y * c - z[0] * sa,  //
      0.0, 1.0, p_.offset_x * c - p_.offset_y * s + z[0] * ca;
  gz << ca, -z[0] * sa,  //
      sa, z[0] * ca;
}

}  // namespace slamkit
