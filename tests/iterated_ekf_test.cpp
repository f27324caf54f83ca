// The iterated EKF update (--ekf-update iterated): Gauss-Newton on the scan's measurement, which
// keeps a loop closure after a long drift from leaving the filter overconfident.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <memory>
#include <stdexcept>

#include "linear_models.hpp"
#include "slamkit/core/angles.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"

using namespace slamkit;

namespace {

constexpr int kIterations = 10;

// A vehicle that has driven far without seeing anything (position std 3 m, heading 5 degrees) and
// a landmark mapped precisely at the start: the geometry of a loop closure, where the observation
// Jacobian at the predicted pose is far from the one at the truth.
struct IteratedLoopClosure {
  Pose2 prior_pose{4.0, -3.0, 0.0};
  Matrix3 prior_covariance = Eigen::Vector3d(9.0, 9.0, deg2rad(5.0) * deg2rad(5.0)).asDiagonal();
  Vector2 landmark{20.0, 5.0};
  Pose2 true_pose{1.0, 2.0, 0.05};
};

}  // namespace

TEST(IteratedEkfUpdate, EqualsTheSingleUpdateForLinearModels) {
  const Matrix3 noise = Eigen::Vector3d(0.04, 0.09, 0.01).asDiagonal();
  auto make = [&](int iterations) {
    return std::make_unique<JointGaussian>(std::make_shared<test_models::LinearMotion>(noise),
                                           std::make_shared<test_models::LinearOffset>(), Pose2(1.0, 2.0, 0.1),
                                           Matrix3::Identity(), Linearisation::kStandard, iterations);
  };
  auto single = make(1), iterated = make(kIterations);
  for (JointGaussian* g : {single.get(), iterated.get()}) {
    g->add_landmark(Vector2(3.0, -1.0));
    g->add_landmark(Vector2(-2.0, 4.0));
    Control u(3);
    u << 1.0, 0.5, 0.2;
    g->predict(u, 2.0);
    const LandmarkObservation scan[] = {{0, Vector2(1.5, -3.5)}, {1, Vector2(-4.0, 1.0)}};
    ASSERT_TRUE(g->update_landmarks(scan));
    ASSERT_TRUE(g->update_landmark(1, Vector2(-4.2, 1.3)));
  }
  EXPECT_LT((single->state() - iterated->state()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((single->covariance() - iterated->covariance()).cwiseAbs().maxCoeff(), 1e-12);
}

// The iterated update's estimate is the maximum a posteriori one, where the gradient of
// (x - x0)^T P0^-1 (x - x0) + (z - h(x))^T R^-1 (z - h(x)) vanishes; the single update stops short of
// it when the prior is wide.
TEST(IteratedEkfUpdate, ReachesTheMaximumAPosterioriEstimateAtALoopClosure) {
  const IteratedLoopClosure c;
  const auto observation = std::make_shared<RangeBearingModel>();
  const Vector2 z = observation->predict(c.true_pose, c.landmark);
  auto gradient_norm = [&](int iterations) {
    // Prior: the drifted vehicle, the landmark known well and independent of it.
    const Matrix3 drift = c.prior_covariance;
    auto g = std::make_unique<JointGaussian>(std::make_shared<test_models::LinearMotion>(drift), observation,
                                             c.prior_pose, Matrix3::Zero(), Linearisation::kStandard, iterations);
    // A landmark added from the exactly known start pose has the covariance Gz R Gz^T; the known
    // landmark is written as that and then the vehicle is moved with the drift as process noise.
    g->add_landmark(observation->predict(c.prior_pose, c.landmark));
    Control still(3);
    still << 0.0, 0.0, 0.0;
    g->predict(still, 1.0);
    const Eigen::VectorXd x0 = g->state();
    const Eigen::MatrixXd p0 = g->covariance();
    EXPECT_TRUE(g->update_landmark(0, z));
    const Eigen::VectorXd x = g->state();
    PoseJacobian hx;
    LandmarkJacobian hm;
    observation->jacobians(x.head<3>(), x.tail<2>(), hx, hm);
    Eigen::Matrix<double, 2, 5> h;
    h << hx, hm;
    Eigen::Matrix<double, 5, 1> dx = x - x0;
    dx[2] = wrap_angle(dx[2]);
    const Vector2 r = observation->residual(z, observation->predict(x.head<3>(), x.tail<2>()));
    const Eigen::Matrix<double, 5, 1> grad =
        p0.ldlt().solve(dx) - h.transpose() * observation->noise().ldlt().solve(r);
    return grad.norm();
  };
  const double single = gradient_norm(1), iterated = gradient_norm(kIterations);
  EXPECT_LT(iterated, 1e-6);
  EXPECT_GT(single, 1e3 * iterated);
}

TEST(IteratedEkfUpdate, IsRefusedWhereItIsNotImplemented) {
  FilterConfig config;
  config.ekf_update = EkfUpdate::kIterated;
  EXPECT_NO_THROW(validate(config));
  for (const EkfVariant variant : {EkfVariant::kFirstEstimates, EkfVariant::kInvariant}) {
    config.ekf_variant = variant;
    EXPECT_NO_THROW(validate(config));
  }
  config.ekf_variant = EkfVariant::kCompressed;
  EXPECT_THROW(validate(config), std::invalid_argument);
  config.ekf_variant = EkfVariant::kFull;
  config.filter = FilterKind::kUkf;
  EXPECT_THROW(validate(config), std::invalid_argument);
  EXPECT_THROW(JointGaussian(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>(), Pose2::Zero(),
                             Matrix3::Zero(), Linearisation::kStandard, 0),
               std::invalid_argument);
}
