#include <cmath>
#include <stdexcept>

#include "slamkit/core/angles.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

Vector2 SensorMount::position(const Pose2& x) const {
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  return Vector2(x[0] + offset_x * c - offset_y * s, x[1] + offset_x * s + offset_y * c);
}

Vector2 SensorMount::turn_derivative(const Pose2& x) const {
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  return Vector2(-offset_x * s - offset_y * c, offset_x * c - offset_y * s);
}

Matrix23 SensorMount::jacobian(const Pose2& x) const {
  Matrix23 j;
  j << Matrix2::Identity(), turn_derivative(x);
  return j;
}

namespace {

// Range and bearing of m from a sensor at `sensor` on a vehicle heading `heading`.
Measurement seen_from(const Vector2& sensor, double heading, const Vector2& m) {
  const Vector2 d = m - sensor;
  Measurement z(2);
  z << d.norm(), wrap_angle(std::atan2(d[1], d[0]) - heading);
  return z;
}

// d range / d m and d bearing / d m of landmark m seen from `sensor`: the rows of the range-bearing
// Jacobian, of which the other models keep one. The pose's columns follow from them, since moving
// the sensor moves the landmark the other way, and turning it turns the bearing back.
void landmark_rows(const Vector2& sensor, const Vector2& m, Matrix2& hm) {
  const Vector2 d = m - sensor;
  const double q = d.squaredNorm(), r = std::sqrt(q);
  hm << d[0] / r, d[1] / r,  //
      -d[1] / q, d[0] / q;
}

MeasurementCovariance variance(double sigma) {
  MeasurementCovariance r(1, 1);
  r(0, 0) = sigma * sigma;
  return r;
}

}  // namespace

void validate(const RangeCalibrationPrior& prior, const ObservationModel& model) {
  if (model.rows().range < 0)
    throw std::invalid_argument("a range calibration needs a sensor that measures range; a " + model.name() +
                                " measurement does not");
  const auto deviation = [](double std) { return std > 0.0 && std::isfinite(std); };
  if (!std::isfinite(prior.offset_m) || !deviation(prior.offset_std_m) ||
      !(prior.scale_error > -0.5 && prior.scale_error < 0.5) || !deviation(prior.scale_error_std))
    throw std::invalid_argument("the range calibration's prior needs a finite offset, a scale error between -0.5 and "
                                "0.5, and positive, finite standard deviations");
}

std::optional<InitialLandmark> inverted_landmark(const ObservationModel& model, const Pose2& x, const Measurement& z) {
  const std::optional<InverseObservation> g = model.invert(x, z);
  if (!g) return std::nullopt;
  return with_measurement_dim(model.dim(), [&]<int D>(std::integral_constant<int, D>) {
    // Fixed-size products, as the filters' kernels: the same bits whatever the caller.
    const Eigen::Matrix<double, 2, D> gz = g->gz;
    const Eigen::Matrix<double, D, D> r = model.noise();
    const int range = model.rows().range;
    InitialLandmark landmark{g->position, g->gx, gz * r * gz.transpose()};
    if (range >= 0) {
      landmark.range_gain = gz.col(range);
      landmark.range_scale_gain = z[range] * landmark.range_gain;
    }
    return landmark;
  });
}

Measurement RangeBearingModel::predict(const Pose2& x, const Vector2& m) const {
  return seen_from(sensor_position(x), x[2], m);
}

void RangeBearingModel::predict_many(const Pose2& x, std::span<const Vector2> m, std::span<Measurement> z) const {
  const Vector2 sensor = sensor_position(x);
  for (std::size_t i = 0; i < m.size(); ++i) z[i] = seen_from(sensor, x[2], m[i]);
}

