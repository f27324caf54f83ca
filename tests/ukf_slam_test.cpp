// UKF-SLAM: on a linear-Gaussian system the unscented joint Gaussian is the Kalman filter (the EKF's
// JointGaussian is exact there), and on a nearly linear one it agrees with the EKF to first order.
#include <gtest/gtest.h>

#include "linear_models.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/filters/unscented_joint_gaussian.hpp"

using namespace slamkit;
using test_models::LinearMotion;
using test_models::LinearOffset;

namespace {

Control control(double a, double b, double c) {
  Control u(3);
  u << a, b, c;
  return u;
}

// The same sequence of steps on any estimator: additions, joint and single updates, a removal.
void drive(EkfEstimator& f) {
  const double dt = 0.5;
  f.predict(control(1.0, 0.2, 0.05), dt);
  f.add_landmark(Vector2(5.0, 2.0));
  f.add_landmark(Vector2(-1.0, 4.0));
  for (int i = 0; i < 3; ++i) f.predict(control(0.8, -0.1, 0.02), dt);
  const LandmarkObservation both[] = {{0, Vector2(3.6, 1.9)}, {1, Vector2(-2.3, 4.2)}};
  ASSERT_TRUE(f.update_landmarks(both));
  f.add_landmark(Vector2(2.0, -3.0));
  f.predict(control(0.5, 0.5, -0.1), dt);
  ASSERT_TRUE(f.update_landmark(2, Vector2(1.7, -3.4)));
  f.remove_landmark(1);
  f.predict(control(0.3, 0.0, 0.0), dt);
  const LandmarkObservation again[] = {{1, Vector2(1.2, -3.9)}, {0, Vector2(2.9, 1.1)}};
  ASSERT_TRUE(f.update_landmarks(again));
}

}  // namespace

// Either treatment of the control noise: for a linear motion it moves no mean.
class UkfOnLinearGaussianSystem : public ::testing::TestWithParam<std::tuple<Matrix3, UkfNoise>> {};

