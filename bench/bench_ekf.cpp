// Cost of EKF-SLAM's updates against the number of landmarks in the joint state. The observation
// update must grow as O(n^2) (one symmetric rank-2 downdate of the covariance) and the time update as
// O(n) (vehicle block and vehicle-map cross-covariance only).
#include <benchmark/benchmark.h>

#include <random>

#include "slamkit/angles.hpp"
#include "slamkit/filters/ekf_slam.hpp"

namespace {

using namespace slamkit;

/// An EKF with `n` landmarks, all correlated through the vehicle, as after a real run.
EkfSlam make_filter(int n) {
  EkfSlam ekf(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>());
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> range(2.0, 30.0), bearing(-kPi, kPi);
  Control u(2);
  u << 3.0, 0.05;
  for (int i = 0; i < n; ++i) {
    ekf.predict(u, 0.025);
    ekf.add_landmark(Vector2(range(rng), bearing(rng)), i);
  }
  return ekf;
}

void BM_EkfObservationUpdate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  EkfSlam ekf = make_filter(n);
  std::size_t index = 0;
  for (auto _ : state) {
    const Vector2 z = ekf.observation_model().predict(ekf.pose(), ekf.landmark_position(index));
    benchmark::DoNotOptimize(ekf.update_landmark(index, z + Vector2(0.01, 0.001)));
    index = (index + 7919) % static_cast<std::size_t>(n);  // spread over the map, not one hot landmark
  }
  state.SetComplexityN(n);
  state.counters["state_dim"] = static_cast<double>(ekf.state_dim());
}
BENCHMARK(BM_EkfObservationUpdate)->RangeMultiplier(2)->Range(10, 2000)->Arg(2000)->Complexity(benchmark::oNSquared);

void BM_EkfTimeUpdate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  EkfSlam ekf = make_filter(n);
  Control u(2);
  u << 3.0, 0.05;
  for (auto _ : state) ekf.predict(u, 0.025);
  state.SetComplexityN(n);
}
BENCHMARK(BM_EkfTimeUpdate)->RangeMultiplier(2)->Range(10, 2000)->Arg(2000)->Complexity(benchmark::oN);

}  // namespace
