// EKF-SLAM without landmark identities: nearest neighbour and JCBB on the simulator, with clutter,
// missed detections and a loop closure.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "slamkit/core/chi_square.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/eval/metrics.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"

using namespace slamkit;

namespace {

EkfSlam make_ekf(const Dataset& d, AssociationMethod method) {
  EkfSlamOptions options;
  options.initial_pose = d.initial_pose;
  options.association.method = method;
  options.sensor = d.sensor;
  return EkfSlam(d.motion, d.observation, options);
}

Metrics run_and_evaluate(const Dataset& d, AssociationMethod method) {
  EkfSlam ekf = make_ekf(d, method);
  RunResult run = run_filter(ekf, d);
  run.association = to_string(method);
  return evaluate_run(run, d.truth);
}

Dataset simulate_scenario(const std::string& name, std::uint64_t seed) {
  Scenario s = scenario(name);
  s.config.seed = seed;
  return simulate(s.world, s.config);
}

/// Unaligned position error at every scan.
std::vector<std::pair<double, double>> position_errors(const Dataset& d, AssociationMethod method) {
  EkfSlam ekf = make_ekf(d, method);
  std::map<double, Vector2> truth;
  for (const auto& p : d.truth.poses) truth[p.t] = p.pose.head<2>();
  std::vector<std::pair<double, double>> out;
  for (const Event& e : d.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      ekf.predict(*c);
    } else {
      const auto& scan = std::get<ScanEvent>(e);
      ekf.update(scan);
      out.emplace_back(scan.t, (ekf.pose().head<2>() - truth.at(scan.t)).norm());
    }
  }
  return out;
}

}  // namespace

class UnknownAssociation : public ::testing::TestWithParam<AssociationMethod> {};

TEST_P(UnknownAssociation, DefaultWorldWithoutIdsMakesNoWrongPairingAndMatchesKnownAccuracy) {
  Scenario s = scenario("default");
  const Dataset with_ids = simulate(s.world, s.config);
  s.config.provide_ids = false;
  const Dataset without_ids = simulate(s.world, s.config);

  const Metrics known = run_and_evaluate(with_ids, AssociationMethod::kKnown);
  const Metrics unknown = run_and_evaluate(without_ids, GetParam());
  ASSERT_TRUE(unknown.association.has_value());
  EXPECT_EQ(unknown.association->wrong, 0u);
  EXPECT_EQ(unknown.association->spurious_landmarks, 0u);
  EXPECT_EQ(unknown.landmarks, 100u);
  EXPECT_GT(unknown.association->correct, 17000u);
  ASSERT_TRUE(known.ate_rmse_m && unknown.ate_rmse_m);
  EXPECT_LE(*unknown.ate_rmse_m, 1.10 * *known.ate_rmse_m)
      << "known " << *known.ate_rmse_m << " m, " << to_string(GetParam()) << " " << *unknown.ate_rmse_m << " m";
}

TEST_P(UnknownAssociation, ClutterIsRemovedAndTheFilterStaysConsistent) {
  // Clutter 1 per scan, detection probability 0.9, no identities: over Monte Carlo runs the
  // averaged pose NEES stays inside its 95% bounds for at least 80% of the scans.
  constexpr int kRuns = 30;
  constexpr double kDuration = 40.0;
  std::map<long, double> nees_sum;
  std::map<long, int> nees_count;
  for (int run = 0; run < kRuns; ++run) {
    Dataset d = simulate_scenario("cluttered", 500 + static_cast<std::uint64_t>(run));
    std::erase_if(d.events, [&](const Event& e) { return event_time(e) > kDuration; });
    EkfSlam ekf = make_ekf(d, GetParam());
    std::map<double, Pose2> truth;
    for (const auto& p : d.truth.poses) truth[p.t] = p.pose;
    for (const Event& e : d.events) {
      if (const auto* c = std::get_if<ControlEvent>(&e)) {
        ekf.predict(*c);
        continue;
      }
      const auto& scan = std::get<ScanEvent>(e);
      ekf.update(scan);
      const long key = std::lround(scan.t / 0.2);
      nees_sum[key] += eval::pose_nees(ekf.pose(), ekf.pose_covariance(), truth.at(scan.t));
      ++nees_count[key];
    }
  }
  const eval::Interval bounds = eval::averaged_nees_interval(0.95, 3, kRuns);
  std::size_t steps = 0, inside = 0;
  for (const auto& [key, sum] : nees_sum) {
    if (nees_count[key] != kRuns) continue;
    ++steps;
    inside += bounds.contains(sum / kRuns);
  }
  ASSERT_GT(steps, 150u);
  const double fraction = static_cast<double>(inside) / static_cast<double>(steps);
  RecordProperty("nees_in_bounds_fraction", std::to_string(fraction));
  EXPECT_GE(fraction, 0.8) << inside << " of " << steps;

  // A full cluttered run: the clutter-born landmarks are all gone from the map.
  const Metrics m = run_and_evaluate(simulate_scenario("cluttered", 1), GetParam());
  ASSERT_TRUE(m.association.has_value());
  EXPECT_GT(m.association->clutter_observations, 1000u);
  EXPECT_EQ(m.association->spurious_landmarks, 0u);
  EXPECT_GT(m.filter_statistics.at("landmarks_removed"), 900.0);
  EXPECT_EQ(m.landmarks, 100u);
  EXPECT_LT(static_cast<double>(m.association->wrong), 0.002 * static_cast<double>(m.association->correct));
}

TEST_P(UnknownAssociation, ClosesTheLoopThroughClutter) {
  const Dataset d = simulate_scenario("loop-closure-cluttered", 1);
  // The landmarks seen first; the loop closes when one of them is seen again after a long absence.
  std::set<int> early;
  std::size_t scan_index = 0;
  double closure_time = 0.0;
  for (const Event& e : d.events) {
    const auto* scan = std::get_if<ScanEvent>(&e);
    if (!scan) continue;
    for (const int id : d.truth.observation_ids[scan_index]) {
      if (scan->t < 20.0 && id != kUnknownId) early.insert(id);
      if (scan->t > 200.0 && closure_time == 0.0 && early.count(id)) closure_time = scan->t;
    }
    ++scan_index;
  }
  ASSERT_GT(closure_time, 200.0);
  const auto errors = position_errors(d, GetParam());
  double before_closure = 0.0;
  for (const auto& [t, e] : errors)
    if (t < closure_time) before_closure = e;
  const double final_error = errors.back().second;
  EXPECT_GT(before_closure, 1.0) << "the scenario must build up real drift before the loop closes";
  EXPECT_LT(final_error, 0.5 * before_closure)
      << "error just before closure " << before_closure << " m, at the end " << final_error << " m";

  const Metrics m = run_and_evaluate(d, GetParam());
  EXPECT_EQ(m.association->spurious_landmarks, 0u);
  EXPECT_EQ(m.landmarks, 150u);
}

INSTANTIATE_TEST_SUITE_P(Methods, UnknownAssociation,
                         ::testing::Values(AssociationMethod::kNearestNeighbour, AssociationMethod::kJcbb),
                         [](const auto& info) { return to_string(info.param); });
