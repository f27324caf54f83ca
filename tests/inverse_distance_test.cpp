// Inverse-distance landmarks, the bearing-only undelayed start: the prediction and the start's
// Jacobians against central differences, the conversion to a point, and the EKF placing a landmark
// from bearings alone.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <memory>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/models/inverse_distance.hpp"
#include "slamkit/models/velocity_model.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "sim_test_support.hpp"
#include "test_data.hpp"

using namespace slamkit;
using test_data::jacobian_matches;
using test_data::numeric_jacobian;

namespace {

const BearingOnlyModel kOffsetCamera({.sigma_bearing = 0.01, .offset_x = 0.8, .offset_y = -0.3});
const InverseDistancePoint kPoint{Vector2(1.0, -2.0)};

}  // namespace

TEST(InverseDistance, PredictionMatchesThePointItStandsFor) {
  const Pose2 x(3.0, 1.0, 0.4);
  for (const double rho : {0.5, 0.1, 0.02}) {
    const Vector2 p(0.7, rho);
    EXPECT_NEAR(kPoint.predict(kOffsetCamera, x, p)[0], kOffsetCamera.predict(x, kPoint.position(p))[0], 1e-12);
  }
}

TEST(InverseDistance, JacobiansMatchCentralDifferencesDownToInfinityAndBeyond) {
  const Pose2 x(3.0, 1.0, 0.4);
  for (const double rho : {0.5, 0.05, 0.0, -0.02}) {
    SCOPED_TRACE(::testing::Message() << "rho " << rho);
    const Vector2 p(0.7, rho);
    PoseJacobian hx;
    LandmarkJacobian hp;
    kPoint.predict(kOffsetCamera, x, p, &hx, &hp);
    const auto h = [&](const Pose2& at, const Vector2& q) -> Eigen::Matrix<double, 1, 1> {
      return Eigen::Matrix<double, 1, 1>(kPoint.predict(kOffsetCamera, at, q)[0]);
    };
    EXPECT_TRUE(jacobian_matches(hx, numeric_jacobian<1>([&](const Eigen::VectorXd& s) { return h(s, p); }, x, {0})));
    EXPECT_TRUE(jacobian_matches(hp, numeric_jacobian<1>([&](const Eigen::VectorXd& q) { return h(x, q); }, p, {0})));
  }
  const Vector2 p(0.7, 0.2);
  EXPECT_TRUE(jacobian_matches(kPoint.position_jacobian(p),
                               numeric_jacobian<2>([&](const Eigen::VectorXd& q) -> Vector2 { return kPoint.position(q); },
                                                   p, {})));
}

// The start's gx: how (theta, rho) about the fixed origin move when the vehicle the bearing was taken
// from moves, the landmark kept at the prior's distance along the bearing.
TEST(InverseDistance, StartJacobianMatchesCentralDifferences) {
  const Pose2 x(3.0, 1.0, 0.4);
  Measurement z(1);
  z << 0.3;
  const InverseDistanceOptions options{.min_distance_m = 2.0, .prior_distance_m = 4.0};
  Vector2 origin;
  const InitialLandmark start = inverse_distance_start(kOffsetCamera, x, Matrix3::Zero(), z, options, origin);
  EXPECT_TRUE(origin.isApprox(kOffsetCamera.sensor_position(x)));
  EXPECT_NEAR(start.mean[0], x[2] + z[0], 1e-12);
  EXPECT_NEAR(start.mean[1], 0.25, 1e-12);
  EXPECT_NEAR(start.covariance(1, 1), 1.0 / 64.0, 1e-12) << "rho's 2-sigma interval reaches 1 / d_min";
  const auto params = [&](const Eigen::VectorXd& s) -> Vector2 {
    const double theta = s[2] + z[0];
    const Vector2 m = kOffsetCamera.sensor_position(s) + Vector2(std::cos(theta), std::sin(theta)) / start.mean[1];
    const Vector2 d = m - origin;
    return Vector2(std::atan2(d[1], d[0]), 1.0 / d.norm());
  };
  EXPECT_TRUE(jacobian_matches(start.gx, numeric_jacobian<2>(params, x, {0})));
}

TEST(InverseDistance, LinearityIndexFallsAsTheDistanceIsPinnedDown) {
  const Pose2 x(0.0, 0.0, 0.0);
  const InverseDistancePoint origin_here{Vector2(0.0, -10.0)};
  const Vector2 p(M_PI / 2, 0.1);  // 10 m north of the origin: at the sensor, seen across the ray
  EXPECT_TRUE(std::isinf(origin_here.linearity(kOffsetCamera, x, Vector2(0.3, 0.0), 1e-4)));
  const double wide = origin_here.linearity(kOffsetCamera, Pose2(-5.0, 0.0, 0.0), p, 0.05 * 0.05);
  const double narrow = origin_here.linearity(kOffsetCamera, Pose2(-5.0, 0.0, 0.0), p, 0.001 * 0.001);
  EXPECT_GT(wide, kInverseDistanceLinearityThreshold);
  EXPECT_LT(narrow, kInverseDistanceLinearityThreshold);
}

