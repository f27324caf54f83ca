// EKF-SLAM against known answers and the invariants of the tutorial's convergence section.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "linear_models.hpp"
#include "slamkit/core/angles.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/filters/unscented_joint_gaussian.hpp"

using namespace slamkit;
using test_models::LinearMotion;
using test_models::LinearOffset;

namespace {

/// A textbook Kalman filter on the full joint state, written densely and independently of EkfSlam:
/// full F, full H, Joseph-form covariance update, augmentation as a linear map of the joint state.
struct DenseKalman {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3);
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(3, 3);
  std::vector<int> ids;

  void predict(const Eigen::Vector3d& u, double dt, const Matrix3& m) {
    const auto n = x.size();
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(n, 3);
    g.topRows<3>() = dt * Matrix3::Identity();
    const Eigen::MatrixXd f = Eigen::MatrixXd::Identity(n, n);
    x = f * x + g * u;
    p = f * p * f.transpose() + g * m * g.transpose();
  }
  Eigen::MatrixXd h_of(std::size_t k) const {
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(2, x.size());
    h.block<2, 2>(0, 0) = -Matrix2::Identity();
    h.block<2, 2>(0, 3 + 2 * k) = Matrix2::Identity();
    return h;
  }
  void update(std::size_t k, const Vector2& z, const Matrix2& r) {
    const Eigen::MatrixXd h = h_of(k);
    const Eigen::MatrixXd s = h * p * h.transpose() + r;
    const Eigen::MatrixXd gain = p * h.transpose() * s.inverse();
    x += gain * (z - h * x);
    const Eigen::MatrixXd a = Eigen::MatrixXd::Identity(x.size(), x.size()) - gain * h;
    p = a * p * a.transpose() + gain * r * gain.transpose();
  }
  void add(const Vector2& z, const Matrix2& r, int id) {
    const auto n = x.size();
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n + 2, n);
    a.topRows(n).setIdentity();
    a.block(n, 0, 2, 2).setIdentity();
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n + 2, 2);
    b.bottomRows<2>().setIdentity();
    x = (a * x + b * z).eval();
    p = (a * p * a.transpose() + b * r * b.transpose()).eval();
    ids.push_back(id);
  }
};

}  // namespace

class LinearGaussian : public ::testing::TestWithParam<bool> {};

// Both ways of applying a scan (joint, and one observation after another) equal the textbook filter
// when the models are linear.
TEST_P(LinearGaussian, EkfSlamEqualsPlainKalmanFilter) {
  auto motion = std::make_shared<LinearMotion>(Eigen::Vector3d(0.04, 0.09, 0.001).asDiagonal().toDenseMatrix());
  auto obs = std::make_shared<LinearOffset>();
  EkfSlamOptions options;
  options.initial_pose = Pose2(1.0, -2.0, 0.1);
  options.initial_covariance = Eigen::Vector3d(0.1, 0.2, 0.01).asDiagonal();
  options.joint_scan_update = GetParam();
  EkfSlam ekf(motion, obs, options);
  DenseKalman kf;
  kf.x = options.initial_pose;
  kf.p = options.initial_covariance;

  std::mt19937_64 rng(42);
  std::normal_distribution<double> n01;
  const std::vector<Vector2> world = {{5, 5}, {-4, 6}, {8, -3}, {0, 10}, {-6, -6}, {3, 1}};
  for (int step = 0; step < 60; ++step) {
    Control u(3);
    u << 0.5 + 0.1 * n01(rng), 0.2 * n01(rng), 0.01 * n01(rng);
    ekf.predict(ControlEvent{0.1 * step, 0.1, u});
    kf.predict(u, 0.1, motion->control_noise(u, 0.1));
    ScanEvent scan;
    for (int id = 0; id < static_cast<int>(world.size()); ++id) {
      if ((step + id) % 3 == 0) continue;  // a changing subset each scan, landmarks appear over time
      if (step < 2 * id) continue;
      scan.observations.push_back({world[id] - kf.x.head<2>() + 0.1 * Vector2(n01(rng), n01(rng)), id});
    }
    ekf.update(scan);
    // The reference applies updates to known landmarks first, then adds new ones, as EkfSlam does.
    for (const Observation& o : scan.observations) {
      const auto it = std::find(kf.ids.begin(), kf.ids.end(), o.id);
      if (it != kf.ids.end()) kf.update(static_cast<std::size_t>(it - kf.ids.begin()), o.z, obs->noise());
    }
    for (const Observation& o : scan.observations)
      if (std::find(kf.ids.begin(), kf.ids.end(), o.id) == kf.ids.end()) kf.add(o.z, obs->noise(), o.id);

    ASSERT_EQ(ekf.estimator().state_dim(), static_cast<std::size_t>(kf.x.size()));
    EXPECT_LT((ekf.estimator().state() - kf.x).cwiseAbs().maxCoeff(), 1e-9) << "step " << step;
    EXPECT_LT((ekf.estimator().covariance() - kf.p).cwiseAbs().maxCoeff(), 1e-9) << "step " << step;
  }
  EXPECT_EQ(ekf.num_landmarks(), world.size());
}

