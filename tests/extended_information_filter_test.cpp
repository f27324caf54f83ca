// The extended information filter is the EKF rewritten in information form: on the same data, with
// the same prior, it must give the EKF's state, covariance and association decisions (to 1e-8 of
// their largest entries).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <memory>

#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/extended_information_filter.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

using namespace slamkit;

namespace {

constexpr double kTolerance = 1e-8;

// The information form cannot start from a pose known exactly; the EKF is given the prior the EIF
// starts from instead.
const Matrix3 kPrior = ExtendedInformationFilter::kInitialPoseFloor * Matrix3::Identity();

struct Differences {
  double state = 0.0;
  double covariance = 0.0;
  double pose_between_scans = 0.0;  // pose and its covariance after controls, before the next scan
  std::size_t checks = 0;
  std::size_t decisions_differing = 0;
  double landmarks_fused = 0.0;
  double landmarks_removed = 0.0;
  std::size_t landmarks = 0;
};

std::unique_ptr<EkfSlam> make(const Dataset& data, EkfVariant variant, AssociationMethod method,
                              bool joint_scan_update, const Matrix3& prior = kPrior) {
  EkfSlamOptions options;
  options.initial_pose = data.initial_pose;
  options.initial_covariance = prior;
  options.association.method = method;
  options.sensor = data.sensor;
  options.variant = variant;
  options.joint_scan_update = joint_scan_update;
  return std::make_unique<EkfSlam>(data.motion, data.observation, options);
}

double max_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a - b).cwiseAbs().maxCoeff(); }

/// The largest difference relative to the largest entry of `a` (or absolute below 1): roundoff
/// grows with the entries, and a range-only map's covariance holds hundreds of square metres.
double relative_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return max_difference(a, b) / std::max(1.0, a.cwiseAbs().maxCoeff());
}

/// Runs the EKF and the EIF side by side over at most `max_scans` scans of `data`, comparing the
/// whole state and covariance every `check_every` scans and at the end, every scan's association
/// decisions, and the pose's belief after every control.
Differences compare(const Dataset& data, AssociationMethod method, std::size_t check_every, std::size_t max_scans,
                    bool joint_scan_update = true, const Matrix3& prior = kPrior) {
  const auto ekf = make(data, EkfVariant::kFull, method, joint_scan_update, prior);
  const auto eif = make(data, EkfVariant::kInformation, method, joint_scan_update, prior);
  const EkfEstimator& a = ekf->estimator();
  const EkfEstimator& b = eif->estimator();
  Differences diff;
  const auto compare_all = [&] {
    EXPECT_EQ(a.state_dim(), b.state_dim());
    if (a.state_dim() != b.state_dim()) return;
    diff.state = std::max(diff.state, relative_difference(a.state(), b.state()));
    diff.covariance = std::max(diff.covariance, relative_difference(a.covariance(), b.covariance()));
    ++diff.checks;
  };
  std::size_t scans = 0;
  for (const Event& e : data.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      ekf->predict(*c);
      eif->predict(*c);
      diff.pose_between_scans =
          std::max({diff.pose_between_scans, relative_difference(a.pose(), b.pose()),
                    relative_difference(a.pose_covariance(), b.pose_covariance())});
      continue;
    }
    ekf->update(std::get<ScanEvent>(e));
    eif->update(std::get<ScanEvent>(e));
    const auto& da = ekf->last_associations();
    const auto& db = eif->last_associations();
    EXPECT_EQ(da.size(), db.size());
    for (std::size_t k = 0; k < std::min(da.size(), db.size()); ++k)
      if (da[k].decision != db[k].decision || da[k].landmark_id != db[k].landmark_id) ++diff.decisions_differing;
    if (++scans % check_every == 0) compare_all();
    if (scans == max_scans) break;
  }
  compare_all();
  if (method != AssociationMethod::kKnown) {
    diff.landmarks_fused = eif->statistics().at("landmarks_fused");
    diff.landmarks_removed = eif->statistics().at("landmarks_removed");
  }
  diff.landmarks = eif->num_landmarks();
  return diff;
}

void expect_equivalent(const Differences& diff) {
  EXPECT_LT(diff.state, kTolerance);
  EXPECT_LT(diff.covariance, kTolerance);
  EXPECT_LT(diff.pose_between_scans, kTolerance);
  EXPECT_EQ(diff.decisions_differing, 0u);
  ::testing::Test::RecordProperty("max_state_difference", std::to_string(diff.state));
  ::testing::Test::RecordProperty("max_covariance_difference", std::to_string(diff.covariance));
}

}  // namespace

TEST(ExtendedInformationFilter, EqualsTheEkfOnTheDefaultWorld) {
  const Differences diff =
      compare(simulate(default_world(), SimulatorConfig{}), AssociationMethod::kKnown, 200, SIZE_MAX);
  expect_equivalent(diff);
  EXPECT_GT(diff.checks, 5u);
  EXPECT_EQ(diff.landmarks, default_world().landmarks.size());
}

TEST(ExtendedInformationFilter, EqualsTheEkfWithSequentialUpdates) {
  const Differences diff =
      compare(simulate(default_world(), SimulatorConfig{}), AssociationMethod::kKnown, 100, 300, false);
  expect_equivalent(diff);
}