void RangeBearingModel::jacobians(const Pose2& x, const Vector2& m, PoseJacobian& hx, LandmarkJacobian& hm) const {
  Matrix2 rows;
  landmark_rows(sensor_position(x), m, rows);
  hm = rows;
  hx.resize(2, 3);
  hx.leftCols<2>() = -rows;
  // The sensor position moves with the heading when it is mounted off the pose origin.
  hx.col(2) = -rows * mount_.turn_derivative(x);
  hx(1, 2) -= 1.0;
}

MeasurementCovariance RangeBearingModel::noise() const {
  return Vector2(p_.sigma_range * p_.sigma_range, p_.sigma_bearing * p_.sigma_bearing).asDiagonal();
}

Measurement RangeBearingModel::residual(const Measurement& z, const Measurement& zhat) const {
  Measurement nu(2);
  nu << z[0] - zhat[0], wrap_angle(z[1] - zhat[1]);
  return nu;
}

double RangeBearingModel::measurement_volume(const SensorLimits& sensor) const {
  return sensor.max_range * sensor.fov;
}

std::optional<InverseObservation> RangeBearingModel::invert(const Pose2& x, const Measurement& z) const {
  const double a = x[2] + z[1], ca = std::cos(a), sa = std::sin(a);
  const Vector2 turn = mount_.turn_derivative(x);
  InverseObservation g;
  g.position = sensor_position(x) + z[0] * Vector2(ca, sa);
  g.gx << 1.0, 0.0, turn[0] - z[0] * sa,  //
      0.0, 1.0, turn[1] + z[0] * ca;
  g.gz.resize(2, 2);
  g.gz << ca, -z[0] * sa,  //
      sa, z[0] * ca;
  return g;
}

MeasurementShape RangeBearingModel::shape(const Pose2& x, const Measurement& z, double) const {
  return {sensor_position(x), invert(x, z)->position, 0.0};
}

Measurement RangeOnlyModel::predict(const Pose2& x, const Vector2& m) const {
  return Measurement::Constant(1, (m - sensor_position(x)).norm());
}

void RangeOnlyModel::jacobians(const Pose2& x, const Vector2& m, PoseJacobian& hx, LandmarkJacobian& hm) const {
  const Vector2 d = m - sensor_position(x);
  const Eigen::RowVector2d along = d.transpose() / d.norm();
  hm = along;
  hx.resize(1, 3);
  hx.leftCols<2>() = -along;
  hx(0, 2) = -along.dot(mount_.turn_derivative(x));
}

MeasurementCovariance RangeOnlyModel::noise() const { return variance(p_.sigma_range); }

MeasurementShape RangeOnlyModel::shape(const Pose2& x, const Measurement& z, double) const {
  const Vector2 sensor = sensor_position(x);
  return {sensor, sensor, z[0]};
}

Measurement BearingOnlyModel::predict(const Pose2& x, const Vector2& m) const {
  const Vector2 d = m - sensor_position(x);
  return Measurement::Constant(1, wrap_angle(std::atan2(d[1], d[0]) - x[2]));
}

void BearingOnlyModel::jacobians(const Pose2& x, const Vector2& m, PoseJacobian& hx, LandmarkJacobian& hm) const {
  const Vector2 d = m - sensor_position(x);
  const double q = d.squaredNorm();
  const Eigen::RowVector2d across(-d[1] / q, d[0] / q);
  hm = across;
  hx.resize(1, 3);
  hx.leftCols<2>() = -across;
  hx(0, 2) = -across.dot(mount_.turn_derivative(x)) - 1.0;
}

MeasurementCovariance BearingOnlyModel::noise() const { return variance(p_.sigma_bearing); }

MeasurementShape BearingOnlyModel::shape(const Pose2& x, const Measurement& z, double reach) const {
  const Vector2 sensor = sensor_position(x);
  const double a = x[2] + z[0];
  return {sensor, sensor + reach * Vector2(std::cos(a), std::sin(a)), 0.0};
}

Measurement BearingOnlyModel::residual(const Measurement& z, const Measurement& zhat) const {
  return Measurement::Constant(1, wrap_angle(z[0] - zhat[0]));
}

}  // namespace slamkit
