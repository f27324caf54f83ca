// The consistent EKF variants over Monte Carlo runs of the sparse world (35 landmarks, a 640 m loop
// driven twice, 180-degree field of view), where the plain EKF becomes overconfident: the
// first-estimates-Jacobians EKF and the invariant EKF are far closer to consistent, and no less
// accurate; with the iterated update both are consistent, and so is the exactly sparse information
// filter with first estimates. A shorter version of the 50-run experiments of docs/consistency.md
// and docs/filters.md (campaigns/consistency.json and information-consistency.json, sparse world).
#include <gtest/gtest.h>

#include <map>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"

using namespace slamkit;

namespace {

constexpr int kRuns = 8;

struct Summary {
  double mean_nees = 0.0;     // mean over runs of each run's mean pose NEES
  double in_band = 0.0;       // mean over runs of the share of steps inside the 95% interval
  double ate = 0.0;
};

// The same seeds for every filter, so they see the same noise.
Summary monte_carlo(FilterKind kind, EkfVariant variant, AssociationMethod association = AssociationMethod::kKnown,
                    EkfUpdate update = EkfUpdate::kJoint, bool gate_known = false, const EseifOptions& eseif = {}) {
  Summary s;
  for (int run = 0; run < kRuns; ++run) {
    Scenario sparse = scenario("sparse");
    sparse.config.seed = 100 + static_cast<std::uint64_t>(run);
    const Dataset d = simulate(sparse.world, sparse.config);
    FilterConfig config;
    config.filter = kind;
    config.ekf_variant = variant;
    config.association.method = association;
    config.ekf_update = update;
    config.eseif = eseif;
    // The known-id outlier gate rejects true observations once the plain EKF is overconfident; off,
    // so that every filter gets the same observations, unless the test is about the default.
    config.association.gate_known = gate_known;
    auto filter = make_filter(config, d);
    const Metrics m = evaluate_run(run_filter(*filter, d), d.truth);
    EXPECT_TRUE(m.nees_pose.has_value());
    if (!m.nees_pose) continue;
    s.mean_nees += m.nees_pose->mean / kRuns;
    s.in_band += m.nees_pose->in_interval_fraction / kRuns;
    s.ate += *m.ate_rmse_m / kRuns;
  }
  return s;
}

}  // namespace

TEST(ConsistentFiltersOnTheSparseWorld, AreFarCloserToConsistentThanThePlainEkfAndAsAccurate) {
  const Summary ekf = monte_carlo(FilterKind::kEkf, EkfVariant::kFull);
  const std::map<std::string, Summary> consistent = {
      {"fej", monte_carlo(FilterKind::kEkf, EkfVariant::kFirstEstimates)},
      {"invariant", monte_carlo(FilterKind::kEkf, EkfVariant::kInvariant)},
  };
  RecordProperty("ekf_mean_nees", std::to_string(ekf.mean_nees));
  RecordProperty("ekf_in_band", std::to_string(ekf.in_band));
  EXPECT_LT(ekf.in_band, 0.8);
  EXPECT_GT(ekf.mean_nees, 10.0);
  for (const auto& [name, s] : consistent) {
    SCOPED_TRACE(name);
    RecordProperty(name + "_mean_nees", std::to_string(s.mean_nees));
    RecordProperty(name + "_in_band", std::to_string(s.in_band));
    EXPECT_LT(s.mean_nees, 0.5 * ekf.mean_nees);
    EXPECT_GT(s.in_band, ekf.in_band + 0.1);
    EXPECT_LT(s.ate, 1.1 * ekf.ate);
  }
}