INSTANTIATE_TEST_SUITE_P(ScanUpdate, LinearGaussian, ::testing::Bool(),
                         [](const auto& info) { return info.param ? "Joint" : "Sequential"; });

TEST(EkfSlam, NewLandmarkCarriesFullCrossCovariance) {
  auto motion = std::make_shared<AckermannModel>();
  auto obs = std::make_shared<RangeBearingModel>();
  EkfSlam ekf(motion, obs);
  Control u(2);
  u << 3.0, 0.1;
  for (int i = 0; i < 40; ++i) ekf.predict(ControlEvent{0.025 * (i + 1), 0.025, u});
  ekf.update(ScanEvent{1.0, {Observation{Vector2(10.0, 0.3), 7}}});
  const Eigen::MatrixXd p = ekf.estimator().covariance();
  // cov(m, v) = Gx Pvv: non-zero, since the landmark inherits the vehicle's uncertainty.
  EXPECT_GT((p.block<2, 3>(3, 0).norm()), 1e-6);
  EXPECT_EQ(ekf.find_landmark(7), 0);
  EXPECT_EQ(ekf.find_landmark(8), -1);
  const double min_eigenvalue = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(p).eigenvalues().minCoeff();
  EXPECT_GT(min_eigenvalue, -1e-12);
}

TEST(EkfSlam, KnownAssociationDiscardsObservationWithoutIdentity) {
  EkfSlam ekf(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>());
  ScanEvent scan;
  scan.observations.push_back({Vector2(5, 0), kUnknownId});
  scan.observations.push_back({Vector2(6, 0.5), 4});
  ekf.update(scan);
  EXPECT_EQ(ekf.num_landmarks(), 1u);
  ASSERT_EQ(ekf.last_associations().size(), 2u);
  EXPECT_EQ(ekf.last_associations()[0].decision, AssociationDecision::kDiscard);
  EXPECT_EQ(ekf.last_associations()[1].decision, AssociationDecision::kNew);
  EXPECT_EQ(ekf.last_associations()[1].landmark_id, 4);
  EXPECT_EQ(ekf.statistics().at("discarded_observations"), 1.0);
}

// A simulator config with no sensor noise used to run to an empty map after thousands of landmarks
// were started and removed: every innovation was infinitely far from every landmark.
TEST(EkfSlam, RejectsAMeasurementNoiseThatIsNotPositiveDefinite) {
  RangeBearingModel::Params perfect;
  perfect.sigma_range = 0.0;
  perfect.sigma_bearing = 0.0;
  EXPECT_THROW(EkfSlam(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>(perfect)),
               std::invalid_argument);
}

TEST(JointGaussian, RemovingALandmarkEqualsMarginalisingItOut) {
  JointGaussian ekf(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>());
  Control u(2);
  u << 3.0, 0.1;
  for (int i = 0; i < 6; ++i) {
    ekf.predict(u, 0.2);
    EXPECT_EQ(ekf.add_landmark(Vector2(8.0 + i, wrap_angle(0.9 * i))), static_cast<std::size_t>(i));
  }
  ekf.update_landmark(2, Vector2(9.5, wrap_angle(1.7)));
  for (const std::size_t victim : {std::size_t{0}, std::size_t{3}, std::size_t{5}}) {
    JointGaussian copy = ekf;
    const Eigen::MatrixXd before = copy.covariance();
    const Eigen::VectorXd x_before = copy.state();
    copy.remove_landmark(victim);
    // The marginal of the remaining variables: drop the victim's rows and columns.
    std::vector<Eigen::Index> keep;
    for (Eigen::Index i = 0; i < before.rows(); ++i)
      if (i < 3 + 2 * static_cast<Eigen::Index>(victim) || i >= 5 + 2 * static_cast<Eigen::Index>(victim))
        keep.push_back(i);
    const Eigen::MatrixXd expected = before(keep, keep);
    EXPECT_EQ(copy.covariance(), expected) << "victim " << victim;
    EXPECT_EQ(copy.state(), x_before(keep));
    EXPECT_EQ(copy.num_landmarks(), 5u);
    // The landmarks after the victim move down one index.
    for (std::size_t i = 0; i < 5; ++i)
      EXPECT_EQ(copy.landmark_position(i), ekf.landmark_position(i < victim ? i : i + 1)) << "victim " << victim;
  }
}

