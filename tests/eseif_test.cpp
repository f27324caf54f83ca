// The exactly sparse extended information filter: with every landmark active it is the EIF; a
// relocation is the exact update of a little less data (dense algebra over the same numbers); with a
// bounded active set Omega stays sparse and the filter stays consistent where SEIF does not.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>

#include "information_filter_support.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"

using namespace slamkit;
using namespace slamkit::testing_support;

namespace {

EseifOptions exact_mean(std::size_t active) {
  EseifOptions options;
  options.active_landmarks = active;
  options.recovery_sweeps = 0;
  return options;
}

std::unique_ptr<EkfSlam> run_scans(const Dataset& data, const EseifOptions& options, std::size_t scans) {
  auto filter =
      make(data, EkfVariant::kExactlySparseInformation, AssociationMethod::kKnown, true, kPrior, {}, options);
  drive(*filter, data, scans);
  return filter;
}

ExactlySparseInformationFilter& eseif_of(EkfSlam& filter) {
  return dynamic_cast<ExactlySparseInformationFilter&>(const_cast<EkfEstimator&>(filter.estimator()));
}

/// Omega += H^T R^-1 H and xi += H^T R^-1 (nu + H mu) over the whole state, dense.
void add_dense(const ObservationModel& model, const Eigen::VectorXd& mu, const LandmarkObservation& o,
               Eigen::MatrixXd& omega, Eigen::VectorXd& xi) {
  const Pose2 x = mu.head<3>();
  const auto l = static_cast<Eigen::Index>(3 + 2 * o.index);
  const Vector2 m = mu.segment<2>(l);
  PoseJacobian hx;
  LandmarkJacobian hm;
  model.jacobians(x, m, hx, hm);
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(hx.rows(), mu.size());
  h.leftCols<3>() = hx;
  h.middleCols<2>(l) = hm;
  const Eigen::MatrixXd r_inverse = Eigen::MatrixXd(o.noise_scale * model.noise()).inverse();
  const Eigen::VectorXd target = model.residual(o.z, model.predict(x, m)) + h * mu;
  omega += h.transpose() * r_inverse * h;
  xi += h.transpose() * r_inverse * target;
}

}  // namespace

TEST(Eseif, ARelocationIsTheExactUpdateOfLessData) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const auto filter = run_scans(data, exact_mean(4), 150);
  ExactlySparseInformationFilter& eseif = eseif_of(*filter);
  ASSERT_GE(eseif.num_landmarks(), 8u);
  const ObservationModel& model = eseif.observation_model();
  const Eigen::VectorXd mu = eseif.state();
  // Observations of eight landmarks, read a little off their predictions: more than the bound.
  std::vector<LandmarkObservation> batch;
  for (std::size_t i = 0; i < 8; ++i) {
    const std::size_t index = eseif.num_landmarks() - 1 - i;
    Measurement z = model.predict(mu.head<3>(), mu.segment<2>(static_cast<Eigen::Index>(3 + 2 * index)));
    z[0] += 0.05 * static_cast<double>(i % 3) - 0.05;
    batch.push_back({index, z});
  }
  const std::vector<std::size_t> beta = eseif.relocation_set(batch);
  ASSERT_EQ(beta.size(), 2u);  // half the bound of four
  Eigen::MatrixXd omega = eseif.information().toDense();
  Eigen::VectorXd xi = eseif.information_vector();
  for (std::size_t k = 0; k < batch.size(); ++k)
    if (std::find(beta.begin(), beta.end(), k) == beta.end()) add_dense(model, mu, batch[k], omega, xi);
  const auto n = omega.rows() - 3;
  const Eigen::LLT<Eigen::MatrixXd> vehicle(omega.topLeftCorner<3, 3>());
  Eigen::MatrixXd relocated = Eigen::MatrixXd::Zero(omega.rows(), omega.cols());
  Eigen::VectorXd relocated_xi = Eigen::VectorXd::Zero(xi.size());
  relocated.bottomRightCorner(n, n) =
      omega.bottomRightCorner(n, n) - omega.bottomLeftCorner(n, 3) * vehicle.solve(omega.topRightCorner(3, n));
  relocated_xi.tail(n) = xi.tail(n) - omega.bottomLeftCorner(n, 3) * vehicle.solve(xi.head<3>());
  for (const std::size_t k : beta) add_dense(model, mu, batch[k], relocated, relocated_xi);

  ASSERT_TRUE(eseif.update_landmarks(batch));
  EXPECT_LT(relative_difference(relocated, eseif.information().toDense()), 1e-9);
  EXPECT_LT(relative_difference(relocated_xi, eseif.information_vector()), 1e-9);
  EXPECT_LT(relative_difference(relocated.llt().solve(relocated_xi), eseif.state()), 1e-9);
  EXPECT_EQ(eseif.active_landmarks().size(), 2u);
}