// The divergent runs of the 50-run table start at the first loop closure, after 640 m of drift: the
// single linearisation at the drifted pose leaves the filter overconfident, and then the known-id
// gate rejects true observations. The iterated update closes the loop at the maximum a posteriori
// estimate: with the default gate, FEJ without it averages a NEES of 8.9 and 83% of steps in the band
// over these seeds, with it 2.7 and 93% (the 50-run figures are in docs/consistency.md).
TEST(ConsistentFiltersOnTheSparseWorld, IteratedFirstEstimatesEkfIsConsistentWithTheDefaultGate) {
  const Summary single = monte_carlo(FilterKind::kEkf, EkfVariant::kFirstEstimates, AssociationMethod::kKnown,
                                     EkfUpdate::kJoint, true);
  const Summary iterated = monte_carlo(FilterKind::kEkf, EkfVariant::kFirstEstimates, AssociationMethod::kKnown,
                                       EkfUpdate::kIterated, true);
  RecordProperty("fej_mean_nees", std::to_string(single.mean_nees));
  RecordProperty("fej_iterated_mean_nees", std::to_string(iterated.mean_nees));
  RecordProperty("fej_iterated_in_band", std::to_string(iterated.in_band));
  EXPECT_GT(single.mean_nees, 5.0);
  EXPECT_LE(iterated.mean_nees, 3.5);
  EXPECT_GE(iterated.in_band, 0.9);
  EXPECT_LT(iterated.ate, single.ate);
}

// The invariant EKF iterates on its group (the prior's invariant error expressed at each iterate):
// over these seeds it averages a NEES of 6.1 and 85% of steps in the band without iterating, 2.6
// and 94% with it.
TEST(ConsistentFiltersOnTheSparseWorld, IteratedInvariantEkfIsConsistentWithTheDefaultGate) {
  const Summary single = monte_carlo(FilterKind::kEkf, EkfVariant::kInvariant, AssociationMethod::kKnown,
                                     EkfUpdate::kJoint, true);
  const Summary iterated = monte_carlo(FilterKind::kEkf, EkfVariant::kInvariant, AssociationMethod::kKnown,
                                       EkfUpdate::kIterated, true);
  RecordProperty("invariant_mean_nees", std::to_string(single.mean_nees));
  RecordProperty("invariant_iterated_mean_nees", std::to_string(iterated.mean_nees));
  RecordProperty("invariant_iterated_in_band", std::to_string(iterated.in_band));
  EXPECT_GT(single.mean_nees, 5.0);
  EXPECT_LE(iterated.mean_nees, 3.5);
  EXPECT_GE(iterated.in_band, 0.9);
  EXPECT_LT(iterated.ate, single.ate);
}

// The consistent sparse filter: ESEIF with first estimates and the iterated update, and a bound (20)
// that makes it relocate on this world. Its linearisation is the FEJ-EKF's, and the mean it
// linearises at is solved from the gates' factorisation; the 50-run table (docs/filters.md) has a
// mean NEES of 3.59 and 92% of steps in the band, against 14.4 and 75% for ESEIF's single update.
TEST(ConsistentFiltersOnTheSparseWorld, IteratedFirstEstimatesEseifIsConsistentWithTheDefaultGate) {
  EseifOptions bounded;
  bounded.active_landmarks = 20;
  const Summary single =
      monte_carlo(FilterKind::kEseif, EkfVariant::kFull, AssociationMethod::kKnown, EkfUpdate::kJoint, true, bounded);
  const Summary iterated = monte_carlo(FilterKind::kEseif, EkfVariant::kFirstEstimates, AssociationMethod::kKnown,
                                       EkfUpdate::kIterated, true, bounded);
  RecordProperty("eseif_mean_nees", std::to_string(single.mean_nees));
  RecordProperty("eseif_fej_iterated_mean_nees", std::to_string(iterated.mean_nees));
  RecordProperty("eseif_fej_iterated_in_band", std::to_string(iterated.in_band));
  EXPECT_GT(single.mean_nees, 5.0);
  EXPECT_LE(iterated.mean_nees, 4.0);
  EXPECT_GE(iterated.in_band, 0.88);
  EXPECT_LT(iterated.ate, single.ate);
}