// Without identities the map is managed: landmarks that fail the existence rule are marginalised
// out, and the second lap's return is recognised by relocalisation, which fuses the landmarks mapped
// again into the first lap's (conditioning on their equality, then removing the duplicates).
TEST(ExtendedInformationFilter, SameDecisionsAndEstimateWithNearestNeighbourFusionAndRemoval) {
  SimulatorConfig sim;
  sim.provide_ids = false;
  const Differences diff = compare(simulate(default_world(), sim), AssociationMethod::kNearestNeighbour, 200, SIZE_MAX);
  expect_equivalent(diff);
  EXPECT_GE(diff.landmarks_fused, 2.0);
}

TEST(ExtendedInformationFilter, ClutterMakesItRemoveLandmarksAsTheEkfDoes) {
  SimulatorConfig sim;
  sim.provide_ids = false;
  sim.clutter_rate = 2.0;
  const Differences diff = compare(simulate(default_world(), sim), AssociationMethod::kJcbb, 100, 500);
  expect_equivalent(diff);
  EXPECT_GT(diff.landmarks_removed, 0.0);
}

// A range-only or bearing-only measurement starts its landmark by the delayed triangulation, whose
// start comes with the vehicle correlations through Gx; the updates are one row each. The start
// prior is wider here: with the floor's (1 mm) and the triangulated landmarks' elongated
// covariances, Omega is so ill-conditioned that roundoff alone parts the two forms by 1e-7 of the
// largest entry (range-only); from 10 cm they agree to 1e-8.
TEST(ExtendedInformationFilter, EqualsTheEkfWithRangeOnlyAndBearingOnlySensors) {
  for (const SensorKind sensor : {SensorKind::kRangeOnly, SensorKind::kBearingOnly}) {
    SimulatorConfig sim;
    sim.sensor = sensor;
    SCOPED_TRACE(sensor == SensorKind::kRangeOnly ? "range-only" : "bearing-only");
    const Differences diff = compare(simulate(default_world(), sim), AssociationMethod::kKnown, 100, 400, true,
                                      1e-2 * Matrix3::Identity());
    expect_equivalent(diff);
    EXPECT_GT(diff.landmarks, 10u);
  }
}

TEST(ExtendedInformationFilter, InformationIsTheInverseCovarianceAndSymmetric) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const auto eif = make(data, EkfVariant::kInformation, AssociationMethod::kKnown, true);
  const auto& filter = dynamic_cast<const ExtendedInformationFilter&>(eif->estimator());
  std::size_t scans = 0;
  for (const Event& e : data.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      eif->predict(*c);
      continue;
    }
    // Read between a scan's controls too: the pending motion is part of the answer.
    if (++scans == 150) break;
    eif->update(std::get<ScanEvent>(e));
  }
  const Eigen::MatrixXd omega = filter.information().toDense();
  const Eigen::MatrixXd p = filter.covariance();
  ASSERT_GT(filter.num_landmarks(), 5u);
  EXPECT_LT(max_difference(omega, omega.transpose()), 1e-9 * omega.cwiseAbs().maxCoeff());
  EXPECT_LT(max_difference(omega * p, Eigen::MatrixXd::Identity(p.rows(), p.cols())), 1e-6);
  EXPECT_EQ(Eigen::LLT<Eigen::MatrixXd>(omega).info(), Eigen::Success);
  std::map<std::string, double> statistics;
  filter.add_statistics(statistics);
  // Counted before the pending motion links the vehicle's neighbours.
  EXPECT_GT(statistics.at("information_nonzeros"), 0.0);
  EXPECT_LE(statistics.at("information_nonzeros"), static_cast<double>(filter.information().nonZeros()));
  EXPECT_GT(statistics.at("information_factorisations"), 0.0);
}

TEST(ExtendedInformationFilter, APoseKnownExactlyStartsFromTheFloor) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const ExtendedInformationFilter exact(data.motion, data.observation);
  EXPECT_LT(max_difference(exact.pose_covariance(), kPrior), 1e-15);
  const Matrix3 wide = Eigen::Vector3d(1.0, 2.0, 0.1).asDiagonal();
  const ExtendedInformationFilter known(data.motion, data.observation, Pose2::Zero(), wide);
  EXPECT_LT(max_difference(known.pose_covariance(), wide), 1e-12);
  EXPECT_THROW(ExtendedInformationFilter(data.motion, data.observation, Pose2::Zero(),
                                         Matrix3::Constant(std::numeric_limits<double>::quiet_NaN())),
               std::invalid_argument);
}

TEST(ExtendedInformationFilter, IsTheFilterNamedEifAndRefusesWhatItDoesNotKeep) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  FilterConfig config;
  config.filter = parse_filter_kind("eif");
  EXPECT_EQ(make_filter(config, data)->name(), "eif");
  config.ekf_variant = EkfVariant::kFirstEstimates;
  EXPECT_THROW(make_filter(config, data), std::invalid_argument);
  config = FilterConfig{};
  config.filter = FilterKind::kEif;
  config.ekf_update = EkfUpdate::kIterated;
  EXPECT_THROW(make_filter(config, data), std::invalid_argument);
  config = FilterConfig{};
  config.ekf_variant = EkfVariant::kInformation;
  EXPECT_THROW(make_filter(config, data), std::invalid_argument);
}
