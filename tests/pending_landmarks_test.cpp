// New landmarks where detections may be false (assoc/pending_landmarks.hpp): the Bayes rule on its
// own, then both filter families on a cluttered world, where it keeps clutter out of the map.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "slamkit/assoc/pending_landmarks.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

constexpr double kFov = std::numbers::pi;  // the sparse worlds' sensor
constexpr double kRange = 30.0;

AssociationConfig cluttered(double clutter_per_scan) {
  AssociationConfig c;
  c.method = AssociationMethod::kNearestNeighbour;
  c.clutter_per_scan = clutter_per_scan;
  return c;
}

struct Pending {
  explicit Pending(double clutter_per_scan)
      : pending(cluttered(clutter_per_scan), SensorLimits{kRange, kFov}, RangeBearingModel{}) {}
  /// One scan at time t from the origin: offers z, ends the scan, returns what offer said.
  int scan(double t, const Vector2& z, std::size_t started = 0, std::size_t scans = 0) {
    pending.begin_scan(t, Pose2::Zero());
    const int detections = pending.offer(z, model, started, scans);
    pending.end_scan(model, view);
    return detections;
  }
  void miss(double t) {
    pending.begin_scan(t, Pose2::Zero());
    pending.end_scan(model, view);
  }
  RangeBearingModel model;
  SensorView view{SensorLimits{kRange, kFov}, -2.0, -0.1};
  PendingLandmarks pending;
};

TEST(PendingLandmarks, WithoutClutterEveryObservationStartsItsLandmarkAtOnce) {
  Pending p(0.0);
  EXPECT_FALSE(p.pending.active());
  EXPECT_EQ(p.scan(0.0, Vector2(10.0, 0.2)), 1);
  EXPECT_EQ(p.pending.size(), 0U);
}

TEST(PendingLandmarks, WithClutterAFirstSightingWaitsAndASecondOneStartsTheLandmark) {
  Pending p(1.0);
  ASSERT_TRUE(p.pending.active());
  // The odds of a first sighting: one landmark started per scan at most (here none in ten scans)
  // against one false detection per scan.
  EXPECT_EQ(p.scan(0.0, Vector2(10.0, 0.2), 0, 10), 0);
  EXPECT_EQ(p.pending.size(), 1U);
  // Elsewhere: a second hypothesis, not a confirmation.
  EXPECT_EQ(p.scan(0.2, Vector2(20.0, -0.5), 0, 11), 0);
  EXPECT_EQ(p.pending.size(), 2U);
  // The first again, within its noise: a landmark seen twice.
  EXPECT_EQ(p.scan(0.4, Vector2(10.05, 0.21), 0, 12), 2);
  EXPECT_EQ(p.pending.size(), 1U);
}

TEST(PendingLandmarks, AMapThatStartsALandmarkEveryScanTrustsAFirstSighting) {
  // beta / kappa > 1: as many landmarks started per scan as false detections are expected.
  Pending p(0.5);
  EXPECT_EQ(p.scan(0.0, Vector2(10.0, 0.2), 10, 10), 1);
}

TEST(PendingLandmarks, MissesInViewOutweighALaterDetection) {
  // Seen, then missed in plain view five times: each miss multiplies the odds by 1 - P_D = 0.1,
  // which one well-fitting detection (a likelihood ratio of a few thousand) does not make up for.
  Pending seen_again(1.0), missed(1.0);
  ASSERT_EQ(seen_again.scan(0.0, Vector2(10.0, 0.2), 0, 50), 0);
  EXPECT_EQ(seen_again.scan(0.2, Vector2(10.0, 0.2), 0, 50), 2);
  ASSERT_EQ(missed.scan(0.0, Vector2(10.0, 0.2), 0, 50), 0);
  for (int k = 1; k <= 5; ++k) missed.miss(0.2 * k);
  EXPECT_EQ(missed.scan(1.2, Vector2(10.0, 0.2), 0, 50), 0);
}

