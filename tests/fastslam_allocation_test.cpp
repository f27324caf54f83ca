// FastSLAM's per-step hot path does not allocate: once the map has been built and the node pools
// have grown to the working set, predict() and update() (association, landmark updates, resampling)
// recycle the nodes of the persistent maps and paths and reuse their scratch vectors. Run on the
// built-in world, which drives its loop twice: the first lap builds the map and warms the pools,
// and a stretch of the second lap must make no heap allocation at all, in any thread.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iterator>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include "allocation_counter.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/filters/landmark_tree.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

using namespace slamkit;

namespace {

struct Case {
  int version;
  AssociationMethod method;
  unsigned threads;
};

std::string name(const ::testing::TestParamInfo<Case>& info) {
  const Case& c = info.param;
  return "FastSlam" + std::to_string(c.version) + (c.method == AssociationMethod::kKnown ? "Known" : "Nn") +
         std::to_string(c.threads) + "Threads";
}

const Dataset& world(bool ids) {
  static const auto simulated = [](bool provide_ids) {
    SimulatorConfig sim;
    sim.provide_ids = provide_ids;
    return simulate(default_world(), sim);
  };
  static const Dataset with_ids = simulated(true);
  static const Dataset without_ids = simulated(false);
  return ids ? with_ids : without_ids;
}

class FastSlamAllocation : public ::testing::TestWithParam<Case> {};

TEST_P(FastSlamAllocation, SecondLapMakesNoHeapAllocation) {
  const Case c = GetParam();
  const Dataset& d = world(c.method == AssociationMethod::kKnown);
  ASSERT_EQ(SimulatorConfig{}.loops, 2);

  FastSlamConfig config;
  config.version = c.version;
  // With two threads and known identities, enough particles that the predictions, not only the scan
  // updates, run on both threads. Without identities 100: the particles' maps diverge (a landmark
  // gets different indices in different maps), and with 512 the number of indices near the vehicle
  // is still growing in the second lap, and with it the candidate scratch; the prediction code is
  // the same in both cases.
  config.particles = c.threads > 1 && c.method == AssociationMethod::kKnown ? 512 : 100;
  config.threads = c.threads;
  config.association.method = c.method;
  config.initial_pose = d.initial_pose;
  config.sensor = d.sensor;
  FastSlam filter(d.motion, d.observation, config);
  ASSERT_EQ(filter.threads(), c.threads);

  std::size_t scans = 0;
  for (const Event& e : d.events) scans += std::holds_alternative<ScanEvent>(e) ? 1 : 0;
  // The window: from 60% of the run (well into the second lap) over 20% of the scans.
  const std::size_t window_begin = scans * 6 / 10;
  const std::size_t window_end = scans * 8 / 10;
  ASSERT_GE(window_end - window_begin, 100u);

  std::map<double, Pose2> truth, controls_alone;
  for (const StampedPose& p : d.truth.poses) truth[p.t] = p.pose;
  for (const StampedPose& p : dead_reckoning(d)) controls_alone[p.t] = p.pose;

  std::size_t scan = 0, updates = 0;
  double squared_error_sum = 0.0, dead_reckoning_squared_error_sum = 0.0;
  std::vector<std::uint64_t> per_scan;  // allocations of each step of the window, for the message
  per_scan.reserve(window_end - window_begin);
  std::uint64_t in_window = 0;
  // A relocalisation's joint search (a loop recognised, once per particle or so) sizes that
  // particle's search storage the first time: those scans are counted apart.
  std::size_t search_scans = 0;
  double searches = 0.0;
  test::AllocationCount step;
  for (const Event& e : d.events) {
    if (scan >= window_end) break;
    if (const auto* control = std::get_if<ControlEvent>(&e)) {
      filter.predict(*control);
      continue;
    }
    const auto& s = std::get<ScanEvent>(e);
    filter.update(s);
    const std::uint64_t n = step.count();
    const double searches_now = filter.statistics().at("relocalisation_searches");
    const bool searched = searches_now > searches;
    searches = searches_now;
    if (scan >= window_begin) {
      search_scans += searched ? 1 : 0;
      in_window += searched ? 0 : n;
      per_scan.push_back(n);
      // Reading the estimate allocates nothing either; reading the landmarks would, so the map's
      // size is checked after the window.
      squared_error_sum += (filter.pose().head<2>() - truth.at(s.t).head<2>()).squaredNorm();
      const auto dr = controls_alone.upper_bound(s.t);  // the last control at or before the scan
      dead_reckoning_squared_error_sum += (std::prev(dr)->second.head<2>() - truth.at(s.t).head<2>()).squaredNorm();
      for (const AssociationRecord& r : filter.last_associations())
        updates += r.decision == AssociationDecision::kUpdate ? 1 : 0;
    }
    ++scan;
    // The surviving path grows by one pose per control for good: room for the rest of the run.
    if (scan == window_begin) filter.reserve(d.events.size(), 0);
    step = test::AllocationCount();
  }
  std::string steps;
  for (std::size_t i = 0; i < per_scan.size(); ++i)
    if (per_scan[i] > 0) steps += " scan " + std::to_string(window_begin + i) + ": " + std::to_string(per_scan[i]) + ";";
  EXPECT_EQ(in_window, 0u) << "allocations over scans " << window_begin << " to " << window_end
                           << " and their controls:" << steps << " (" << search_scans
                           << " of them ran a joint search and are not counted)";
  // FastSLAM 1.0 nn searched in 9 of the window's 243 scans, and in 11 once duplicates were fused
  // (weigh_duplicates: two fusions earlier in the run change the particles' histories).
  EXPECT_LE(search_scans, 12u) << "a loop is recognised once, not searched for at every scan";

  // Not vacuous: the filter really tracked the vehicle against a full map in the window.
  // Position errors are not aligned to the truth, so they include the drift no filter can see.
  const auto rms = [&](double sum) { return std::sqrt(sum / static_cast<double>(window_end - window_begin)); };
  const double rms_error = rms(squared_error_sum), dead_reckoning_rms_error = rms(dead_reckoning_squared_error_sum);
  std::printf("position RMSE over the window: %.3f m (dead reckoning %.3f m)\n", rms_error, dead_reckoning_rms_error);
  EXPECT_LT(rms_error, 2.5) << "position RMSE over the window [m]";
  EXPECT_LT(rms_error, dead_reckoning_rms_error) << "position RMSE over the window [m]";
  EXPECT_GT(updates, 10 * (window_end - window_begin)) << "landmark updates in the window";
  EXPECT_NEAR(static_cast<double>(filter.num_landmarks()), static_cast<double>(d.truth.landmarks.size()), 10.0);
}

// The mechanism on its own: maps made with a NodeStorage copy paths into recycled nodes.
TEST(PooledLandmarkTree, ChangesToSharedMapsRecycleNodes) {
  const WorkerPool threads(1);
  LandmarkTree::NodeStorage storage(threads);
  LandmarkTree base(&storage);
  for (int i = 0; i < 1000; ++i) {
    LandmarkGaussian lm;
    lm.id = i;
    base.push_back(lm);
  }
  std::vector<LandmarkTree> maps(10, base);
  // Each round, every map is a fresh copy of the base that changes 15 landmarks: ~15 path copies.
  const auto round = [&](int r) {
    for (std::size_t m = 0; m < maps.size(); ++m) {
      maps[m] = base;
      for (std::size_t k = 0; k < 15; ++k) maps[m].mutate((m * 97 + k * 61 + r) % 1000).covariance(0, 1) = r;
    }
  };
  round(0);
  const test::AllocationCount allocations;
  for (int r = 1; r <= 100; ++r) round(r);
  EXPECT_EQ(allocations.count(), 0u);
  for (std::size_t m = 0; m < maps.size(); ++m)
    for (std::size_t k = 0; k < 15; ++k)
      EXPECT_EQ(maps[m][(m * 97 + k * 61 + 100) % 1000].covariance(0, 1), 100.0);
  EXPECT_EQ(base[999].covariance(0, 1), 0.0);
  EXPECT_EQ(base[999].id, 999);
}

INSTANTIATE_TEST_SUITE_P(
    AllVariants, FastSlamAllocation,
    ::testing::Values(Case{1, AssociationMethod::kKnown, 1}, Case{2, AssociationMethod::kKnown, 1},
                      Case{1, AssociationMethod::kNearestNeighbour, 1}, Case{2, AssociationMethod::kNearestNeighbour, 1},
                      Case{1, AssociationMethod::kKnown, 2}, Case{2, AssociationMethod::kKnown, 2},
                      Case{1, AssociationMethod::kNearestNeighbour, 2}, Case{2, AssociationMethod::kNearestNeighbour, 2}),
    name);

}  // namespace