// Map management removes a landmark through the estimator and renumbers the rest: the ids still
// name the right landmarks afterwards.
TEST(EkfSlam, RemovedLandmarkLeavesTheOthersUnderTheirIds) {
  EkfSlamOptions options;
  options.association.method = AssociationMethod::kNearestNeighbour;
  EkfSlam ekf(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>(), options);
  const Vector2 a(10.0, 0.0), b(12.0, 1.0), c(8.0, -1.5);
  ekf.update(ScanEvent{0.0, {Observation{a}, Observation{b}, Observation{c}}});  // ids 0, 1, 2
  // b is seen no more: it is missed three times while provisional, and removed.
  for (int scan = 1; scan <= 3; ++scan) ekf.update(ScanEvent{0.1 * scan, {Observation{a}, Observation{c}}});
  EXPECT_EQ(ekf.statistics().at("landmarks_removed"), 1.0);
  EXPECT_EQ(ekf.num_landmarks(), 2u);
  EXPECT_EQ(ekf.find_landmark(1), -1);
  ASSERT_EQ(ekf.find_landmark(2), 1);
  const RangeBearingModel model;
  EXPECT_LT((ekf.estimator().landmark_position(1) - model.invert(Pose2::Zero(), c)->position).norm(), 1e-6);
  // a and c were seen four times: confirmed, and the map under their ids.
  const std::vector<Landmark> map = ekf.landmarks();
  ASSERT_EQ(map.size(), 2u);
  EXPECT_EQ(map[0].id, 0);
  EXPECT_EQ(map[1].id, 2);
}

TEST(JointGaussian, GrowsPastInitialCapacityWithoutLosingState) {
  JointGaussian ekf(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>());
  Control u(2);
  u << 3.0, 0.05;
  ekf.predict(u, 0.5);
  for (int i = 0; i < 300; ++i) ekf.add_landmark(Vector2(5.0 + i * 0.01, wrap_angle(i * 0.1)));
  const Eigen::MatrixXd before = ekf.covariance();
  ekf.predict(u, 0.1);
  ekf.update_landmark(150, Vector2(6.5, wrap_angle(150 * 0.1)));
  const Eigen::MatrixXd after = ekf.covariance();
  EXPECT_EQ(ekf.num_landmarks(), 300u);
  EXPECT_EQ(after.rows(), 3 + 600);
  EXPECT_TRUE(after.isApprox(after.transpose()));
  // An update only removes uncertainty from the map block.
  EXPECT_LE(after.bottomRightCorner(600, 600).trace(), before.bottomRightCorner(600, 600).trace());
}

