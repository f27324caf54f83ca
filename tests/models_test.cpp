// Angle wrapping and the known answers of the Ackermann, odometry and range-bearing models; what
// every model must satisfy (Jacobians, wrapping, noise) is tested over all of them in
// model_properties_test.cpp.
#include <gtest/gtest.h>

#include <cmath>

#include "slamkit/core/angles.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

using namespace slamkit;

TEST(AngleWrap, WrapsIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(wrap_angle(kPi), kPi);
  EXPECT_DOUBLE_EQ(wrap_angle(-kPi), kPi);
  EXPECT_NEAR(wrap_angle(3 * kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle(2 * kPi + 0.5), 0.5, 1e-12);
  EXPECT_NEAR(wrap_angle(-2 * kPi - 0.5), -0.5, 1e-12);
  EXPECT_NEAR(wrap_angle(1e6), std::remainder(1e6, 2 * kPi), 1e-6);
  for (double a = -20; a < 20; a += 0.37) {
    const double w = wrap_angle(a);
    EXPECT_GT(w, -kPi);
    EXPECT_LE(w, kPi);
    EXPECT_NEAR(std::sin(w), std::sin(a), 1e-9);
    EXPECT_NEAR(std::cos(w), std::cos(a), 1e-9);
  }
}

TEST(AckermannModel, KnownMotionStraightAndTurning) {
  const AckermannModel model;
  Control u(2);
  u << 3.0, 0.0;
  const Pose2 straight = model.predict(Pose2(1, 2, kPi / 2), u, 2.0);
  EXPECT_NEAR(straight[0], 1.0, 1e-12);
  EXPECT_NEAR(straight[1], 8.0, 1e-12);
  EXPECT_NEAR(straight[2], kPi / 2, 1e-12);
  u << 4.0, deg2rad(30);
  const Pose2 turn = model.predict(Pose2::Zero(), u, 0.5);
  EXPECT_NEAR(turn[2], 4.0 * 0.5 * std::sin(deg2rad(30)) / 4.0, 1e-12);
}

TEST(OdometryModel, BetweenInvertsPredict) {
  const OdometryModel model;
  const Pose2 from(1, 2, 3.0);
  const Pose2 to(-0.5, 2.7, -2.8);
  const Control u = OdometryModel::between(from, to);
  const Pose2 back = model.predict(from, u, 0.0);
  EXPECT_NEAR(back[0], to[0], 1e-12);
  EXPECT_NEAR(back[1], to[1], 1e-12);
  EXPECT_NEAR(wrap_angle(back[2] - to[2]), 0.0, 1e-12);
  // Noise grows with the motion and stays positive definite when stationary.
  const ControlCovariance still = model.control_noise(OdometryModel::between(from, from), 0.0);
  EXPECT_GT(still.diagonal().minCoeff(), 0.0);
  EXPECT_GT(model.control_noise(u, 0.0)(1, 1), still(1, 1));
}

TEST(RangeBearingModel, KnownMeasurementAndWrappedResidual) {
  const RangeBearingModel model;
  const Vector2 z = model.predict(Pose2(0, 0, kPi / 2), Vector2(0, -2));
  EXPECT_NEAR(z[0], 2.0, 1e-12);
  EXPECT_NEAR(std::abs(z[1]), kPi, 1e-12);
  const Vector2 r = model.residual(Vector2(1, kPi - 0.01), Vector2(1, -kPi + 0.01));
  EXPECT_NEAR(r[1], -0.02, 1e-12);
  EXPECT_DOUBLE_EQ(model.noise()(0, 0), 0.01);
}
