// Memory: what the filters hold, and the machine's memory bandwidth, the bound on an EKF update.
//
// EKF-SLAM keeps its covariance dense, so its memory grows as O(n^2) in the landmarks; FastSLAM keeps
// O(landmarks) per particle in principle, but particles share unchanged subtrees of their maps, so it
// holds one map plus what each particle has changed since resampling.
//
// The bandwidth figures are measured in the same run as bench_ekf.cpp's observation update, whose
// "bandwidth" counter they bound: a streaming copy between two buffers far larger than the last-level
// cache (main memory), and a read-modify-write pass over a buffer the size of the covariance at a
// given landmark count (the access pattern of the update's rank-2 downdate, which reads and writes
// every element of the lower triangle once, from whichever level of the hierarchy the matrix fits).
#include <benchmark/benchmark.h>

#include <cstring>
#include <vector>

#include "ekf_fixture.hpp"
#include "fastslam_fixture.hpp"
#include "slamkit/filters/landmark_tree.hpp"

namespace {

using namespace slamkit;

// Arg: landmarks. The time is the filter's construction (n predictions and landmark initialisations,
// and the buffers' growth); the counters are the point.
void BM_EkfMemory(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  bench::drop_cached_ekf();
  const std::size_t before = bench::heap_bytes_in_use();
  std::unique_ptr<EkfSlam> ekf;
  for (auto _ : state) {
    ekf.reset();
    ekf = bench::make_ekf(n);
  }
  const auto held = static_cast<double>(bench::heap_bytes_in_use() - before);
  const auto dim = static_cast<double>(ekf->estimator().state_dim());
  state.counters["heap_bytes"] = held;
  state.counters["bytes_per_landmark"] = held / n;
  // The least a dense covariance can take: its lower triangle.
  state.counters["triangle_bytes"] = dim * (dim + 1.0) / 2.0 * 8.0;
}
BENCHMARK(BM_EkfMemory)
    ->Arg(10)->Arg(100)->Arg(1000)->Arg(2000)->Arg(5000)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

// Args: particles, landmarks. FastSLAM 2.0 with known identities after 50 scans (resampling when the
// ESS drops below half): the heap the filter holds, against deep copies of the map in every particle.
void BM_FastSlamMemory(benchmark::State& state) {
  const int particles = static_cast<int>(state.range(0));
  const int landmarks = static_cast<int>(state.range(1));
  const bench::Scene scene = bench::make_scene(landmarks, true);
  const std::size_t before = bench::heap_bytes_in_use();
  std::unique_ptr<FastSlam> filter;
  for (auto _ : state) {
    filter.reset();
    filter = std::make_unique<FastSlam>(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>(),
                                        bench::make_config(2, particles, AssociationMethod::kKnown, 1));
    filter->set_initial_map(scene.map);
    std::size_t k = 0;
    for (int s = 0; s < 50; ++s) bench::step(*filter, scene, k);
  }
  const auto held = static_cast<double>(bench::heap_bytes_in_use() - before);
  state.counters["heap_bytes"] = held;
  state.counters["bytes_per_particle"] = held / particles;
  state.counters["deep_copy_bytes"] = static_cast<double>(particles) * landmarks * sizeof(LandmarkGaussian);
}
BENCHMARK(BM_FastSlamMemory)
    ->ArgsProduct({{100, 1000}, {1000, 20000}})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

constexpr std::size_t kStreamBytes = std::size_t{256} << 20;

// Main-memory bandwidth: memcpy between two 256 MB buffers, counted as STREAM counts its copy (bytes
// read plus bytes written).
void BM_StreamCopy(benchmark::State& state) {
  std::vector<char> from(kStreamBytes, 1), to(kStreamBytes, 0);  // filled, so every page is mapped
  for (auto _ : state) {
    std::memcpy(to.data(), from.data(), kStreamBytes);
    benchmark::DoNotOptimize(to.data());
    benchmark::ClobberMemory();
  }
  state.counters["bandwidth"] =
      benchmark::Counter(2.0 * kStreamBytes * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_StreamCopy)->Unit(benchmark::kMillisecond);

// Arg: landmarks. One read-modify-write pass over d (d + 1) / 2 doubles, d = 3 + 2n: the lower
// triangle of the EKF covariance, the bytes an update reads and writes, so the working set (and the
// cache level it fits in) is the update's. The affine map keeps the values normal (it converges to
// 2), so no pass slows down on denormals.
void BM_ReadModifyWrite(benchmark::State& state) {
  const auto dim = static_cast<std::size_t>(3 + 2 * state.range(0));
  std::vector<double> a(dim * (dim + 1) / 2, 1.0);
  for (auto _ : state) {
    for (double& v : a) v = 0.5 * v + 1.0;
    benchmark::DoNotOptimize(a.data());
    benchmark::ClobberMemory();
  }
  state.counters["bandwidth"] = benchmark::Counter(2.0 * static_cast<double>(a.size() * sizeof(double)) *
                                                       static_cast<double>(state.iterations()),
                                                   benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ReadModifyWrite)->Arg(100)->Arg(1000)->Arg(5000)->Unit(benchmark::kMillisecond);

}  // namespace
