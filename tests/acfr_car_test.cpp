// The ACFR car model: the kinematics against the exact circular motion of the rear axle that the
// model is derived from (its Jacobians: model_properties_test.cpp).
#include "slamkit/models/acfr_car.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <stdexcept>

#include "slamkit/core/angles.hpp"

using namespace slamkit;

namespace {

Control car_control(double speed, double steer) {
  Control u(2);
  u << speed, steer;
  return u;
}

// The rear-axle centre of the car whose laser is at pose x.
Eigen::Vector2d rear_axle(const AcfrCarModel::Params& p, const Pose2& x) {
  return x.head<2>() - Eigen::Rotation2Dd(x[2]) * Eigen::Vector2d(p.laser_forward, p.laser_left);
}

}  // namespace

TEST(AcfrCarModel, StraightDrivingMovesTheLaserAlongTheHeading) {
  const AcfrCarModel model;
  const Pose2 next = model.predict(Pose2(1, 2, kPi / 2), car_control(4.0, 0.0), 0.5);
  EXPECT_NEAR(next[0], 1.0, 1e-12);
  EXPECT_NEAR(next[1], 4.0, 1e-12);
  EXPECT_NEAR(next[2], kPi / 2, 1e-12);
}

TEST(AcfrCarModel, EncoderSpeedIsCorrectedToTheAxleCentre) {
  const AcfrCarModel model;
  const AcfrCarModel::Params& p = model.params();
  // Turning towards the encoder's side puts its wheel on the inside, slower than the axle centre.
  const double steer = 0.3;
  const double radius = p.wheelbase / std::tan(steer);  // of the axle centre
  EXPECT_NEAR(model.axle_speed(2.0, steer), 2.0 * radius / (radius - p.encoder_offset), 1e-12);
  EXPECT_GT(model.axle_speed(2.0, steer), 2.0);
  EXPECT_LT(model.axle_speed(2.0, -steer), 2.0);
  EXPECT_DOUBLE_EQ(model.axle_speed(2.0, 0.0), 2.0);
}

TEST(AcfrCarModel, SmallStepsFollowTheRearAxlesCircle) {
  const AcfrCarModel model;
  const AcfrCarModel::Params& p = model.params();
  const double speed = 3.0, steer = 0.25, dt = 1e-4;
  const int steps = 100000;  // 10 s
  Pose2 x(5.0, -1.0, 0.4);
  const Eigen::Vector2d start = rear_axle(p, x);
  for (int i = 0; i < steps; ++i) x = model.predict(x, car_control(speed, steer), dt);

  // The axle centre turns about a fixed centre at radius L / tan(steer), at rate v_c tan(steer) / L.
  const double radius = p.wheelbase / std::tan(steer);
  const double turned = model.axle_speed(speed, steer) * std::tan(steer) / p.wheelbase * dt * steps;
  const Eigen::Vector2d centre = start + radius * Eigen::Vector2d(-std::sin(0.4), std::cos(0.4));
  const Eigen::Vector2d expected = centre + Eigen::Rotation2Dd(turned) * (start - centre);
  EXPECT_NEAR(wrap_angle(x[2] - (0.4 + turned)), 0.0, 1e-9);
  EXPECT_LT((rear_axle(p, x) - expected).norm(), 1e-3);
}

TEST(AcfrCarModel, ControlNoiseIsConstantAndDiagonal) {
  AcfrCarModel::Params p;
  p.sigma_speed = 0.5;
  p.sigma_steer = deg2rad(2.0);
  const AcfrCarModel model(p);
  const ControlCovariance m = model.control_noise(car_control(3.0, 0.1), 0.025);
  ASSERT_EQ(m.rows(), 2);
  EXPECT_DOUBLE_EQ(m(0, 0), 0.25);
  EXPECT_DOUBLE_EQ(m(1, 1), deg2rad(2.0) * deg2rad(2.0));
  EXPECT_DOUBLE_EQ(m(0, 1), 0.0);
  EXPECT_EQ(model.control_dim(), 2);
  EXPECT_EQ(model.name(), "acfr-car");
}

TEST(AcfrCarModel, RejectsInvalidParameters) {
  AcfrCarModel::Params p;
  p.wheelbase = 0.0;
  EXPECT_THROW(AcfrCarModel{p}, std::invalid_argument);
  p = {};
  p.sigma_steer = -1.0;
  EXPECT_THROW(AcfrCarModel{p}, std::invalid_argument);
}