TEST(Eseif, WithABoundThatHoldsEveryLandmarkItIsTheEif) {
  EseifOptions everything = exact_mean(1000);
  const Differences diff = compare(simulate(default_world(), SimulatorConfig{}), AssociationMethod::kKnown, 200,
                                   capped_under_sanitizer(600), true, kPrior, EkfVariant::kInformation,
                                   EkfVariant::kExactlySparseInformation, {}, everything);
  // The mean recovered from the information vector afresh each scan: the EIF's numbers by another
  // roundoff.
  EXPECT_LT(diff.state, 1e-7);
  EXPECT_LT(diff.covariance, 1e-7);
  EXPECT_EQ(diff.decisions_differing, 0u);
}

// With first estimates and the iterated update too: moving a first estimate carries the information
// vector along, and every linearisation is the EIF's.
TEST(Eseif, WithABoundThatHoldsEveryLandmarkItIsTheFirstEstimatesIteratedEif) {
  const Differences diff = compare(simulate(default_world(), SimulatorConfig{}), AssociationMethod::kKnown, 200,
                                   capped_under_sanitizer(600), true, kPrior, EkfVariant::kInformation,
                                   EkfVariant::kExactlySparseInformation, {}, exact_mean(1000), {},
                                   {Linearisation::kFirstEstimates, 10});
  EXPECT_LT(diff.state, 1e-7);
  EXPECT_LT(diff.covariance, 1e-7);
  EXPECT_EQ(diff.decisions_differing, 0u);
}

TEST(Eseif, ABoundedActiveSetKeepsOmegaSparseAndStillMaps) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const std::size_t scans = capped_under_sanitizer(600);
  EseifOptions bounded;
  bounded.active_landmarks = 10;
  const auto eseif = run_scans(data, bounded, scans);
  const auto exact = run_scans(data, exact_mean(1000), scans);  // the EIF (the test above)
  const auto statistics = eseif->statistics();
  EXPECT_LE(statistics.at("eseif_active_landmarks"), 10.0 + 12.0);  // the bound, and what one scan adds
  EXPECT_GT(statistics.at("eseif_relocations"), 10.0);
  EXPECT_EQ(statistics.at("eseif_relocations_deferred"), 0.0);  // the default world shows several at once
  const double sparse_nonzeros = static_cast<double>(eseif_of(*eseif).information().nonZeros());
  const double exact_nonzeros = static_cast<double>(eseif_of(*exact).information().nonZeros());
  EXPECT_LT(sparse_nonzeros, 0.6 * exact_nonzeros);
  double worst = 0.0;
  for (std::size_t i = 0; i < exact->num_landmarks(); ++i)
    worst = std::max(
        worst, (eseif->estimator().landmark_position(i) - exact->estimator().landmark_position(i)).norm());
  EXPECT_LT(worst, 1.0);
  ::testing::Test::RecordProperty("information_nonzeros_fraction", std::to_string(sparse_nonzeros / exact_nonzeros));
}