TEST_P(UkfOnLinearGaussianSystem, EqualsTheKalmanFilter) {
  const auto [start_covariance, noise] = GetParam();
  // A control noise with correlations, which the sigma points must carry exactly.
  auto motion = std::make_shared<LinearMotion>(
      (Matrix3() << 0.04, 0.01, 0.0, 0.01, 0.09, 0.002, 0.0, 0.002, 0.003).finished());
  auto observation = std::make_shared<LinearOffset>();
  JointGaussian kalman(motion, observation, Pose2(1.0, -2.0, 0.3), start_covariance);
  UnscentedJointGaussian ukf(motion, observation, Pose2(1.0, -2.0, 0.3), start_covariance, noise);
  drive(kalman);
  drive(ukf);
  ASSERT_EQ(ukf.state_dim(), kalman.state_dim());
  EXPECT_LT((ukf.state() - kalman.state()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((ukf.covariance() - kalman.covariance()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT(kalman.covariance().diagonal().minCoeff(), 1e-3);  // the comparison is not of zeros
}

// The start pose known exactly (the default, whose covariance is singular) and uncertain.
INSTANTIATE_TEST_SUITE_P(
    StartCovarianceAndNoise, UkfOnLinearGaussianSystem,
    ::testing::Combine(::testing::Values(Matrix3::Zero(), Eigen::Vector3d(0.1, 0.2, 0.01).asDiagonal().toDenseMatrix()),
                       ::testing::Values(UkfNoise::kAugmented, UkfNoise::kAdditive)));

// A car steering with a noisy wheel: the augmented UKF's mean takes the curvature of the motion in
// the steering angle (E[cos(theta + gamma)] < cos(theta + E[gamma]): a shorter step), the additive
// one stays at f(x, u) and keeps that shift as spread. From a known pose both see the same sigma
// points of the control noise, so the second moment the additive one adds is exactly the augmented
// one's covariance plus the shift's square.
TEST(UkfControlNoise, AdditiveKeepsTheMeanWhereTheControlsPutItAndTheShiftAsSpread) {
  AckermannModel::Params car;
  car.sigma_speed = 0.5;
  car.sigma_steer = deg2rad(20.0);
  auto motion = std::make_shared<AckermannModel>(car);
  auto observation = std::make_shared<LinearOffset>();
  const Pose2 start(1.0, -2.0, 0.3);
  Control u(2);
  u << 4.0, deg2rad(10.0);
  const double dt = 0.5;
  UnscentedJointGaussian augmented(motion, observation, start, Matrix3::Zero(), UkfNoise::kAugmented);
  UnscentedJointGaussian additive(motion, observation, start, Matrix3::Zero(), UkfNoise::kAdditive);
  augmented.predict(u, dt);
  additive.predict(u, dt);

  const Pose2 f = motion->predict(start, u, dt);
  EXPECT_LT((additive.pose() - f).cwiseAbs().maxCoeff(), 1e-12);
  const Pose2 shift = augmented.pose() - f;
  EXPECT_LT((augmented.pose().head<2>() - start.head<2>()).norm(), (f.head<2>() - start.head<2>()).norm() - 0.05)
      << "a shorter step on average";
  EXPECT_LT((additive.pose_covariance() - augmented.pose_covariance() - shift * shift.transpose()).cwiseAbs().maxCoeff(),
            1e-12);
  // To first order both spreads are the EKF's process noise.
  const Matrix3 q = motion->process_noise(start, u, dt);
  EXPECT_LT((additive.pose_covariance() - q).norm(), 0.1 * q.norm());
}

namespace {

// The UKF's and the EKF's estimates after a few steps of the nonlinear models, with every noise
// (and so every covariance) scaled by `scale`^2 and the measurements scaled accordingly.
double largest_difference(double scale, double& covariance_difference) {
  AckermannModel::Params mp;
  mp.sigma_speed *= scale;
  mp.sigma_steer *= scale;
  RangeBearingModel::Params op;
  op.sigma_range *= scale;
  op.sigma_bearing *= scale;
  auto motion = std::make_shared<AckermannModel>(mp);
  auto observation = std::make_shared<RangeBearingModel>(op);
  const Matrix3 start = scale * scale * Eigen::Vector3d(0.04, 0.04, 0.001).asDiagonal().toDenseMatrix();
  JointGaussian ekf(motion, observation, Pose2::Zero(), start);
  UnscentedJointGaussian ukf(motion, observation, Pose2::Zero(), start);
  const Vector2 landmarks[] = {{30.0, 8.0}, {25.0, -12.0}, {40.0, 3.0}};
  Pose2 truth = Pose2::Zero();
  const Vector2 offsets[] = {{0.05, -0.01}, {-0.08, 0.015}, {0.02, 0.01}};  // in units of sigma
  auto measure = [&](int i) {
    Vector2 z = observation->predict(truth, landmarks[i]);
    z += scale * Vector2(offsets[i][0], offsets[i][1] * deg2rad(1.0) / 0.1);
    return z;
  };
  Control u(2);
  u << 3.0, 0.05;
  for (EkfEstimator* f : {static_cast<EkfEstimator*>(&ekf), static_cast<EkfEstimator*>(&ukf)})
    for (int i = 0; i < 3; ++i) f->add_landmark(measure(i));
  for (int step = 0; step < 4; ++step) {
    truth = motion->predict(truth, u, 0.5);
    ekf.predict(u, 0.5);
    ukf.predict(u, 0.5);
    const LandmarkObservation scan[] = {{0, measure(0)}, {1, measure(1)}, {2, measure(2)}};
    EXPECT_TRUE(ekf.update_landmarks(scan));
    EXPECT_TRUE(ukf.update_landmarks(scan));
  }
  const Eigen::MatrixXd p = ekf.covariance();
  covariance_difference = (ukf.covariance() - p).cwiseAbs().maxCoeff() / p.diagonal().maxCoeff();
  // State differences in units of the EKF's standard deviations.
  return ((ukf.state() - ekf.state()).array() / p.diagonal().array().sqrt()).abs().maxCoeff();
}

}  // namespace

TEST(UkfOnNearlyLinearSystem, AgreesWithTheEkfToFirstOrder) {
  double cov_coarse = 0.0, cov_fine = 0.0;
  const double coarse = largest_difference(1e-2, cov_coarse);
  const double fine = largest_difference(1e-3, cov_fine);
  // The two differ by second-order terms: in units of sigma, the difference of the means shrinks in
  // proportion to sigma, and so does the relative difference of the covariances.
  EXPECT_LT(coarse, 1e-2);
  EXPECT_LT(fine, 0.2 * coarse);
  EXPECT_LT(cov_coarse, 1e-2);
  EXPECT_LT(cov_fine, 0.2 * cov_coarse + 1e-9);
}
