// The first-estimates EKF's anchors (joint_gaussian.hpp, "Moving a first estimate"): a landmark first
// seen far away while the heading was poorly known keeps a first estimate metres from where the
// filter later puts it; before its next observation is linearised there, the anchor moves to the
// current estimate and the covariance is carried along, P -> M P M^T, so that the turn of the whole
// scene about the origin stays as unobserved as it was.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/models/velocity_model.hpp"

using namespace slamkit;

namespace {

// The turn of the whole scene about the origin, at the pose p and the landmark anchors: (J p, 1,
// J m_1, ...).
Eigen::VectorXd turn_at(const Eigen::VectorXd& points) {
  Eigen::VectorXd n(points.size());
  for (Eigen::Index o = 0; o < points.size(); o += (o == 0 ? 3 : 2)) {
    n[o] = -points[o + 1];
    n[o + 1] = points[o];
  }
  n[2] = 1.0;
  return n;
}

// The Kalman update of covariance p with the observation Jacobians at (pose, landmark 1 at m) of a
// three-state-plus-two-landmark state: H, S and the gain.
struct Update {
  Eigen::MatrixXd h, s, gain;
  Update(const RangeBearingModel& model, const Eigen::MatrixXd& p, const Pose2& pose, const Vector2& m) {
    PoseJacobian hx;
    LandmarkJacobian hm;
    model.jacobians(pose, m, hx, hm);
    h = Eigen::MatrixXd::Zero(2, 7);
    h.leftCols<3>() = hx;
    h.block<2, 2>(0, 5) = hm;
    s = h * p * h.transpose() + model.noise();
    gain = p * h.transpose() * s.inverse();
  }
  Eigen::MatrixXd covariance(const Eigen::MatrixXd& p) const { return p - gain * s * gain.transpose(); }
};

struct Scene {
  std::shared_ptr<VelocityModel> motion = std::make_shared<VelocityModel>(VelocityModel::Params{.q_v = 1e-3, .q_omega = 1e-2});
  std::shared_ptr<RangeBearingModel> observation =
      std::make_shared<RangeBearingModel>(RangeBearingModel::Params{.sigma_range = 0.05, .sigma_bearing = deg2rad(0.5)});
  JointGaussian fej{motion, observation, Pose2::Zero(), Matrix3::Zero(), Linearisation::kFirstEstimates};
  Control still = (Control(2) << 0.0, 0.0).finished();

  // Landmark 0 seen from the known start; 20 s standing still (heading std 0.45 rad); landmark 1 seen
  // 8 m off to the left; landmark 0 seen again `turn` rad off its first bearing, which corrects the
  // heading by about that much and so moves landmark 1 by about 8 * turn through their correlation.
  explicit Scene(double turn) {
    fej.add_landmark(Vector2(3.0, 0.0));
    fej.predict(still, 20.0);
    fej.add_landmark(Vector2(8.0, kPi / 2.0));
    fej.update_landmark(0, Vector2(3.0, turn));
    fej.predict(still, 1e-3);  // the pose the next update is linearised at: the current one
  }
};

TEST(FirstEstimatesEkf, MovesAFirstEstimateTheBeliefRulesOutCarryingTheCovariance) {
  Scene scene(-0.3);
  JointGaussian& fej = scene.fej;
  const Vector2 first = fej.linearisation_anchor(1);
  const Eigen::VectorXd x = fej.state();
  const Eigen::MatrixXd p = fej.covariance();
  ASSERT_GT((x.segment<2>(5) - first).norm(), 2.0);

  const Vector2 z(8.0, kPi / 2.0 + 0.01);
  ASSERT_TRUE(fej.update_landmark(1, z));
  EXPECT_EQ(fej.linearisation_anchor(1), Vector2(x.segment<2>(5)));
  std::map<std::string, double> stats;
  fej.add_statistics(stats);
  EXPECT_EQ(stats.at("first_estimates_moved"), 1.0);

  // M = I + u e_theta^T, u = J (m - m_first) in landmark 1's rows, takes the turn at the old
  // anchors to the turn at the new ones.
  Eigen::VectorXd anchors_before = x, anchors_after = x;
  anchors_before.segment<2>(3) = fej.linearisation_anchor(0);
  anchors_before.segment<2>(5) = first;
  anchors_after.segment<2>(3) = fej.linearisation_anchor(0);
  Eigen::MatrixXd m = Eigen::MatrixXd::Identity(7, 7);
  m(5, 2) = -(x[6] - first[1]);
  m(6, 2) = x[5] - first[0];
  EXPECT_LT((m * turn_at(anchors_before) - turn_at(anchors_after)).norm(), 1e-12);
  const Eigen::MatrixXd carried = m * p * m.transpose();
  // ... and the carried covariance holds what P held about the old turn about the new one.
  const auto information = [](const Eigen::MatrixXd& cov, const Eigen::VectorXd& n) { return n.dot(cov.ldlt().solve(n)); };
  EXPECT_NEAR(information(carried, turn_at(anchors_after)), information(p, turn_at(anchors_before)),
              1e-9 * information(p, turn_at(anchors_before)));

  // The update is then the Kalman update of the carried covariance with the Jacobians at the pose
  // and the new anchor, i.e. at the current estimate.
  const Update kalman(*scene.observation, carried, x.head<3>(), x.segment<2>(5));
  const Vector2 nu = scene.observation->residual(z, scene.observation->predict(x.head<3>(), x.segment<2>(5)));
  Eigen::VectorXd expected_x = x + kalman.gain * nu;
  expected_x[2] = wrap_angle(expected_x[2]);
  EXPECT_LT((fej.state() - expected_x).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((fej.covariance() - kalman.covariance(carried)).cwiseAbs().maxCoeff(), 1e-9);
  // The Jacobian at the new anchors leaves the new turn unobserved.
  EXPECT_LT((kalman.h * turn_at(anchors_after)).norm(), 1e-9);
}

TEST(FirstEstimatesEkf, KeepsAFirstEstimateTheBeliefAllows) {
  Scene scene(-0.001);
  JointGaussian& fej = scene.fej;
  const Vector2 first = fej.linearisation_anchor(1);
  const Eigen::VectorXd x = fej.state();
  const Eigen::MatrixXd p = fej.covariance();
  ASSERT_GT((x.segment<2>(5) - first).norm(), 1e-4);

  const Vector2 z(8.0, kPi / 2.0 + 0.01);
  ASSERT_TRUE(fej.update_landmark(1, z));
  EXPECT_EQ(fej.linearisation_anchor(1), first);
  std::map<std::string, double> stats;
  fej.add_statistics(stats);
  EXPECT_EQ(stats.at("first_estimates_moved"), 0.0);
  // FEJ's own update: the Jacobians at the pose and the first estimate, the covariance as it was.
  const Update kalman(*scene.observation, p, x.head<3>(), first);
  EXPECT_LT((fej.covariance() - kalman.covariance(p)).cwiseAbs().maxCoeff(), 1e-9);
}

}  // namespace
