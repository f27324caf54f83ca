#pragma once
// Unicycle driven by commanded velocities: forward speed v [m/s] and turn rate omega [rad/s], held for
// dt seconds. Control vector: (v, omega). This is what differential-drive robots log when they log
// their commands (e.g. the MRCLAM dataset) rather than wheel odometry.
#include <string>

#include "slamkit/models/motion_model.hpp"

namespace slamkit {

/// Motion by midpoint integration of the unicycle over dt:
///
///   x' = x + v dt cos(theta + omega dt / 2)
///   y' = y + v dt sin(theta + omega dt / 2)
///   theta' = theta + omega dt
///
/// The exact arc is (v / omega)(sin(theta + omega dt) - sin theta), which is singular as omega -> 0
/// and needs a separate straight-line branch with its own Jacobians; the midpoint rule is smooth
/// everywhere. It moves along the arc's chord, in exactly the chord's direction, and overshoots the
/// chord's length by v dt (omega dt)^2 / 24: 1.5 um for v = 0.1 m/s, omega = 0.6 rad/s, dt = 0.1 s,
/// orders of magnitude below any real robot's slip.
///
/// Noise: the true velocities are the commanded ones plus white noise of spectral density q_v and
/// q_omega. Averaged over a step of dt seconds that noise has variance q / dt, so
///
///   M = diag(q_v / dt, q_omega / dt)
///
/// and the state noise Q = Fu M Fu^T is about dt * q: the pose uncertainty grows linearly with time
/// whatever the control rate, and splitting a step into two shorter ones adds the same noise as the
/// step itself. A per-step constant sigma would instead make the noise depend on how often the robot
/// happened to log. For dt below kMinDt the variance is taken at kMinDt: Q still goes to zero (as
/// dt^2 / kMinDt), and M stays finite for filters that sample controls.
class VelocityModel final : public MotionModel {
 public:
  struct Params {
    double q_v = 1e-4;      // m^2/s: after t seconds the along-track position std is sqrt(q_v t)
    double q_omega = 1e-3;  // rad^2/s: after t seconds the heading std is sqrt(q_omega t)
  };
  static constexpr double kMinDt = 1e-6;  // s

  VelocityModel() = default;
  explicit VelocityModel(const Params& p) : p_(p) {}

  std::string name() const override { return "velocity"; }
  int control_dim() const override { return 2; }
  Pose2 predict(const Pose2& x, const Control& u, double dt) const override;
  Matrix3 jacobian_state(const Pose2& x, const Control& u, double dt) const override;
  ControlJacobian jacobian_control(const Pose2& x, const Control& u, double dt) const override;
  ControlCovariance control_noise(const Control& u, double dt) const override;

  const Params& params() const { return p_; }

 private:
  Params p_;
};

}  // namespace slamkit
