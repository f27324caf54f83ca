// Cost of FastSLAM: one step (the eight 25 ms predictions between two scans, then a scan of ~15
// observations) against the number of particles and against the number of landmarks in the map;
// resampling with shared (persistent) maps against deep copies; and the landmark tree's fan-out.
// The scene is fastslam_fixture.hpp's.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "fastslam_fixture.hpp"
#include "slamkit/filters/landmark_tree.hpp"

namespace {

using namespace slamkit;
using bench::make_config;
using bench::make_scene;
using bench::Scene;

void run_steps(benchmark::State& state, int version, int particles, int landmarks, AssociationMethod method,
               unsigned threads) {
  const bool known = method == AssociationMethod::kKnown;
  const Scene scene = make_scene(landmarks, known);
  FastSlam filter(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>(),
                  make_config(version, particles, method, threads));
  filter.set_initial_map(scene.map);
  std::size_t k = 0;
  for (auto _ : state) bench::step(filter, scene, k);
  state.counters["obs_per_scan"] = static_cast<double>(scene.scans.front().observations.size());
  state.counters["per_particle"] = benchmark::Counter(static_cast<double>(state.iterations()) * particles,
                                                     benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// Args: version, particles.
void BM_StepVsParticles(benchmark::State& state) {
  run_steps(state, static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), 100, AssociationMethod::kKnown, 1);
}
BENCHMARK(BM_StepVsParticles)
    ->ArgsProduct({{1, 2}, {10, 30, 100, 300, 1000}})
    ->Unit(benchmark::kMicrosecond);

// Args: version, particles; both threads of the machine.
void BM_StepVsParticlesTwoThreads(benchmark::State& state) {
  run_steps(state, static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), 100, AssociationMethod::kKnown, 2);
}
BENCHMARK(BM_StepVsParticlesTwoThreads)
    ->ArgsProduct({{1, 2}, {100, 1000}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

// Args: association (0 known, 1 nearest neighbour, 2 JCBB), landmarks; FastSLAM 2.0, 100 particles.
void BM_StepVsLandmarks(benchmark::State& state) {
  constexpr AssociationMethod kMethods[] = {AssociationMethod::kKnown, AssociationMethod::kNearestNeighbour,
                                            AssociationMethod::kJcbb};
  run_steps(state, 2, 100, static_cast<int>(state.range(1)), kMethods[state.range(0)], 1);
}
BENCHMARK(BM_StepVsLandmarks)
    ->ArgsProduct({{0, 1, 2}, {100, 1000, 5000, 20000, 50000}})
    ->Unit(benchmark::kMicrosecond);

/// A deep copy: what resampling costs when each particle owns its map outright.
LandmarkTree deep_copy(const LandmarkTree& map) {
  LandmarkTree copy;
  map.for_each([&](std::size_t, const LandmarkGaussian& lm) { copy.push_back(lm); });
  return copy;
}

// Args: shared (1) or deep copies (0), particles, landmarks. The parents are a systematic draw
// from skewed weights, as after a typical scan; the maps start distinct (each particle has
// changed a few landmarks since the last resampling).
void BM_ResampleMaps(benchmark::State& state) {
  const bool shared = state.range(0) == 1;
  const auto n = static_cast<std::size_t>(state.range(1));
  const auto m = static_cast<std::size_t>(state.range(2));
  LandmarkTree base;
  for (std::size_t i = 0; i < m; ++i) base.push_back(LandmarkGaussian{});
  std::vector<LandmarkTree> maps(n, base);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < 15; ++k) maps[i].mutate((i * 7919 + k * 104729) % m).covariance(0, 1) = 1.0;
  std::vector<double> weights(n);
  std::mt19937_64 rng(5);
  std::exponential_distribution<double> exponential(1.0);
  double sum = 0.0;
  for (double& w : weights) sum += (w = std::pow(exponential(rng), 4.0));
  for (double& w : weights) w /= sum;
  for (auto _ : state) {
    const std::vector<std::size_t> parents = resample_systematic(weights, rng);
    std::vector<LandmarkTree> next;
    next.reserve(n);
    for (const std::size_t p : parents) next.push_back(shared ? maps[p] : deep_copy(maps[p]));
    benchmark::DoNotOptimize(next.data());
  }
}
BENCHMARK(BM_ResampleMaps)
    ->ArgsProduct({{1, 0}, {100, 1000}, {100, 1000, 10000}})
    ->Unit(benchmark::kMicrosecond);

// The tree's fan-out: what one particle's scan costs the map after resampling has shared it, i.e.
// copy the map, change 15 landmarks near each other in index (landmarks seen together were mostly
// created together), and read them back. Arg: landmarks.
template <int FanOut>
void BM_TreeScanAfterResampling(benchmark::State& state) {
  const auto m = static_cast<std::size_t>(state.range(0));
  BasicLandmarkTree<FanOut> base;
  for (std::size_t i = 0; i < m; ++i) base.push_back(LandmarkGaussian{});
  std::mt19937_64 rng(3);
  for (auto _ : state) {
    BasicLandmarkTree<FanOut> mine = base;
    const std::size_t first = rng() % (m > 40 ? m - 40 : 1);
    for (std::size_t k = 0; k < 15; ++k) {
      const std::size_t i = std::min(m - 1, first + (rng() % 40));
      benchmark::DoNotOptimize(mine[i].mean);
      mine.mutate(i).covariance(0, 1) += 1.0;
    }
    benchmark::DoNotOptimize(mine.size());
  }
}
BENCHMARK_TEMPLATE(BM_TreeScanAfterResampling, 2)->Arg(100)->Arg(1000)->Arg(20000);
BENCHMARK_TEMPLATE(BM_TreeScanAfterResampling, 4)->Arg(100)->Arg(1000)->Arg(20000);
BENCHMARK_TEMPLATE(BM_TreeScanAfterResampling, 8)->Arg(100)->Arg(1000)->Arg(20000);
BENCHMARK_TEMPLATE(BM_TreeScanAfterResampling, 16)->Arg(100)->Arg(1000)->Arg(20000);

// Reading one landmark: the dependent pointer loads of a lookup. Arg: landmarks.
template <int FanOut>
void BM_TreeLookup(benchmark::State& state) {
  const auto m = static_cast<std::size_t>(state.range(0));
  BasicLandmarkTree<FanOut> tree;
  for (std::size_t i = 0; i < m; ++i) tree.push_back(LandmarkGaussian{});
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(tree[i].mean);
    i = (i + 7919) % m;
  }
}
BENCHMARK_TEMPLATE(BM_TreeLookup, 2)->Arg(20000);
BENCHMARK_TEMPLATE(BM_TreeLookup, 4)->Arg(20000);
BENCHMARK_TEMPLATE(BM_TreeLookup, 8)->Arg(20000);
BENCHMARK_TEMPLATE(BM_TreeLookup, 16)->Arg(20000);

}  // namespace