// What ESEIF is for: sparse like SEIF, but without SEIF's overconfidence; each as the command line
// runs it (SEIF's local covariances, ESEIF's exact ones), ESEIF with the linearisation that keeps it
// consistent (first estimates, iterated; its single update gives a NEES of 4.3 and 80% of steps in
// the band on these seeds). Seeds of the default world other than those the relocation rule and the
// bound were chosen on (1-3).
TEST(Eseif, StaysConsistentWhereSeifIsOverconfident) {
  if (capped_under_sanitizer(SIZE_MAX) != SIZE_MAX)
    GTEST_SKIP() << "the numbers of three whole runs, checked by make test; the sanitizers check the filter's "
                    "memory in the other tests";
  constexpr int kRuns = 3;
  double eseif_nees = 0.0, eseif_in_band = 0.0, seif_nees = 0.0, relocations = 0.0;
  for (int run = 0; run < kRuns; ++run) {
    SimulatorConfig sim;
    sim.seed = 40 + static_cast<std::uint64_t>(run);
    const Dataset data = simulate(default_world(), sim);
    for (const FilterKind kind : {FilterKind::kEseif, FilterKind::kSeif}) {
      FilterConfig config;
      config.filter = kind;
      if (kind == FilterKind::kEseif) {
        config.ekf_variant = EkfVariant::kFirstEstimates;
        config.ekf_update = EkfUpdate::kIterated;
      }
      const auto filter = make_filter(config, data);
      const Metrics m = evaluate_run(run_filter(*filter, data), data.truth);
      ASSERT_TRUE(m.nees_pose.has_value());
      if (kind == FilterKind::kEseif) relocations += filter->statistics().at("eseif_relocations");
      (kind == FilterKind::kEseif ? eseif_nees : seif_nees) += m.nees_pose->mean / kRuns;
      if (kind == FilterKind::kEseif) eseif_in_band += m.nees_pose->in_interval_fraction / kRuns;
    }
  }
  RecordProperty("eseif_mean_nees", std::to_string(eseif_nees));
  RecordProperty("seif_mean_nees", std::to_string(seif_nees));
  EXPECT_GT(relocations, 0.0);  // sparse, not the EIF
  EXPECT_LT(eseif_nees, 6.0);
  EXPECT_GT(eseif_in_band, 0.85);
  EXPECT_GT(seif_nees, 5.0 * eseif_nees);
}

TEST(Eseif, SettingsAreValidatedAndNamed) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  FilterConfig config;
  config.filter = parse_filter_kind("eseif");
  EXPECT_EQ(make_filter(config, data)->name(), "eseif");
  config.eseif.active_landmarks = 0;
  try {
    make_filter(config, data);
    ADD_FAILURE() << "a bound of 0 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("eseif_active_landmarks"), std::string::npos) << e.what();
  }
  config = FilterConfig{};
  config.filter = FilterKind::kEseif;
  config.seif.active_landmarks = 5;  // a SEIF setting for the ESEIF
  EXPECT_THROW(make_filter(config, data), std::invalid_argument);
  config = FilterConfig{};
  config.filter = FilterKind::kEseif;
  config.ekf_update = EkfUpdate::kSequential;  // one observation at a time never relocates
  EXPECT_THROW(make_filter(config, data), std::invalid_argument);
  config = FilterConfig{};
  config.filter = FilterKind::kEseif;
  config.eseif.active_landmarks = 7;
  config.eseif.recovery_sweeps = 3;
  config.eseif.covariance = CovarianceRecovery::kLocal;
  const FilterConfig read = filter_config_from_json(to_json(config), "run.json");
  EXPECT_EQ(read.eseif.active_landmarks, 7u);
  EXPECT_EQ(read.eseif.recovery_sweeps, 3);
  EXPECT_EQ(read.eseif.covariance, CovarianceRecovery::kLocal);
  EXPECT_EQ(EseifOptions{}.covariance, CovarianceRecovery::kExact);
}
