#pragma once
// Linear-Gaussian motion and observation models, for tests that compare a filter with the Kalman
// filter it must equal when nothing is nonlinear.
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit::test_models {

/// x' = x + dt u with u = (vx, vy, omega), and a control noise that does not depend on the state.
class LinearMotion final : public MotionModel {
 public:
  explicit LinearMotion(const Matrix3& control_noise) : control_noise_(control_noise) {}
  std::string name() const override { return "linear"; }
  int control_dim() const override { return 3; }
  Pose2 predict(const Pose2& x, const Control& u, double dt) const override { return x + dt * u; }
  Matrix3 jacobian_state(const Pose2&, const Control&, double) const override { return Matrix3::Identity(); }
  ControlJacobian jacobian_control(const Pose2&, const Control&, double dt) const override {
    return dt * Matrix3::Identity();
  }
  ControlCovariance control_noise(const Control&, double) const override { return control_noise_; }

 private:
  Matrix3 control_noise_;
};

/// z = m - (x, y): the landmark's offset from the vehicle in world axes.
class LinearOffset final : public ObservationModel {
 public:
  std::string name() const override { return "offset"; }
  int dim() const override { return 2; }
  Measurement predict(const Pose2& x, const Vector2& m) const override { return m - x.head<2>(); }
  void jacobians(const Pose2&, const Vector2&, PoseJacobian& hx, LandmarkJacobian& hm) const override {
    hx.resize(2, 3);
    hx << -1, 0, 0, 0, -1, 0;
    hm = Matrix2::Identity();
  }
  MeasurementCovariance noise() const override { return (Matrix2() << 0.02, 0.005, 0.005, 0.03).finished(); }
  Measurement residual(const Measurement& z, const Measurement& zhat) const override { return z - zhat; }
  Vector2 sensor_position(const Pose2& x) const override { return x.head<2>(); }
  Matrix23 sensor_jacobian(const Pose2&) const override { return Matrix23::Identity(); }
  // The range-bearing sensor's, which the tests' clutter settings were written against.
  double measurement_volume(const SensorLimits& sensor) const override { return sensor.max_range * sensor.fov; }
  MeasurementShape shape(const Pose2& x, const Measurement& z, double) const override {
    return {x.head<2>(), x.head<2>() + z, 0.0};
  }
  MeasuredRows rows() const override { return {}; }
  bool invertible() const override { return true; }
  std::optional<InverseObservation> invert(const Pose2& x, const Measurement& z) const override {
    InverseObservation g;
    g.position = x.head<2>() + z;
    g.gx << 1, 0, 0, 0, 1, 0;
    g.gz = Matrix2::Identity();
    return g;
  }
};

}  // namespace slamkit::test_models