TEST(PendingLandmarks, AHypothesisOutOfViewIsNotMissedAndOneUnseenForTheWindowIsForgotten) {
  Pending p(1.0);
  ASSERT_EQ(p.scan(0.0, Vector2(10.0, 1.5), 0, 50), 0);  // at the edge: outside the narrowed view
  for (int k = 1; k <= 5; ++k) p.miss(0.2 * k);
  EXPECT_EQ(p.scan(1.2, Vector2(10.0, 1.5), 0, 50), 2);
  ASSERT_EQ(p.scan(2.0, Vector2(12.0, 1.5), 0, 50), 0);
  p.miss(2.0 + AssociationConfig{}.relocalise_window_s + 0.1);
  EXPECT_EQ(p.pending.size(), 0U);
}

Dataset cluttered_world(std::uint64_t seed) {
  Scenario s = scenario("sparse-cluttered");
  s.config.seed = seed;
  s.config.loops = 1;
  return simulate(s.world, s.config);
}

struct RunOutcome {
  Metrics metrics;
  std::map<std::string, double> statistics;
};

RunOutcome run(FilterConfig config, const Dataset& d) {
  RunResult r = run_filter(*make_filter(config, d), d);
  r.association = to_string(config.association.method);
  return {evaluate_run(r, d.truth), r.statistics};
}

// One false detection per scan, a lap of the sparse world: started as landmarks, the false detections
// crowd the EKF's state (and one falling next to a landmark about to be seen becomes that landmark,
// with a false origin); kept pending, none enters it, and the map has every landmark once.
TEST(PendingLandmarks, KeepClutterOutOfTheEkfsState) {
  const Dataset d = cluttered_world(3);
  FilterConfig config;
  config.association = cluttered(0.0);
  const RunOutcome immediate = run(config, d);
  config.association.clutter_per_scan = 1.0;
  const RunOutcome pending = run(config, d);
  ASSERT_TRUE(pending.metrics.association && immediate.metrics.association);
  const std::size_t true_landmarks = pending.metrics.association->landmarks_true_seen;
  // Every landmark ever in the state, removed or not: about one per true landmark, against over a
  // thousand when each false detection starts one.
  const double ever = pending.statistics.at("landmarks_removed") + pending.statistics.at("landmarks_in_state");
  EXPECT_LT(ever, 1.5 * static_cast<double>(true_landmarks));
  EXPECT_GT(immediate.statistics.at("landmarks_removed"), 20.0 * ever);
  EXPECT_GT(pending.statistics.at("observations_pending"), 0.8 * static_cast<double>(pending.metrics.association->clutter_observations));
  EXPECT_EQ(pending.metrics.association->spurious_landmarks, 0U);
  EXPECT_LE(pending.metrics.association->wrong, immediate.metrics.association->wrong);
}

TEST(PendingLandmarks, KeepClutterOutOfFastSlamsMaps) {
  const Dataset d = cluttered_world(3);
  FilterConfig config;
  config.filter = FilterKind::kFastSlam2;
  config.particles = 20;
  config.seed = 3;
  config.threads = 1;
  config.association = cluttered(1.0);
  const RunResult r = run_filter(*make_filter(config, d), d);
  std::size_t clutter = 0;
  for (const std::vector<int>& ids : d.truth.observation_ids)
    clutter += static_cast<std::size_t>(std::count(ids.begin(), ids.end(), kUnknownId));
  EXPECT_GT(r.statistics.at("observations_pending"), 0.8 * static_cast<double>(clutter));
  // No landmark of the final map started from a false detection.
  ASSERT_FALSE(r.map.empty());
  for (const Landmark& lm : r.map) {
    const LandmarkOrigin& origin = r.landmark_origins.at(lm.id);
    EXPECT_NE(d.truth.observation_ids.at(origin.scan).at(origin.observation), kUnknownId) << lm.id;
  }
}

}  // namespace
}  // namespace slamkit
