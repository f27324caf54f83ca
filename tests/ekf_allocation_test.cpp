// EKF-SLAM's per-step hot path (predict and update) must not touch the heap once the map has stopped
// growing: every workspace is sized during the first lap of the built-in world and reused on the
// second. Each mode a user can pick on the command line is driven through make_filter, as the CLI
// does, and checked for zero allocations over a stretch of the second lap, and for still tracking
// the truth there, so the count cannot be zero because the filter stopped doing its work.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <variant>
#include <vector>

#include "allocation_counter.hpp"
#include "slamkit/core/angles.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/sim/simulator.hpp"

using namespace slamkit;

namespace {

struct Mode {
  std::string name;
  AssociationMethod method;
  std::string update;   // FilterConfig::ekf_update
  std::string variant;  // FilterConfig::ekf_variant
};

std::ostream& operator<<(std::ostream& out, const Mode& m) { return out << m.name; }

/// The built-in world driven twice, with or without landmark identities (simulated once each).
const Dataset& built_in_world(bool ids) {
  static std::map<bool, Dataset> cache;
  auto it = cache.find(ids);
  if (it == cache.end()) {
    Scenario s = scenario("default");
    s.config.provide_ids = ids;
    it = cache.emplace(ids, simulate(s.world, s.config)).first;
  }
  return it->second;
}

class EkfAllocationFree : public ::testing::TestWithParam<Mode> {};

TEST_P(EkfAllocationFree, SecondLapMakesNoHeapAllocation) {
  const Mode& mode = GetParam();
  const Dataset& data = built_in_world(mode.method == AssociationMethod::kKnown);
  FilterConfig config;
  config.association.method = mode.method;
  config.ekf_update = parse_ekf_update(mode.update);
  config.ekf_variant = parse_ekf_variant(mode.variant);
  const std::unique_ptr<SlamFilter> filter = make_filter(config, data);

  // Scan i of the stream starts at event scan_events[i]; the truth at each scan time is looked up
  // now, as is everything else the counted stretch needs.
  std::vector<std::size_t> scan_events;
  for (std::size_t e = 0; e < data.events.size(); ++e)
    if (std::holds_alternative<ScanEvent>(data.events[e])) scan_events.push_back(e);
  std::map<double, Vector2> truth_at;
  for (const StampedPose& p : data.truth.poses) truth_at[p.t] = p.pose.head<2>();
  // The route is driven twice, and once the first lap is done the map no longer grows: the stretch
  // starts a little into the second lap. 250 scans with their controls are 50 s of driving.
  const std::size_t first = scan_events.size() * 55 / 100, last = first + 250;
  ASSERT_LT(last, scan_events.size());
  std::vector<Vector2> truth(last - first);
  for (std::size_t i = first; i < last; ++i)
    truth[i - first] = truth_at.at(std::get<ScanEvent>(data.events[scan_events[i]]).t);
  // Dead reckoning over the same stretch, the error the filter must stay well below.
  double dead_reckoning_error = 0.0;
  Pose2 integrated = data.initial_pose;
  for (std::size_t e = 0; e < scan_events[last]; ++e) {
    if (const auto* c = std::get_if<ControlEvent>(&data.events[e]))
      integrated = data.motion->predict(integrated, c->u, c->dt);
    else if (e >= scan_events[first])
      dead_reckoning_error += (integrated.head<2>() - truth_at.at(std::get<ScanEvent>(data.events[e]).t)).norm();
  }
  dead_reckoning_error /= double(last - first);

  auto step = [&](const Event& e) {
    if (const auto* c = std::get_if<ControlEvent>(&e))
      filter->predict(*c);
    else
      filter->update(std::get<ScanEvent>(e));
  };
  for (std::size_t e = 0; e < scan_events[first]; ++e) step(data.events[e]);
  const std::size_t landmarks = filter->num_landmarks();
  const bool compressed = mode.variant == "compressed";
  auto flushes = [&] { return compressed ? filter->statistics().at("local_area_flushes") : 0.0; };

  // Each scan with the controls before it is counted on its own, so that the compressed variant's
  // scans that leave a local area (a flush: O(n^2) products through Eigen's packing buffers) can be
  // told apart from the steps inside an area.
  double max_error = 0.0, sum_error = 0.0;
  std::size_t updates = 0, flush_scans = 0;
  std::uint64_t allocations = 0, flush_allocations = 0;
  for (std::size_t i = first; i < last; ++i) {
    const double flushes_before = flushes();
    std::uint64_t scan_allocations = 0;
    {
      const test::AllocationCount count;
      for (std::size_t e = scan_events[i]; e < scan_events[i + 1]; ++e) step(data.events[e]);
      const double error = (filter->pose().head<2>() - truth[i - first]).norm();
      max_error = std::max(max_error, error);
      sum_error += error;
      for (const AssociationRecord& r : filter->last_associations())
        updates += r.decision == AssociationDecision::kUpdate;
      scan_allocations = count.count();
    }
    if (flushes() > flushes_before) {
      ++flush_scans;
      flush_allocations += scan_allocations;
    } else {
      allocations += scan_allocations;
    }
  }
  EXPECT_EQ(allocations, 0u) << mode.name << ": heap allocations over " << last - first - flush_scans
                             << " scans of the second lap";
  EXPECT_GE(last - first - flush_scans, 200u);
  EXPECT_EQ(filter->num_landmarks(), landmarks) << "the map must have stopped growing";
  // Unaligned errors: on this stretch the filter is about 1.1 m off on average, dead reckoning 4.1 m.
  const double mean_error = sum_error / double(last - first);
  EXPECT_LT(mean_error, 0.35 * dead_reckoning_error) << "the filter must still track the vehicle";
  EXPECT_LT(max_error, 1.5);
  EXPECT_GT(updates, 10 * (last - first)) << "the filter must still pair observations with the map";
  if (compressed) {
    EXPECT_GT(flush_scans, 0u) << "the stretch must leave a local area";
    std::cout << "[          ] " << flush_scans << " local-area flushes, " << flush_allocations
              << " allocations in their scans\n";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Modes, EkfAllocationFree,
    ::testing::Values(Mode{"KnownJoint", AssociationMethod::kKnown, "joint", "full"},
                      Mode{"KnownSequential", AssociationMethod::kKnown, "sequential", "full"},
                      Mode{"NearestNeighbour", AssociationMethod::kNearestNeighbour, "joint", "full"},
                      Mode{"Jcbb", AssociationMethod::kJcbb, "joint", "full"},
                      Mode{"KnownIteratedFej", AssociationMethod::kKnown, "iterated", "fej"},
                      Mode{"KnownIteratedInvariant", AssociationMethod::kKnown, "iterated", "invariant"},
                      Mode{"CompressedKnown", AssociationMethod::kKnown, "joint", "compressed"},
                      Mode{"CompressedNearestNeighbour", AssociationMethod::kNearestNeighbour, "joint", "compressed"},
                      Mode{"CompressedJcbb", AssociationMethod::kJcbb, "joint", "compressed"}),
    [](const ::testing::TestParamInfo<Mode>& info) { return info.param.name; });

// On a large map the updates' products span a covariance far bigger than Eigen's stack buffers for
// packed operands (128 KB), which they would then take from the heap on every scan: the joint
// update's solve is tiled to stay below it, and the downdate packs into a workspace it keeps. 1,500
// landmarks (state dimension 3,003) is well past the point where an untiled update allocated (about
// 300 landmarks). The downdate is shared out over two threads: handing work to them must not
// allocate either.
class EkfLargeMapAllocationFree : public ::testing::TestWithParam<bool> {};

TEST_P(EkfLargeMapAllocationFree, KnownScansMakeNoHeapAllocation) {
  auto map = std::make_unique<JointGaussian>(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>());
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> range(2.0, 30.0), bearing(-kPi, kPi);
  Control u(2);
  u << 3.0, 0.05;
  constexpr int kLandmarks = 1500;
  std::vector<int> ids;
  for (int i = 0; i < kLandmarks; ++i) {
    map->predict(u, 0.025);
    map->add_landmark(Vector2(range(rng), bearing(rng)));
    ids.push_back(i);
  }
  map->use_threads(2);
  EkfSlamOptions options;
  options.joint_scan_update = GetParam();
  EkfSlam ekf(std::move(map), ids, options);
  const EkfEstimator& g = ekf.estimator();
  const ControlEvent control{0.0, 0.025, u};
  // The scan re-observes the 15 newest landmarks, a little off their predictions, alternately to
  // either side, so every scan has a real correction to make.
  ScanEvent scan;
  const auto observe = [&](double sign) {
    scan.observations.clear();
    for (int id = kLandmarks - 15; id < kLandmarks; ++id) {
      const Vector2 z = g.observation_model().predict(ekf.pose(), g.landmark_position(ekf.find_landmark(id)));
      scan.observations.push_back({z + sign * Vector2(0.05, 0.005), id});
    }
  };
  scan.observations.reserve(15);
  for (int warm = 0; warm < 2; ++warm) {
    for (int k = 0; k < 8; ++k) ekf.predict(control);
    observe(warm % 2 ? 1.0 : -1.0);
    ekf.update(scan);
  }
  const auto watched = ekf.find_landmark(kLandmarks - 1);
  const double variance_before = g.landmark_covariance(watched).trace();
  double vehicle_variance_predicted = 0.0;
  const test::AllocationCount count;
  for (int s = 0; s < 6; ++s) {
    for (int k = 0; k < 8; ++k) ekf.predict(control);
    observe(s % 2 ? 1.0 : -1.0);
    vehicle_variance_predicted = ekf.pose_covariance().trace();
    ekf.update(scan);
  }
  EXPECT_EQ(count.count(), 0u);
  EXPECT_EQ(ekf.landmarks().size(), static_cast<std::size_t>(kLandmarks));
  EXPECT_LT(g.landmark_covariance(watched).trace(), variance_before);
  EXPECT_LT(ekf.pose_covariance().trace(), vehicle_variance_predicted);
}

INSTANTIATE_TEST_SUITE_P(Updates, EkfLargeMapAllocationFree, ::testing::Values(true, false),
                         [](const ::testing::TestParamInfo<bool>& info) { return info.param ? "Joint" : "Sequential"; });

}  // namespace
