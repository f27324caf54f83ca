// Every analytic Jacobian of the model plug-ins against central differences, plus the known-answer
// behaviour of each model.
#include <gtest/gtest.h>

#include "test_data.hpp"

#include <functional>
#include <random>

#include "slamkit/core/angles.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

using namespace slamkit;

namespace {

using test_data::numeric_jacobian;

std::vector<Pose2> sample_poses() {
  return {Pose2(0, 0, 0), Pose2(1.5, -2.0, 0.7), Pose2(-3, 4, -2.9), Pose2(10, 2, kPi - 1e-3)};
}

}  // namespace

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

TEST(AckermannModel, JacobiansMatchNumericDifferentiation) {
  const AckermannModel model;
  for (const Pose2& x : sample_poses()) {
    for (const double steer : {-0.5, 0.0, 0.3}) {
      Control u(2);
      u << 2.7, steer;
      const double dt = 0.025;
      const auto fx = numeric_jacobian<3>(
          [&](const Eigen::VectorXd& s) { return model.predict(s, u, dt); }, x, {2});
      const auto fu = numeric_jacobian<3>(
          [&](const Eigen::VectorXd& c) { return model.predict(x, Control(c), dt); }, u, {2});
      EXPECT_TRUE(model.jacobian_state(x, u, dt).isApprox(fx, 1e-6)) << model.jacobian_state(x, u, dt) << "\n" << fx;
      EXPECT_LT((Eigen::MatrixXd(model.jacobian_control(x, u, dt)) - fu).norm(), 1e-8);
    }
  }
}

TEST(OdometryModel, JacobiansMatchNumericDifferentiation) {
  const OdometryModel model;
  for (const Pose2& x : sample_poses()) {
    Control u(3);
    u << 0.2, 0.8, -0.4;
    const auto fx = numeric_jacobian<3>([&](const Eigen::VectorXd& s) { return model.predict(s, u, 0.1); }, x, {2});
    const auto fu =
        numeric_jacobian<3>([&](const Eigen::VectorXd& c) { return model.predict(x, Control(c), 0.1); }, u, {2});
    EXPECT_LT((Eigen::MatrixXd(model.jacobian_state(x, u, 0.1)) - fx).norm(), 1e-8);
    EXPECT_LT((Eigen::MatrixXd(model.jacobian_control(x, u, 0.1)) - fu).norm(), 1e-8);
  }
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

TEST(MotionModel, SampledControlsHaveTheModelledCovariance) {
  const AckermannModel model;
  std::mt19937_64 rng(7);
  Control u(2);
  u << 3.0, 0.1;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero(), sq = Eigen::Vector2d::Zero();
  const int n = 40000;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d d = model.sample_control(u, 0.025, rng) - u;
    sum += d;
    sq += d.cwiseProduct(d);
  }
  const Eigen::Vector2d sd = (sq / n).cwiseSqrt();
  EXPECT_NEAR(sd[0], 0.3, 0.3 * 0.02);
  EXPECT_NEAR(sd[1], deg2rad(3), deg2rad(3) * 0.02);
  EXPECT_LT(std::abs(sum[0] / n), 0.01);
}

class RangeBearingTest : public ::testing::TestWithParam<RangeBearingModel::Params> {};

TEST_P(RangeBearingTest, JacobiansMatchNumericDifferentiation) {
  const RangeBearingModel model(GetParam());
  const std::vector<Vector2> landmarks = {Vector2(5, 1), Vector2(-3, -7), Vector2(0.5, 12), Vector2(-20, 0.1)};
  for (const Pose2& x : sample_poses()) {
    for (const Vector2& m : landmarks) {
      Matrix23 hx;
      Matrix2 hm;
      model.jacobians(x, m, hx, hm);
      const auto nx = numeric_jacobian<2>([&](const Eigen::VectorXd& s) { return model.predict(s, m); }, x, {1});
      const auto nm = numeric_jacobian<2>([&](const Eigen::VectorXd& l) { return model.predict(x, l); }, m, {1});
      EXPECT_LT((Eigen::MatrixXd(hx) - nx).norm(), 1e-6) << hx << "\n" << nx;
      EXPECT_LT((Eigen::MatrixXd(hm) - nm).norm(), 1e-6);

      const Vector2 z = model.predict(x, m);
      Matrix23 gx;
      Matrix2 gz;
      model.inverse_jacobians(x, z, gx, gz);
      const auto ngx = numeric_jacobian<2>([&](const Eigen::VectorXd& s) { return model.inverse(s, z); }, x, {});
      const auto ngz = numeric_jacobian<2>([&](const Eigen::VectorXd& c) { return model.inverse(x, c); }, z, {});
      EXPECT_LT((Eigen::MatrixXd(gx) - ngx).norm(), 1e-6);
      EXPECT_LT((Eigen::MatrixXd(gz) - ngz).norm(), 1e-6);
    }
  }
}

TEST_P(RangeBearingTest, InverseRecoversTheLandmark) {
  const RangeBearingModel model(GetParam());
  for (const Pose2& x : sample_poses()) {
    const Vector2 m(3.0, -4.0);
    const Vector2 z = model.predict(x, m);
    EXPECT_GT(z[1], -kPi);
    EXPECT_LE(z[1], kPi);
    EXPECT_LT((model.inverse(x, z) - m).norm(), 1e-10);
  }
}

INSTANTIATE_TEST_SUITE_P(Mounts, RangeBearingTest,
                         ::testing::Values(RangeBearingModel::Params{},
                                           RangeBearingModel::Params{0.2, 0.01, 3.78, 0.5}),
                         [](const auto& info) { return info.index == 0 ? "SensorAtOrigin" : "SensorOffset"; });

TEST(RangeBearingModel, KnownMeasurementAndWrappedResidual) {
  const RangeBearingModel model;
  const Vector2 z = model.predict(Pose2(0, 0, kPi / 2), Vector2(0, -2));
  EXPECT_NEAR(z[0], 2.0, 1e-12);
  EXPECT_NEAR(std::abs(z[1]), kPi, 1e-12);
  const Vector2 r = model.residual(Vector2(1, kPi - 0.01), Vector2(1, -kPi + 0.01));
  EXPECT_NEAR(r[1], -0.02, 1e-12);
  EXPECT_DOUBLE_EQ(model.noise()(0, 0), 0.01);
}
