#pragma once
// Motion model plug-in interface, eq. (6) of the tutorial: x_k = f(x_{k-1}, u_k) + w_k.
//
// The noise enters through the control: a model states the covariance M of its control noise, and the
// state-space process noise is Q = Fu M Fu^T. Filters are written once against this interface: the
// EKF uses f, Fx and Q; particle filters sample noisy controls and push them through f.
#include <memory>
#include <random>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

class MotionModel {
 public:
  virtual ~MotionModel() = default;

  virtual std::string name() const = 0;
  /// Number of entries of the control vector this model expects.
  virtual int control_dim() const = 0;

  /// f(x, u): the noise-free pose after applying control u for dt seconds. Heading wrapped.
  virtual Pose2 predict(const Pose2& x, const Control& u, double dt) const = 0;
  /// df/dx at (x, u).
  virtual Matrix3 jacobian_state(const Pose2& x, const Control& u, double dt) const = 0;
  /// df/du at (x, u).
  virtual ControlJacobian jacobian_control(const Pose2& x, const Control& u, double dt) const = 0;
  /// Covariance M of the noise on the control u.
  virtual ControlCovariance control_noise(const Control& u, double dt) const = 0;

  /// df/dx written through the poses it links, for the consistent EKF variants: every model here
  /// moves by a displacement fixed in the vehicle frame, rotated by the heading, so the Jacobian is
  /// [I  J (p_to - p_from); 0 1] with J the 90-degree rotation, whatever the control. Evaluated at
  /// (from, f(from, u)) it equals jacobian_state(from, u); first-estimates Jacobians evaluate it at
  /// other pose pairs, so that the products over a trajectory telescope.
  static Matrix3 jacobian_between(const Pose2& from, const Pose2& to) {
    Matrix3 f = Matrix3::Identity();
    f(0, 2) = -(to[1] - from[1]);
    f(1, 2) = to[0] - from[0];
    return f;
  }

  /// Q = Fu M Fu^T, the process noise of eq. (9).
  Matrix3 process_noise(const Pose2& x, const Control& u, double dt) const {
    const ControlJacobian fu = jacobian_control(x, u, dt);
    return fu * control_noise(u, dt) * fu.transpose();
  }

  /// Draws u' ~ N(u, M): the control a noisy actuator (or a particle's hypothesis) applies.
  Control sample_control(const Control& u, double dt, std::mt19937_64& rng) const;
};

/// Car-like vehicle driven by speed v [m/s] and steering angle gamma [rad], wheelbase L; the
/// kinematics of the tutorial's reference simulators: the vehicle moves along heading + gamma.
/// Control vector: (v, gamma).
class AckermannModel final : public MotionModel {
 public:
  struct Params {
    double wheelbase = 4.0;
    double sigma_speed = 0.3;             // m/s
    double sigma_steer = deg2rad(3.0);  // rad
  };
  AckermannModel() = default;
  explicit AckermannModel(const Params& p) : p_(p) {}

  std::string name() const override { return "ackermann"; }
  int control_dim() const override { return 2; }
  Pose2 predict(const Pose2& x, const Control& u, double dt) const override;
  Matrix3 jacobian_state(const Pose2& x, const Control& u, double dt) const override;
  ControlJacobian jacobian_control(const Pose2& x, const Control& u, double dt) const override;
  ControlCovariance control_noise(const Control& u, double dt) const override;

  const Params& params() const { return p_; }

 private:
  Params p_;
};

/// Odometry model (rot1, trans, rot2): turn by rot1, drive trans along the new heading, turn by
/// rot2. Noise grows with the motion itself (alpha1..alpha4 as in Probabilistic Robotics), plus a
/// small floor so a stationary robot still has a well-defined, positive-definite noise.
class OdometryModel final : public MotionModel {
 public:
  struct Params {
    double alpha_rot_rot = 0.01;     // rot variance per rad^2 of rotation
    double alpha_rot_trans = 0.001;  // rot variance per m^2 of translation
    double alpha_trans_trans = 0.01; // trans variance per m^2 of translation
    double alpha_trans_rot = 0.001;  // trans variance per rad^2 of rotation
    double min_variance = 1e-8;
  };
  OdometryModel() = default;
  explicit OdometryModel(const Params& p) : p_(p) {}

  std::string name() const override { return "odometry"; }
  int control_dim() const override { return 3; }
  Pose2 predict(const Pose2& x, const Control& u, double dt) const override;
  Matrix3 jacobian_state(const Pose2& x, const Control& u, double dt) const override;
  ControlJacobian jacobian_control(const Pose2& x, const Control& u, double dt) const override;
  ControlCovariance control_noise(const Control& u, double dt) const override;

  /// The (rot1, trans, rot2) that takes pose `from` to pose `to`: turns logged odometry poses into
  /// controls for this model.
  static Control between(const Pose2& from, const Pose2& to);

  const Params& params() const { return p_; }

 private:
  Params p_;
};

}  // namespace slamkit
