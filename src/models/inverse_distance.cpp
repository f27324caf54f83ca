#include "slamkit/models/inverse_distance.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace slamkit {

namespace {

Vector2 direction(double theta) { return Vector2(std::cos(theta), std::sin(theta)); }
Vector2 perp(const Vector2& v) { return Vector2(-v[1], v[0]); }

}  // namespace

void validate(const InverseDistanceOptions& options) {
  if (!(options.min_distance_m > 0.0 && options.prior_distance_m > options.min_distance_m &&
        std::isfinite(options.prior_distance_m)))
  {
    std::ostringstream message;
    message << "the inverse-distance start needs 0 < min_distance_m < prior_distance_m, both finite; found "
            << options.min_distance_m << " and " << options.prior_distance_m;
    throw std::invalid_argument(message.str());
  }
}

void require_bearing_only(const ObservationModel& model, const std::string& what) {
  const MeasuredRows rows = model.rows();
  if (rows.bearing < 0 || rows.range >= 0 || model.dim() != 1)
    throw std::invalid_argument(what + " is for a bearing-only sensor; a " + model.name() +
                                " measurement places or constrains a landmark's distance itself");
}

Vector2 InverseDistancePoint::position(const Vector2& p) const {
  return origin + direction(p[0]) / std::max(p[1], kSmallestRho);
}

Matrix2 InverseDistancePoint::position_jacobian(const Vector2& p) const {
  const double rho = std::max(p[1], kSmallestRho);
  const Vector2 u = direction(p[0]);
  Matrix2 g;
  g << perp(u) / rho, -u / (rho * rho);
  return g;
}

Measurement InverseDistancePoint::predict(const ObservationModel& model, const Pose2& x, const Vector2& p,
                                          PoseJacobian* hx, LandmarkJacobian* hp, LandmarkJacobian* horigin) const {
  const Vector2 sensor = model.sensor_position(x);
  const Vector2 u = direction(p[0]);
  // rho (m - s): the landmark's direction from the sensor, finite at rho = 0. The model sees the
  // point sensor + d, which lies in that direction, so it predicts the landmark's bearing.
  const Vector2 d = p[1] * (origin - sensor) + u;
  const Vector2 seen = sensor + d;
  if (hx || hp || horigin) {
    PoseJacobian hx_point;
    LandmarkJacobian hm;
    model.jacobians(x, seen, hx_point, hm);
    // The point seen moves with the vehicle by (1 - rho) ds/dx, and with the origin by rho.
    if (hx) *hx = hx_point + (1.0 - p[1]) * hm * model.sensor_jacobian(x);
    if (hp) {
      Matrix2 dd;
      dd << perp(u), origin - sensor;
      *hp = hm * dd;
    }
    if (horigin) *horigin = p[1] * hm;
  }
  return model.predict(x, seen);
}

double InverseDistancePoint::linearity(const ObservationModel& model, const Pose2& x, const Vector2& p,
                                       double rho_variance) const {
  if (!(p[1] > 0.0)) return std::numeric_limits<double>::infinity();
  const Vector2 ray = position(p) - model.sensor_position(x);
  const double distance = ray.norm();
  const double distance_std = std::sqrt(std::max(rho_variance, 0.0)) / (p[1] * p[1]);
  const double cos_parallax = direction(p[0]).dot(ray) / distance;
  return 4.0 * distance_std / distance * std::abs(cos_parallax);
}

double InverseDistancePoint::bearing_spread(const ObservationModel& model, const Pose2& x, const Vector2& p,
                                            double rho_variance) const {
  const double across = perp(direction(p[0])).dot(origin - model.sensor_position(x));
  return 2.0 * std::sqrt(std::max(rho_variance, 0.0)) * std::abs(across);
}

InverseDistanceStart inverse_distance_start(const ObservationModel& model, const Pose2& x, const Measurement& z,
                                            const InverseDistanceOptions& options) {
  const int bearing = model.rows().bearing;
  InverseDistanceStart start;
  start.parameters.mean = Vector2(wrap_angle(x[2] + z[bearing]), options.prior_rho());
  start.parameters.gx.setZero();
  start.parameters.gx(0, 2) = 1.0;
  const double rho_std = options.prior_rho_std();
  start.parameters.covariance << model.noise()(bearing, bearing), 0.0, 0.0, rho_std * rho_std;
  start.origin = model.sensor_position(x);
  start.origin_gx = model.sensor_jacobian(x);
  return start;
}

}  // namespace slamkit
