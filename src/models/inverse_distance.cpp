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
                                          PoseJacobian* hx, LandmarkJacobian* hp) const {
  const Vector2 sensor = model.sensor_position(x);
  const Vector2 u = direction(p[0]);
  // rho (m - s): the landmark's direction from the sensor, finite at rho = 0. The model sees the
  // point sensor + d, which lies in that direction, so it predicts the landmark's bearing.
  const Vector2 d = p[1] * (origin - sensor) + u;
  const Vector2 seen = sensor + d;
  if (hx || hp) {
    PoseJacobian hx_point;
    LandmarkJacobian hm;
    model.jacobians(x, seen, hx_point, hm);
    // The point seen moves with the vehicle by (1 - rho) ds/dx.
    if (hx) *hx = hx_point + (1.0 - p[1]) * hm * model.sensor_jacobian(x);
    if (hp) {
      Matrix2 dd;
      dd << perp(u), origin - sensor;
      *hp = hm * dd;
    }
  }
  return model.predict(x, seen);
}

double InverseDistancePoint::coupling_variance(const ObservationModel& model, const Pose2& x, const Vector2& p,
                                                const Matrix3& pose_covariance,
                                                const Eigen::RowVector3d& rho_pose_covariance,
                                                double rho_variance) const {
  const Vector2 sensor = model.sensor_position(x);
  PoseJacobian hx;
  LandmarkJacobian direction_rows;
  model.jacobians(x, sensor + direction(p[0]), hx, direction_rows);
  // h depends on the sensor through rho (origin - s): d2h / drho ds = -dh/dd at rho = 0.
  const Eigen::RowVector3d c = -direction_rows.row(model.rows().bearing) * model.sensor_jacobian(x);
  const double through_rho = c.dot(rho_pose_covariance);
  return rho_variance * c.dot(pose_covariance * c.transpose()) + through_rho * through_rho;
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

InitialLandmark inverse_distance_start(const ObservationModel& model, const Pose2& x, const Matrix3& pose_covariance,
                                       const Measurement& z, const InverseDistanceOptions& options, Vector2& origin) {
  const int bearing = model.rows().bearing;
  const double rho = options.prior_rho();
  const double rho_std = options.prior_rho_std();
  const double theta = wrap_angle(x[2] + z[bearing]);
  const Vector2 u = direction(theta);
  origin = model.sensor_position(x);
  // The landmark m = s(x) + u(heading + z) / rho expressed about the fixed origin: at the estimate
  // m - origin = u / rho, so dtheta/dm = rho perp(u)^T and drho/dm = -rho^2 u^T, and m moves with
  // the sensor and, by perp(u) / rho, with the heading.
  const Matrix23 sensor = model.sensor_jacobian(x);
  InitialLandmark start;
  start.mean = Vector2(theta, rho);
  start.gx.row(0) = rho * perp(u).transpose() * sensor;
  start.gx(0, 2) += 1.0;
  start.gx.row(1) = -rho * rho * u.transpose() * sensor;
  // The sensor's error e = s - origin moves theta by rho perp(u)^T e and rho by -rho^2 u^T e with the
  // landmark's true rho, not the prior's: gx carries the part at rho0, and the rest, a product of
  // rho's and the sensor's independent errors, is added as variance (the second-order term).
  const Matrix2 sensor_covariance = sensor * pose_covariance * sensor.transpose();
  const double across = perp(u).dot(sensor_covariance * perp(u)), along = u.dot(sensor_covariance * u);
  const double rho_variance = rho_std * rho_std;
  start.covariance << model.noise()(bearing, bearing) + rho_variance * across, 0.0, 0.0,
      rho_variance + 4.0 * rho * rho * rho_variance * along;
  return start;
}

}  // namespace slamkit
