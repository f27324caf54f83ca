#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>

#include "slamkit/core/angles.hpp"
#include "slamkit/models/motion_model.hpp"

namespace slamkit {

Control MotionModel::sample_control(const Control& u, double dt, std::mt19937_64& rng) const {
  const ControlCovariance m = control_noise(u, dt);
  // LDLT tolerates a zero variance (a noise-free control entry) where LLT would fail.
  const Eigen::LDLT<ControlCovariance> ldlt(m);
  std::normal_distribution<double> normal(0.0, 1.0);
  Control e(u.size());
  for (int i = 0; i < e.size(); ++i) e[i] = normal(rng);
  const Control d = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt();
  Control scaled = d.cwiseProduct(e);
  // M = P^T L D L^T P, so a sample is P^T L sqrt(D) e.
  Control correlated = ldlt.matrixL() * scaled;
  return u + ldlt.transpositionsP().transpose() * correlated;
}

// ---- Ackermann ------------------------------------------------------------------------------------

Pose2 AckermannModel::predict(const Pose2& x, const Control& u, double dt) const {
  const double v = u[0], g = u[1];
  const double a = x[2] + g;
  return Pose2(x[0] + v * dt * std::cos(a), x[1] + v * dt * std::sin(a),
               wrap_angle(x[2] + v * dt * std::sin(g) / p_.wheelbase));
}

Matrix3 AckermannModel::jacobian_state(const Pose2& x, const Control& u, double dt) const {
  const double v = u[0], a = x[2] + u[1];
  Matrix3 f = Matrix3::Identity();
  f(0, 2) = -v * dt * std::sin(a);
  f(1, 2) = v * dt * std::cos(a);
  return f;
}

ControlJacobian AckermannModel::jacobian_control(const Pose2& x, const Control& u, double dt) const {
  const double v = u[0], g = u[1], a = x[2] + g;
  ControlJacobian fu(3, 2);
  fu << dt * std::cos(a), -v * dt * std::sin(a),  //
      dt * std::sin(a), v * dt * std::cos(a),     //
      dt * std::sin(g) / p_.wheelbase, v * dt * std::cos(g) / p_.wheelbase;
  return fu;
}

ControlCovariance AckermannModel::control_noise(const Control&, double) const {
  ControlCovariance m = ControlCovariance::Zero(2, 2);
  m(0, 0) = p_.sigma_speed * p_.sigma_speed;
  m(1, 1) = p_.sigma_steer * p_.sigma_steer;
  return m;
}

// ---- Odometry (rot1, trans, rot2) ----------------------------------------------------------------

Pose2 OdometryModel::predict(const Pose2& x, const Control& u, double) const {
  const double a = x[2] + u[0];
  return Pose2(x[0] + u[1] * std::cos(a), x[1] + u[1] * std::sin(a), wrap_angle(a + u[2]));
}

Matrix3 OdometryModel::jacobian_state(const Pose2& x, const Control& u, double) const {
  const double a = x[2] + u[0];
  Matrix3 f = Matrix3::Identity();
  f(0, 2) = -u[1] * std::sin(a);
  f(1, 2) = u[1] * std::cos(a);
  return f;
}

ControlJacobian OdometryModel::jacobian_control(const Pose2& x, const Control& u, double) const {
  const double a = x[2] + u[0];
  ControlJacobian fu(3, 3);
  fu << -u[1] * std::sin(a), std::cos(a), 0.0,  //
      u[1] * std::cos(a), std::sin(a), 0.0,     //
      1.0, 0.0, 1.0;
  return fu;
}

ControlCovariance OdometryModel::control_noise(const Control& u, double) const {
  const double r1 = u[0] * u[0], t = u[1] * u[1], r2 = u[2] * u[2];
  ControlCovariance m = ControlCovariance::Zero(3, 3);
  m(0, 0) = p_.alpha_rot_rot * r1 + p_.alpha_rot_trans * t + p_.min_variance;
  m(1, 1) = p_.alpha_trans_trans * t + p_.alpha_trans_rot * (r1 + r2) + p_.min_variance;
  m(2, 2) = p_.alpha_rot_rot * r2 + p_.alpha_rot_trans * t + p_.min_variance;
  return m;
}

Control OdometryModel::between(const Pose2& from, const Pose2& to) {
  const double dx = to[0] - from[0], dy = to[1] - from[1];
  const double trans = std::hypot(dx, dy);
  // Below a millimetre the direction of travel is noise; treat the motion as a turn on the spot.
  const double rot1 = trans < 1e-3 ? 0.0 : wrap_angle(std::atan2(dy, dx) - from[2]);
  Control u(3);
  u << rot1, trans, wrap_angle(to[2] - from[2] - rot1);
  return u;
}

}  // namespace slamkit
