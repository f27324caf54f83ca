#include "slamkit/models/acfr_car.hpp"

#include <cmath>
#include <stdexcept>

namespace slamkit {

AcfrCarModel::AcfrCarModel(const Params& params) : p_(params) {
  if (!(p_.wheelbase > 0.0)) throw std::invalid_argument("AcfrCarModel: the wheelbase must be > 0");
  if (!(p_.sigma_speed >= 0.0) || !(p_.sigma_steer >= 0.0))
    throw std::invalid_argument("AcfrCarModel: the control noise must be >= 0");
}

double AcfrCarModel::axle_speed(double encoder_speed, double steer) const {
  return encoder_speed / (1.0 - std::tan(steer) * p_.encoder_offset / p_.wheelbase);
}

Pose2 AcfrCarModel::predict(const Pose2& x, const Control& u, double dt) const {
  const double v = axle_speed(u[0], u[1]);
  const double w = v * std::tan(u[1]) / p_.wheelbase;
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  const double a = p_.laser_forward, b = p_.laser_left;
  return Pose2(x[0] + dt * (v * c - w * (a * s + b * c)), x[1] + dt * (v * s + w * (a * c - b * s)),
               wrap_angle(x[2] + dt * w));
}

Matrix3 AcfrCarModel::jacobian_state(const Pose2& x, const Control& u, double dt) const {
  const double v = axle_speed(u[0], u[1]);
  const double w = v * std::tan(u[1]) / p_.wheelbase;
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  const double a = p_.laser_forward, b = p_.laser_left;
  Matrix3 f = Matrix3::Identity();
  f(0, 2) = -dt * (v * s + w * (a * c - b * s));
  f(1, 2) = dt * (v * c - w * (a * s + b * c));
  return f;
}

ControlJacobian AcfrCarModel::jacobian_control(const Pose2& x, const Control& u, double dt) const {
  const double t = std::tan(u[1]);
  const double sec2 = 1.0 + t * t;  // d tan(alpha) / d alpha
  const double hl = p_.encoder_offset / p_.wheelbase;
  const double k = 1.0 / (1.0 - t * hl);  // v_c = k v_e
  const double v = k * u[0];
  // Derivatives of v_c and of the turn rate w = v_c t / L with respect to v_e and alpha.
  const double dv_dve = k, dv_dalpha = u[0] * k * k * hl * sec2;
  const double dw_dve = dv_dve * t / p_.wheelbase;
  const double dw_dalpha = (dv_dalpha * t + v * sec2) / p_.wheelbase;
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  const double a = p_.laser_forward, b = p_.laser_left;
  const double lx = -(a * s + b * c), ly = a * c - b * s;  // the laser's sideways sweep per unit w
  ControlJacobian fu(3, 2);
  fu << dt * (dv_dve * c + dw_dve * lx), dt * (dv_dalpha * c + dw_dalpha * lx),  //
      dt * (dv_dve * s + dw_dve * ly), dt * (dv_dalpha * s + dw_dalpha * ly),    //
      dt * dw_dve, dt * dw_dalpha;
  return fu;
}

ControlCovariance AcfrCarModel::control_noise(const Control&, double) const {
  ControlCovariance m = ControlCovariance::Zero(2, 2);
  m(0, 0) = p_.sigma_speed * p_.sigma_speed;
  m(1, 1) = p_.sigma_steer * p_.sigma_steer;
  return m;
}

}  // namespace slamkit
