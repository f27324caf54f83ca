// The extended information filter is the EKF rewritten in information form: on the same data, with
// the same prior, it must give the EKF's state, covariance and association decisions (to 1e-8 of
// their largest entries).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <memory>

#include "information_filter_support.hpp"
#include "slamkit/pipeline/factory.hpp"

using namespace slamkit;
using namespace slamkit::testing_support;

TEST(ExtendedInformationFilter, EqualsTheEkfOnTheDefaultWorld) {
  const Differences diff =
      compare(simulate(default_world(), SimulatorConfig{}), AssociationMethod::kKnown, 200,
              capped_under_sanitizer(SIZE_MAX));
  expect_equivalent(diff);
  EXPECT_GE(diff.checks, 2u);
  if (capped_under_sanitizer(SIZE_MAX) == SIZE_MAX) EXPECT_EQ(diff.landmarks, default_world().landmarks.size());
}

// First-estimates Jacobians and the iterated update are the EKF's own (filters/information_form.hpp):
// the same Jacobians, the same iterates, the same first estimates moved (the default world has some
// 190 first estimates the belief comes to rule out).
TEST(ExtendedInformationFilter, EqualsTheFirstEstimatesAndIteratedEkfs) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const std::size_t scans = capped_under_sanitizer(SIZE_MAX);
  const struct {
    const char* name;
    EkfVariant ekf;
    InformationLinearisation linearised;
  } cases[] = {{"fej", EkfVariant::kFirstEstimates, {Linearisation::kFirstEstimates, 1}},
               {"iterated", EkfVariant::kFull, {Linearisation::kStandard, 10}},
               {"fej, iterated", EkfVariant::kFirstEstimates, {Linearisation::kFirstEstimates, 10}}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const Differences diff = compare(data, AssociationMethod::kKnown, 200, scans, true, kPrior, c.ekf,
                                     EkfVariant::kInformation, {}, {}, {}, c.linearised);
    expect_equivalent(diff);
    EXPECT_GE(diff.checks, 2u);
  }
}

// Each linearisation is a different filter: the comparisons above would pass if the settings were
// ignored on both sides.
TEST(ExtendedInformationFilter, FirstEstimatesAndIterationChangeTheEstimate) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const std::size_t scans = capped_under_sanitizer(600);
  double anchors_moved = 0.0;
  const auto run = [&](const InformationLinearisation& linearised) {
    const auto eif = make(data, EkfVariant::kInformation, AssociationMethod::kKnown, true, kPrior, {}, {}, {},
                          linearised);
    drive(*eif, data, scans);
    const auto statistics = eif->statistics();
    EXPECT_EQ(statistics.count("first_estimates_moved"),
              linearised.linearisation == Linearisation::kFirstEstimates ? 1u : 0u);
    if (statistics.count("first_estimates_moved") > 0) anchors_moved = statistics.at("first_estimates_moved");
    return eif->estimator().state();
  };
  const Eigen::VectorXd standard = run({}), fej = run({Linearisation::kFirstEstimates, 1}),
                        iterated = run({Linearisation::kStandard, 10});
  EXPECT_GT(max_difference(standard, fej), 1e-6);
  EXPECT_GT(max_difference(standard, iterated), 1e-6);
  EXPECT_GT(anchors_moved, 0.0);
}

TEST(ExtendedInformationFilter, EqualsTheEkfWithSequentialUpdates) {
  const Differences diff =
      compare(simulate(default_world(), SimulatorConfig{}), AssociationMethod::kKnown, 100, 300, false);
  expect_equivalent(diff);
}

// Without identities the map is managed: landmarks that fail the existence rule are marginalised
// out, and the second lap's return is recognised by relocalisation, which fuses the landmarks mapped
// again into the first lap's (conditioning on their equality, then removing the duplicates). The
// return comes in the second lap, after the sanitizers' 300 scans.
TEST(ExtendedInformationFilter, SameDecisionsAndEstimateWithNearestNeighbourFusionAndRemoval) {
  SimulatorConfig sim;
  sim.provide_ids = false;
  const std::size_t scans = capped_under_sanitizer(SIZE_MAX);
  const Differences diff = compare(simulate(default_world(), sim), AssociationMethod::kNearestNeighbour, 200, scans);
  expect_equivalent(diff);
  if (scans == SIZE_MAX) EXPECT_GE(diff.landmarks_fused, 2.0);
}

TEST(ExtendedInformationFilter, ClutterMakesItRemoveLandmarksAsTheEkfDoes) {
  SimulatorConfig sim;
  sim.provide_ids = false;
  sim.clutter_rate = 2.0;
  const Differences diff =
      compare(simulate(default_world(), sim), AssociationMethod::kJcbb, 100, capped_under_sanitizer(500));
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
    const Differences diff = compare(simulate(default_world(), sim), AssociationMethod::kKnown, 100,
                                     capped_under_sanitizer(400), true, 1e-2 * Matrix3::Identity());
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
  for (const EkfVariant variant : {EkfVariant::kInvariant, EkfVariant::kCompressed}) {
    config.ekf_variant = variant;
    EXPECT_THROW(make_filter(config, data), std::invalid_argument);
  }
  EXPECT_THROW(ExtendedInformationFilter(data.motion, data.observation, Pose2::Zero(), Matrix3::Zero(),
                                         {Linearisation::kInvariant, 1}),
               std::invalid_argument);
  EXPECT_THROW(ExtendedInformationFilter(data.motion, data.observation, Pose2::Zero(), Matrix3::Zero(),
                                         {Linearisation::kStandard, 0}),
               std::invalid_argument);
  config = FilterConfig{};
  config.ekf_variant = EkfVariant::kInformation;
  EXPECT_THROW(make_filter(config, data), std::invalid_argument);
}
