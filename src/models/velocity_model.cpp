#include "slamkit/models/velocity_model.hpp"

#include <algorithm>
#include <cmath>

#include "slamkit/core/angles.hpp"

namespace slamkit {

Pose2 VelocityModel::predict(const Pose2& x, const Control& u, double dt) const {
  const double v = u[0], w = u[1];
  const double a = x[2] + 0.5 * w * dt;
  return Pose2(x[0] + v * dt * std::cos(a), x[1] + v * dt * std::sin(a), wrap_angle(x[2] + w * dt));
}

Matrix3 VelocityModel::jacobian_state(const Pose2& x, const Control& u, double dt) const {
  const double v = u[0], a = x[2] + 0.5 * u[1] * dt;
  Matrix3 f = Matrix3::Identity();
  f(0, 2) = -v * dt * std::sin(a);
  f(1, 2) = v * dt * std::cos(a);
  return f;
}

ControlJacobian VelocityModel::jacobian_control(const Pose2& x, const Control& u, double dt) const {
  const double v = u[0], a = x[2] + 0.5 * u[1] * dt;
  const double c = std::cos(a), s = std::sin(a);
  ControlJacobian fu(3, 2);
  fu << dt * c, -0.5 * v * dt * dt * s,  //
      dt * s, 0.5 * v * dt * dt * c,     //
      0.0, dt;
  return fu;
}

ControlCovariance VelocityModel::control_noise(const Control&, double dt) const {
  const double span = std::max(dt, kMinDt);
  ControlCovariance m = ControlCovariance::Zero(2, 2);
  m(0, 0) = p_.q_v / span;
  m(1, 1) = p_.q_omega / span;
  return m;
}

}  // namespace slamkit