TEST(InverseDistance, RefusesASensorThatMeasuresRange) {
  EXPECT_THROW(require_bearing_only(RangeBearingModel{}, "test"), std::invalid_argument);
  EXPECT_THROW(require_bearing_only(RangeOnlyModel{}, "test"), std::invalid_argument);
  EXPECT_NO_THROW(require_bearing_only(BearingOnlyModel{}, "test"));
  EXPECT_THROW(validate(InverseDistanceOptions{.min_distance_m = 0.0}), std::invalid_argument);
  EXPECT_THROW(validate(InverseDistanceOptions{.min_distance_m = 5.0, .prior_distance_m = 5.0}), std::invalid_argument);
}

// The EKF placing a landmark from exact bearings taken while driving past it: it joins the state at
// once, its distance shrinks from the prior's to the truth, and it becomes a point there.
TEST(InverseDistance, EkfPlacesALandmarkFromBearingsAndConvertsIt) {
  for (const Linearisation linearisation : {Linearisation::kStandard, Linearisation::kFirstEstimates}) {
    auto motion = std::make_shared<VelocityModel>();
    auto camera = std::make_shared<BearingOnlyModel>(BearingOnlyModel::Params{.sigma_bearing = 1e-3});
    JointGaussian ekf(motion, camera, Pose2::Zero(), Matrix3::Zero(), linearisation);
    const Vector2 m(12.0, 6.0);
    ekf.add_inverse_distance_landmark(camera->predict(ekf.pose(), m), {});
    ASSERT_TRUE(ekf.at_inverse_distance(0));
    EXPECT_GT((ekf.landmark_position(0) - m).norm(), 2.0) << "the prior puts it 10 m away";
    for (int step = 0; step < 100 && ekf.at_inverse_distance(0); ++step) {
      ekf.predict(Control(Eigen::Vector2d(1.0, 0.0)), 0.25);
      const Eigen::MatrixXd before = ekf.covariance();
      ASSERT_TRUE(ekf.update_landmark(0, camera->predict(ekf.pose(), m)));
      if (ekf.at_inverse_distance(0))
        EXPECT_LE(ekf.covariance()(4, 4), before(4, 4) + 1e-15) << "rho's variance never grows in an update";
    }
    ASSERT_FALSE(ekf.at_inverse_distance(0)) << "converted once the distance is pinned down";
    EXPECT_LT((ekf.landmark_position(0) - m).norm(), 0.2);
    const Eigen::MatrixXd p = ekf.covariance();
    EXPECT_TRUE(p.isApprox(p.transpose()));
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(p).eigenvalues().minCoeff(), -1e-12);
    // A point now: its state rows are the position itself.
    EXPECT_TRUE(ekf.state().segment<2>(3).isApprox(ekf.landmark_position(0)));
  }
}

// Converting changes the coordinates, not the belief: the point's mean, covariance and correlations
// with the vehicle and another landmark read the same before and after, the whole covariance stays
// symmetric, and a second conversion changes nothing.
TEST(InverseDistance, ConversionKeepsTheBeliefAboutThePoint) {
  auto motion = std::make_shared<VelocityModel>();
  auto camera = std::make_shared<BearingOnlyModel>(BearingOnlyModel::Params{.sigma_bearing = 0.02, .offset_x = 0.5});
  JointGaussian ekf(motion, camera, Pose2::Zero(), Matrix3::Identity() * 1e-4);
  const Vector2 m(8.0, 5.0), other(3.0, -4.0);
  ekf.add_inverse_distance_landmark(camera->predict(ekf.pose(), other), {});
  ekf.add_inverse_distance_landmark(camera->predict(ekf.pose(), m), {});
  ekf.add_inverse_distance_landmark(camera->predict(ekf.pose(), other), {});
  for (int step = 0; step < 4; ++step) {
    ekf.predict(Control(Eigen::Vector2d(1.0, 0.05)), 0.25);
    ASSERT_TRUE(ekf.update_landmark(1, camera->predict(ekf.pose(), m)));
    ASSERT_TRUE(ekf.update_landmark(0, camera->predict(ekf.pose(), other)));
  }
  ekf.predict(Control(Eigen::Vector2d(1.0, 0.05)), 0.25);  // a motion not yet applied to P_mv
  ASSERT_TRUE(ekf.at_inverse_distance(1));
  const Vector2 position = ekf.landmark_position(1);
  const Matrix2 covariance = ekf.landmark_covariance(1);
  const Matrix23 with_pose = ekf.landmark_pose_covariance(1);
  const Matrix2 with_before = ekf.landmark_cross_covariance(1, 0), with_after = ekf.landmark_cross_covariance(2, 1);
  ekf.convert_to_point(1);
  EXPECT_FALSE(ekf.at_inverse_distance(1));
  EXPECT_TRUE(ekf.landmark_position(1).isApprox(position, 1e-12));
  EXPECT_TRUE(ekf.landmark_covariance(1).isApprox(covariance, 1e-10));
  EXPECT_TRUE(ekf.landmark_pose_covariance(1).isApprox(with_pose, 1e-10));
  EXPECT_TRUE(ekf.landmark_cross_covariance(1, 0).isApprox(with_before, 1e-10));
  EXPECT_TRUE(ekf.landmark_cross_covariance(2, 1).isApprox(with_after, 1e-10));
  const Eigen::MatrixXd p = ekf.covariance();
  EXPECT_TRUE(p.isApprox(p.transpose()));
  ekf.convert_to_point(1);
  EXPECT_EQ(ekf.covariance(), p);
}

