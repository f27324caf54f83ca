// The velocity (unicycle) motion model: known motions, and the noise scaling that makes the pose
// uncertainty independent of the control rate (its Jacobians: model_properties_test.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/models/velocity_model.hpp"

using namespace slamkit;

namespace {

Control velocity_control(double v, double omega) {
  Control u(2);
  u << v, omega;
  return u;
}

}  // namespace

TEST(VelocityModel, KnownMotions) {
  const VelocityModel model;
  const Pose2 straight = model.predict(Pose2(1, 2, kPi / 2), velocity_control(0.5, 0.0), 4.0);
  EXPECT_NEAR(straight[0], 1.0, 1e-12);
  EXPECT_NEAR(straight[1], 4.0, 1e-12);
  EXPECT_NEAR(straight[2], kPi / 2, 1e-12);

  const Pose2 spin = model.predict(Pose2(1, 2, 3.0), velocity_control(0.0, 0.5), 1.0);
  EXPECT_NEAR(spin[0], 1.0, 1e-12);
  EXPECT_NEAR(spin[1], 2.0, 1e-12);
  EXPECT_NEAR(spin[2], wrap_angle(3.5), 1e-12);

  // One step moves along the arc's chord, overshooting its length by v dt (omega dt)^2 / 24.
  const double v = 0.1, w = 0.6, dt = 0.1;
  const Pose2 step = model.predict(Pose2::Zero(), velocity_control(v, w), dt);
  const Vector2 arc_end((v / w) * std::sin(w * dt), (v / w) * (1 - std::cos(w * dt)));
  EXPECT_NEAR((step.head<2>() - arc_end).norm(), v * dt * std::pow(w * dt, 2) / 24, 1e-9);
  EXPECT_NEAR(std::atan2(step[1], step[0]), std::atan2(arc_end[1], arc_end[0]), 1e-12);

  // A full circle at 67 Hz closes on itself to well under a millimetre.
  Pose2 x = Pose2::Zero();
  const double period = 2 * kPi / 0.4;
  const int steps = static_cast<int>(std::round(period * 67));
  for (int i = 0; i < steps; ++i) x = model.predict(x, velocity_control(0.086, 0.4), period / steps);
  EXPECT_LT(x.head<2>().norm(), 1e-4);
  EXPECT_NEAR(wrap_angle(x[2]), 0.0, 1e-9);
}

TEST(VelocityModel, NoiseGrowsLinearlyWithTimeWhateverTheRate) {
  const VelocityModel model({.q_v = 2e-4, .q_omega = 3e-3});
  const Pose2 x(0.5, -1.0, 0.3);
  // Standing still the process noise is exactly dt times the densities, at any dt.
  for (const double dt : {0.001, 0.015, 0.2, 3.0}) {
    const Matrix3 q = model.process_noise(x, velocity_control(0.0, 0.0), dt) / dt;
    EXPECT_NEAR(q(0, 0), 2e-4 * std::cos(0.3) * std::cos(0.3), 1e-15);
    EXPECT_NEAR(q(2, 2), 3e-3, 1e-15);
  }
  // Moving, ten steps at 100 Hz and one step of 0.1 s accumulate about the same covariance.
  const Control u = velocity_control(0.086, 0.4);
  Pose2 fine = x;
  Matrix3 p_fine = Matrix3::Zero();
  for (int i = 0; i < 10; ++i) {
    const Matrix3 f = model.jacobian_state(fine, u, 0.01);
    p_fine = f * p_fine * f.transpose() + model.process_noise(fine, u, 0.01);
    fine = model.predict(fine, u, 0.01);
  }
  const Matrix3 p_coarse = model.process_noise(x, u, 0.1);
  EXPECT_LT((p_fine - p_coarse).norm(), 0.02 * p_coarse.norm()) << p_fine << "\n" << p_coarse;
}

TEST(VelocityModel, VanishingTimeStepIsGuarded) {
  const VelocityModel model;
  const Control u = velocity_control(0.086, 0.4);
  for (const double dt : {0.0, 1e-12}) {
    const ControlCovariance m = model.control_noise(u, dt);
    EXPECT_TRUE(m.allFinite());
    EXPECT_DOUBLE_EQ(m(0, 0), model.params().q_v / VelocityModel::kMinDt);
    EXPECT_LT(model.process_noise(Pose2(1, 2, 0.5), u, dt).norm(), 1e-12);
    EXPECT_LT((model.predict(Pose2(1, 2, 0.5), u, dt) - Pose2(1, 2, 0.5)).norm(), 1e-11);
  }
}
