// The sparse extended information filter: with every landmark active and the mean recovered
// exactly it is the EIF; its sparsification keeps the map's marginal and cuts the vehicle's links;
// with a bounded active set its information matrix stays sparse while it still maps the world.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>

#include "information_filter_support.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"

using namespace slamkit;
using namespace slamkit::testing_support;

namespace {

/// Every landmark of the default world active, the mean and the covariances recovered exactly.
SeifOptions exact() {
  SeifOptions options;
  options.active_landmarks = 1000;
  options.recovery_sweeps = 0;
  options.covariance = CovarianceRecovery::kExact;
  return options;
}

/// A SEIF (or the `variant` given) over the first `scans` scans of `data` with known identities.
std::unique_ptr<EkfSlam> run_scans(const Dataset& data, const SeifOptions& options, std::size_t scans,
                                   EkfVariant variant = EkfVariant::kSparseInformation) {
  auto seif = make(data, variant, AssociationMethod::kKnown, true, kPrior, options);
  drive(*seif, data, scans);
  return seif;
}

const SparseExtendedInformationFilter& seif_of(const EkfSlam& filter) {
  return dynamic_cast<const SparseExtendedInformationFilter&>(filter.estimator());
}

}  // namespace

TEST(Seif, WithEveryLandmarkActiveAndExactRecoveryItIsTheEif) {
  const Differences diff =
      compare(simulate(default_world(), SimulatorConfig{}), AssociationMethod::kKnown, 200,
              capped_under_sanitizer(600), true, kPrior, EkfVariant::kInformation, EkfVariant::kSparseInformation,
              exact());
  // The SEIF recovers its mean from the information vector afresh each scan, the EIF moves it by
  // each update's solve: the same numbers by a different roundoff.
  EXPECT_LT(diff.state, 1e-7);
  EXPECT_LT(diff.covariance, 1e-7);
  EXPECT_LT(diff.pose_between_scans, 1e-7);
  EXPECT_EQ(diff.decisions_differing, 0u);
}

// Without identities: removals, and at the second lap's return the fusion of the landmarks mapped
// again, which in canonical form drops the difference's rows. (The return comes after the
// sanitizers' 300 scans.)
TEST(Seif, WithoutIdentitiesItFusesAndRemovesAsTheEifDoes) {
  SimulatorConfig sim;
  sim.provide_ids = false;
  const std::size_t scans = capped_under_sanitizer(SIZE_MAX);
  const Differences diff = compare(simulate(default_world(), sim), AssociationMethod::kNearestNeighbour, 200, scans,
                                   true, kPrior, EkfVariant::kInformation, EkfVariant::kSparseInformation, exact());
  EXPECT_LT(diff.state, 1e-7);
  EXPECT_LT(diff.covariance, 1e-7);
  EXPECT_EQ(diff.decisions_differing, 0u);
  if (scans == SIZE_MAX) EXPECT_GE(diff.landmarks_fused, 2.0);
}

TEST(Seif, SparsificationKeepsTheMapMarginalAndCutsTheVehicleLinks) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const auto filter = run_scans(data, exact(), 300);
  auto& seif = const_cast<SparseExtendedInformationFilter&>(seif_of(*filter));
  ASSERT_GT(seif.active_landmarks().size(), 12u);
  const Eigen::MatrixXd before = seif.covariance();
  const Eigen::VectorXd mean_before = seif.information().toDense().llt().solve(seif.information_vector());
  std::vector<std::size_t> recent = seif.active_landmarks();

  seif.sparsify(5);
  ASSERT_EQ(seif.active_landmarks().size(), 5u);
  const Eigen::MatrixXd after = seif.covariance();
  const auto n = before.rows();
  // p(m) is untouched: the map's block of the covariance, cross-covariances included.
  EXPECT_LT(relative_difference(before.bottomRightCorner(n - 3, n - 3), after.bottomRightCorner(n - 3, n - 3)),
            1e-9);
  // The mean the canonical form stands for is unchanged (xi moved with Omega).
  const Eigen::VectorXd mean_after = seif.information().toDense().llt().solve(seif.information_vector());
  EXPECT_LT(relative_difference(mean_before, mean_after), 1e-9);
  // The vehicle keeps links only to the active landmarks.
  const Eigen::MatrixXd omega = seif.information().toDense();
  std::size_t linked = 0;
  for (std::size_t i = 0; i < seif.num_landmarks(); ++i) {
    const auto l = static_cast<Eigen::Index>(3 + 2 * i);
    const bool active = std::find(seif.active_landmarks().begin(), seif.active_landmarks().end(), i) !=
                        seif.active_landmarks().end();
    if (omega.block<3, 2>(0, l).cwiseAbs().maxCoeff() > 0.0) {
      ++linked;
      EXPECT_TRUE(active) << "landmark " << i;
    }
  }
  EXPECT_LE(linked, 5u);
  // Conditioning the vehicle on the passive landmarks at their means makes it more certain.
  const double trace_before = before.topLeftCorner(3, 3).trace(), trace_after = after.topLeftCorner(3, 3).trace();
  EXPECT_LE(trace_after, trace_before * (1.0 + 1e-9));
}