TEST(InverseDistance, EkfSlamRefusesWhatCannotKeepIt) {
  EkfSlamOptions options;
  options.initialisation = LandmarkInitialisation::kInverseDistance;
  auto motion = std::make_shared<VelocityModel>();
  EXPECT_NO_THROW(EkfSlam(motion, std::make_shared<BearingOnlyModel>(), options));
  EXPECT_THROW(EkfSlam(motion, std::make_shared<RangeBearingModel>(), options), std::invalid_argument);
  for (const EkfVariant variant : {EkfVariant::kInvariant, EkfVariant::kCompressed, EkfVariant::kUnscented}) {
    options.variant = variant;
    EXPECT_THROW(EkfSlam(motion, std::make_shared<BearingOnlyModel>(), options), std::invalid_argument);
  }
}

// End to end on the default world with bearings alone (seed 1): every landmark joins at its first
// bearing, nearly all become points, and the run beats dead reckoning. Its covariance is not
// asserted: the start is overconfident (docs/sensing.md, "The inverse-distance start, measured").
TEST(InverseDistance, BearingOnlyWorldBeatsDeadReckoning) {
  Scenario s = scenario("default");
  s.config.sensor = SensorKind::kBearingOnly;
  s.config.seed = 1;
  const Dataset d = simulate(s.world, s.config);
  EkfSlamOptions options = test_sim::ekf_options_for(d, EkfVariant::kFirstEstimates);
  options.initialisation = LandmarkInitialisation::kInverseDistance;
  EkfSlam filter(d.motion, d.observation, options);
  const Metrics m = evaluate_run(run_filter(filter, d), d.truth);
  ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m && m.map_rmse_m);
  EXPECT_LT(*m.ate_rmse_m, 0.5 * *m.dead_reckoning_ate_rmse_m);
  EXPECT_LT(*m.map_rmse_m, 2.0);
  const std::map<std::string, double> statistics = filter.statistics();
  EXPECT_GE(statistics.at("inverse_distance_converted"), 95.0);
  EXPECT_EQ(statistics.at("inverse_distance_converted") + statistics.at("landmarks_inverse_distance"),
            statistics.at("landmarks_in_state"));
  EXPECT_EQ(static_cast<double>(m.landmarks), statistics.at("inverse_distance_converted"));
}

// The product of rho's error and the sensor's adds variance only where both are uncertain, and the
// known-identity gate's S (EkfEstimator::innovation) is the update's, with that variance in it.
TEST(InverseDistance, CouplingVarianceNeedsBothUncertainAndReachesTheGate) {
  const Pose2 x(3.0, 1.0, 0.4);
  const Vector2 p(0.7, 0.1);
  const Eigen::RowVector3d none = Eigen::RowVector3d::Zero();
  EXPECT_EQ(kPoint.coupling_variance(kOffsetCamera, x, p, Matrix3::Zero(), none, 0.2), 0.0);
  EXPECT_EQ(kPoint.coupling_variance(kOffsetCamera, x, p, Matrix3::Identity() * 0.01, none, 0.0), 0.0);
  EXPECT_GT(kPoint.coupling_variance(kOffsetCamera, x, p, Matrix3::Identity() * 0.01, none, 0.2), 0.0);

  auto motion = std::make_shared<VelocityModel>();
  auto camera = std::make_shared<BearingOnlyModel>(BearingOnlyModel::Params{.sigma_bearing = 0.02, .offset_x = 0.5});
  JointGaussian ekf(motion, camera, Pose2::Zero(), Matrix3::Identity() * 0.01);
  ekf.add_inverse_distance_landmark(camera->predict(ekf.pose(), Vector2(9.0, 4.0)), {});
  ekf.predict(Control(Eigen::Vector2d(1.0, 0.05)), 0.5);
  Measurement zhat;
  MeasurementCovariance s;
  ekf.innovation(0, zhat, s);
  PoseJacobian hx;
  LandmarkJacobian hp;
  const Eigen::VectorXd state = ekf.state();
  const InverseDistancePoint origin{camera->sensor_position(Pose2::Zero())};
  origin.predict(*camera, ekf.pose(), state.segment<2>(3), &hx, &hp);
  Eigen::RowVectorXd h(5);
  h << hx, hp;
  const Eigen::MatrixXd p_full = ekf.covariance();
  const double coupling = origin.coupling_variance(*camera, ekf.pose(), state.segment<2>(3), ekf.pose_covariance(),
                                                   p_full.block<1, 3>(4, 0), p_full(4, 4));
  EXPECT_GT(coupling, 0.0);
  EXPECT_NEAR(s(0, 0), h.dot(p_full * h.transpose()) + camera->noise()(0, 0) + coupling, 1e-12);
}
