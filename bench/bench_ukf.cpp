// Cost of a UKF-SLAM step against the map size, beside the EKF's on the same map: one control and
// one joint update of the 10 landmarks nearest the vehicle (the last ones added). Both must grow as
// O(n^2), the UKF's sigma points being drawn over the vehicle and the 10 landmarks only.
#include <benchmark/benchmark.h>

#include <memory>
#include <random>
#include <vector>

#include "ekf_fixture.hpp"
#include "slamkit/filters/unscented_joint_gaussian.hpp"

namespace {

using namespace slamkit;

constexpr int kObservedPerScan = 10;

void gaussian_landmark_counts(benchmark::internal::Benchmark* b) {
  for (const int n : {10, 30, 100, 300, 1000, 2000}) b->Arg(n);
}

/// The map of make_joint_gaussian, built by the estimator under test; one cached at a time.
template <typename Estimator>
Estimator& cached_map(int n) {
  static std::unique_ptr<Estimator> map;
  static int size = -1;
  if (!map || size != n) {
    map.reset();
    map = std::make_unique<Estimator>(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>());
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> range(2.0, 30.0), bearing(-kPi, kPi);
    for (int i = 0; i < n; ++i) {
      map->predict(bench::ekf_control(), 0.025);
      map->add_landmark(Vector2(range(rng), bearing(rng)));
    }
    size = n;
  }
  return *map;
}

template <typename Estimator>
void BM_Step(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  Estimator& f = cached_map<Estimator>(n);
  const int seen = std::min(n, kObservedPerScan);
  std::vector<LandmarkObservation> scan;
  for (int i = n - seen; i < n; ++i) scan.push_back({static_cast<std::size_t>(i), Vector2::Zero()});
  for (auto _ : state) {
    f.predict(bench::ekf_control(), 0.025);
    // Observations a little off the estimate's prediction, so that the filter stays converged: one
    // fixed scan while the vehicle drives on made it diverge within a few thousand steps, to a
    // covariance no longer positive definite, and the UKF then timed its eigen-decomposition fallback.
    for (LandmarkObservation& o : scan)
      o.z = f.observation_model().predict(f.pose(), f.landmark_position(o.index)) + Vector2(0.01, 0.001);
    benchmark::DoNotOptimize(f.update_landmarks(scan));
  }
  state.SetComplexityN(n);
  state.counters["observations"] = seen;
}

BENCHMARK(BM_Step<JointGaussian>)->Name("BM_GaussianStep/ekf")->Apply(gaussian_landmark_counts)->Complexity(benchmark::oNSquared)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Step<UnscentedJointGaussian>)->Name("BM_GaussianStep/ukf")->Apply(gaussian_landmark_counts)->Complexity(benchmark::oNSquared)->Unit(benchmark::kMicrosecond);

}  // namespace