TEST(Seif, ItsPictureIsTheNextSparsificationStep) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  SeifOptions bounded = exact();
  bounded.active_landmarks = 6;
  const auto filter = run_scans(data, bounded, 200);
  auto& seif = const_cast<SparseExtendedInformationFilter&>(seif_of(*filter));
  const std::size_t active = seif.active_landmarks().size();
  ASSERT_GT(active, 6u);  // the last scan's observed landmarks joined the bound's six
  const std::vector<InformationMatrixPanel> panels = filter->information_panels();
  ASSERT_EQ(panels.size(), 2u);
  EXPECT_EQ((panels[0].information - seif.information()).norm(), 0.0);
  seif.sparsify(6);
  EXPECT_LT((Eigen::MatrixXd(panels[1].information) - Eigen::MatrixXd(seif.information())).cwiseAbs().maxCoeff(),
            1e-12);
  // The vehicle's rows keep their links to the six landmarks left active only.
  const auto vehicle_entries = [](const Eigen::SparseMatrix<double>& omega) {
    Eigen::Index entries = 0;
    for (Eigen::Index col = 0; col < omega.outerSize(); ++col)
      for (Eigen::SparseMatrix<double>::InnerIterator it(omega, col); it; ++it) entries += it.row() < 3 ? 1 : 0;
    return static_cast<std::size_t>(entries);
  };
  EXPECT_EQ(vehicle_entries(panels[0].information), 3 * (3 + 2 * active));
  EXPECT_EQ(vehicle_entries(panels[1].information), 3 * (3 + 2 * 6));
}

TEST(Seif, ABoundedActiveSetKeepsOmegaSparseAndStillMaps) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const std::size_t scans = capped_under_sanitizer(600);
  SeifOptions bounded;
  bounded.active_landmarks = 10;
  const auto seif = run_scans(data, bounded, scans);
  const auto eif = run_scans(data, {}, scans, EkfVariant::kInformation);
  const auto statistics = seif->statistics();
  EXPECT_LE(statistics.at("seif_active_landmarks"), 10.0 + 12.0);  // the bound, and what one scan adds
  EXPECT_GT(statistics.at("seif_sparsifications"), 10.0);
  const double sparse_nonzeros = static_cast<double>(seif_of(*seif).information().nonZeros());
  const double exact_nonzeros = static_cast<double>(
      dynamic_cast<const ExtendedInformationFilter&>(eif->estimator()).information().nonZeros());
  EXPECT_LT(sparse_nonzeros, 0.6 * exact_nonzeros);
  // The map agrees with the exact filter's to within the world's scale of error.
  double worst = 0.0;
  for (std::size_t i = 0; i < eif->num_landmarks(); ++i)
    worst = std::max(worst, (seif->estimator().landmark_position(i) - eif->estimator().landmark_position(i)).norm());
  EXPECT_LT(worst, 1.0);
  ::testing::Test::RecordProperty("information_nonzeros_fraction", std::to_string(sparse_nonzeros / exact_nonzeros));
}

TEST(Seif, SettingsAreValidatedAndNamed) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  FilterConfig config;
  config.filter = parse_filter_kind("seif");
  EXPECT_EQ(make_filter(config, data)->name(), "seif");
  config.seif.active_landmarks = 0;
  EXPECT_THROW(make_filter(config, data), std::invalid_argument);
  config.seif = SeifOptions{};
  config.seif.recovery_sweeps = -1;
  EXPECT_THROW(make_filter(config, data), std::invalid_argument);
  config = FilterConfig{};
  config.seif.active_landmarks = 5;  // a SEIF setting for the EKF
  EXPECT_THROW(make_filter(config, data), std::invalid_argument);
  config = FilterConfig{};
  config.filter = FilterKind::kSeif;
  config.seif.active_landmarks = 7;
  config.seif.recovery_sweeps = 3;
  const FilterConfig read = filter_config_from_json(to_json(config), "run.json");
  EXPECT_EQ(read.seif.active_landmarks, 7u);
  EXPECT_EQ(read.seif.recovery_sweeps, 3);
}
