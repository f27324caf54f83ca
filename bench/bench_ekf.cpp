// Cost of EKF-SLAM's updates against the number of landmarks in the joint state. The observation
// update must grow as O(n^2) (one symmetric rank-2 downdate of the covariance) and the time update as
// O(n) (vehicle block and vehicle-map cross-covariance only); a scan is one observation update per
// observation, so ~15 times the former.
//
// The observation update streams the covariance's lower triangle through the core once, read and
// written back, so its "bandwidth" counter (those bytes per second) is comparable with the memory
// bandwidth of bench_memory.cpp measured in the same run: how close the update is to the bound.
#include <benchmark/benchmark.h>

#include <algorithm>

#include "ekf_fixture.hpp"

namespace {

using namespace slamkit;
using bench::cached_ekf;
using bench::cached_joint_gaussian;

constexpr int kMaxLandmarks = 5000;

void ekf_landmark_counts(benchmark::internal::Benchmark* b) {
  for (const int n : {10, 30, 100, 300, 1000, 2000, kMaxLandmarks}) b->Arg(n);
}

/// Bytes of the covariance's lower triangle, read and written once.
double lower_triangle_traffic(std::size_t dim) { return 2.0 * (static_cast<double>(dim * (dim + 1)) / 2.0) * 8.0; }

void BM_EkfObservationUpdate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  JointGaussian& ekf = cached_joint_gaussian(n);
  std::size_t index = 0;
  for (auto _ : state) {
    const Vector2 z = ekf.observation_model().predict(ekf.pose(), ekf.landmark_position(index));
    benchmark::DoNotOptimize(ekf.update_landmark(index, z + Vector2(0.01, 0.001)));
    index = (index + 7919) % static_cast<std::size_t>(n);  // spread over the map, not one hot landmark
  }
  state.SetComplexityN(n);
  state.counters["state_dim"] = static_cast<double>(ekf.state_dim());
  state.counters["bandwidth"] = benchmark::Counter(lower_triangle_traffic(ekf.state_dim()) * static_cast<double>(state.iterations()),
                                                   benchmark::Counter::kIsRate);
}
BENCHMARK(BM_EkfObservationUpdate)->Apply(ekf_landmark_counts)->Complexity(benchmark::oNSquared);

// Per control: the vehicle block only. The map-vehicle cross-covariance takes the product of the
// controls' Jacobians once, at the next update (part of the observation update's O(n) work).
void BM_EkfTimeUpdate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  JointGaussian& ekf = cached_joint_gaussian(n);
  const Control u = bench::ekf_control();
  for (auto _ : state) ekf.predict(u, 0.025);
  state.SetComplexityN(n);
}
BENCHMARK(BM_EkfTimeUpdate)->Apply(ekf_landmark_counts)->Complexity(benchmark::o1);

// A whole scan through EkfSlam::update with known identities: the 15 landmarks added last, which are
// the ones near the vehicle, observed from where it stands (with the outlier gate of known
// association, as the command line runs it).
void BM_EkfScanUpdate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  EkfSlam& ekf = cached_ekf(n);
  const EkfEstimator& map = ekf.estimator();
  const int seen = std::min(n, 15);
  ScanEvent scan;
  for (int i = n - seen; i < n; ++i) {
    const auto index = static_cast<std::size_t>(ekf.find_landmark(i));
    const Vector2 z = map.observation_model().predict(ekf.pose(), map.landmark_position(index));
    scan.observations.push_back({z + Vector2(0.01, 0.001), i});
  }
  for (auto _ : state) ekf.update(scan);
  state.SetComplexityN(n);
  state.counters["observations"] = static_cast<double>(seen);
}
BENCHMARK(BM_EkfScanUpdate)->Apply(ekf_landmark_counts)->Complexity(benchmark::oNSquared)->Unit(benchmark::kMillisecond);

}  // namespace