// Relocalisation fuses a landmark mapped twice: the state conditioned on m_duplicate = m_original,
// a noiseless linear measurement of all pairs at once, which for every estimator is the textbook
// Kalman update with H = [.. I .. -I ..] and R = 0 (the pose and every other landmark move through
// their correlations). Afterwards the pair is one landmark: equal means, no uncertainty between.
TEST(JointGaussian, FusingDuplicatesIsTheKalmanUpdateOnTheirDiscrepancy) {
  const auto motion = std::make_shared<AckermannModel>();
  const auto observation = std::make_shared<RangeBearingModel>();
  std::vector<std::unique_ptr<JointGaussian>> estimators;
  estimators.push_back(std::make_unique<JointGaussian>(motion, observation));
  estimators.push_back(std::make_unique<JointGaussian>(motion, observation, Pose2::Zero(), Matrix3::Zero(),
                                                       Linearisation::kFirstEstimates));
  estimators.push_back(std::make_unique<UnscentedJointGaussian>(motion, observation));
  for (const auto& ekf : estimators) {
    Control u(2);
    u << 3.0, 0.08;
    // Six landmarks seen along an arc, then the first three mapped again after more driving.
    for (int i = 0; i < 6; ++i) {
      ekf->predict(u, 0.5);
      ekf->add_landmark(Vector2(8.0 + i, wrap_angle(0.7 * i - 1.0)));
    }
    for (int i = 0; i < 3; ++i) {
      ekf->predict(u, 0.5);
      const Vector2 m = ekf->landmark_position(static_cast<std::size_t>(i)) + Vector2(0.3, -0.2);
      const Pose2 x = ekf->pose();
      ekf->add_landmark(observation->predict(x, m));
    }
    const std::vector<LandmarkPair> pairs = {LandmarkPair{6, 0}, LandmarkPair{8, 2}};
    const Eigen::VectorXd x = ekf->state();
    const Eigen::MatrixXd p = ekf->covariance();
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(4, x.size());
    for (Eigen::Index i = 0; i < 2; ++i) {
      h.block<2, 2>(2 * i, 3 + 2 * static_cast<Eigen::Index>(pairs[i].duplicate)).setIdentity();
      h.block<2, 2>(2 * i, 3 + 2 * static_cast<Eigen::Index>(pairs[i].original)) = -Matrix2::Identity();
    }
    const Eigen::MatrixXd s = h * p * h.transpose();
    const Eigen::MatrixXd gain = p * h.transpose() * s.inverse();
    Eigen::VectorXd expected_x = x - gain * (h * x);
    expected_x[2] = wrap_angle(expected_x[2]);
    const Eigen::MatrixXd expected_p = p - gain * h * p;

    ASSERT_TRUE(ekf->fuse_landmarks(pairs));
    EXPECT_LT((ekf->state() - expected_x).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((ekf->covariance() - expected_p).cwiseAbs().maxCoeff(), 1e-9);
    for (const LandmarkPair& pair : pairs) {
      const Vector2 apart = ekf->landmark_position(pair.duplicate) - ekf->landmark_position(pair.original);
      EXPECT_LT(apart.norm(), 1e-9);
      const Matrix2 discrepancy = ekf->landmark_covariance(pair.duplicate) + ekf->landmark_covariance(pair.original) -
                                  ekf->landmark_cross_covariance(pair.duplicate, pair.original) -
                                  ekf->landmark_cross_covariance(pair.original, pair.duplicate);
      EXPECT_LT(discrepancy.cwiseAbs().maxCoeff(), 1e-9);
    }
    // The fused pose is known better than before, and the map's uncertainty did not grow anywhere.
    const double pose_before = p.topLeftCorner(3, 3).trace();
    EXPECT_LT(ekf->pose_covariance().trace(), pose_before);
    const Eigen::VectorXd shrink = (p - ekf->covariance()).selfadjointView<Eigen::Lower>().eigenvalues();
    EXPECT_GT(shrink.minCoeff(), -1e-9);
  }
}

// A map given to the constructor is the frame the start pose is known in, so the vehicle starts
// anchored to it: without identities its landmarks are recognised directly however late the first
// scan comes (here 1,000 s after the clock's zero), not held back for relocalisation and mapped
// again.
TEST(EkfSlam, AGivenMapIsRecognisedWithoutRelocalisation) {
  auto motion = std::make_shared<AckermannModel>();
  auto observation = std::make_shared<RangeBearingModel>();
  auto map = std::make_unique<JointGaussian>(motion, observation);
  const std::vector<Vector2> seen = {{12.0, 0.4}, {9.0, -0.6}, {20.0, 0.1}};
  for (const Vector2& z : seen) map->add_landmark(z);
  EkfSlamOptions options;
  options.association.method = AssociationMethod::kNearestNeighbour;
  ASSERT_GE(options.association.relocalise_min_pairs, 2u);
  EkfSlam ekf(std::move(map), std::vector<int>{7, 8, 9}, options);
  ScanEvent scan{1000.0, {}};
  for (const Vector2& z : seen) scan.observations.push_back({z + Vector2(0.05, 0.002), kUnknownId});
  for (int i = 0; i < 3; ++i) {
    ekf.update(scan);
    scan.t += 10.0;
    for (const AssociationRecord& r : ekf.last_associations()) EXPECT_EQ(r.decision, AssociationDecision::kUpdate);
  }
  EXPECT_EQ(ekf.num_landmarks(), 3u);
}
