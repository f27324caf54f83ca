// The compressed EKF against the full one: the cost of a step (8 time updates and a scan of 15
// known landmarks) as the map grows, with the vehicle inside one local area. The full EKF's step is
// O(n^2); the compressed one's depends on the area only, so it stays flat. What the compressed
// filter defers is paid once per area, by the flush (BM_CompressedEkfFlush), O(n^2 dim(A)).
//
// The map: 30 landmarks around the vehicle (the area's) and the rest hundreds of metres to
// kilometres away, all correlated through the vehicle as after a real run.
#include <benchmark/benchmark.h>

#include <memory>
#include <random>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/ekf_slam.hpp"

namespace {

using namespace slamkit;

constexpr int kLocalLandmarks = 30;
constexpr int kObserved = 15;
constexpr int kBuildBatch = 250;  // far landmarks added per area while building, then flushed

/// 3 m/s on a circle of ~7 m radius: the vehicle never leaves its area.
Control circling() {
  Control u(2);
  u << 3.0, 0.5;
  return u;
}

std::unique_ptr<EkfSlam> make_map(EkfVariant variant, int n) {
  EkfSlamOptions options;
  options.variant = variant;
  auto ekf = std::make_unique<EkfSlam>(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>(),
                                       options);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> near(2.0, 25.0), far(200.0, 3000.0), bearing(-kPi, kPi);
  const Control u = circling();
  for (int i = 0; i < n; ++i) {
    ekf->predict(u, 0.025);
    const double range = i < kLocalLandmarks ? near(rng) : far(rng);
    ekf->add_landmark(Vector2(range, bearing(rng)), i);
    // Landmarks added in an area join it; flushing now and then keeps the far ones out of the next.
    if (i % kBuildBatch == kBuildBatch - 1) ekf->flush_local_area();
  }
  ekf->flush_local_area();
  return ekf;
}

struct Cache {
  std::unique_ptr<EkfSlam> filter;
  EkfVariant variant = EkfVariant::kFull;
  int landmarks = -1;
};

/// One filter alive at a time: at 5000 landmarks each holds gigabytes.
EkfSlam& cached_map(EkfVariant variant, int n) {
  static Cache cache;
  if (cache.landmarks != n || cache.variant != variant) {
    cache = {};
    cache = {make_map(variant, n), variant, n};
  }
  return *cache.filter;
}

// The measurements miss the prediction by a little, so the update has work to do; the sign
// alternates from scan to scan, because a constant bias would drag the estimate out of its local area
// over the thousands of steps of a benchmark's repetitions, and every step after that would flush.
ScanEvent local_scan(const EkfSlam& ekf, double sign) {
  ScanEvent scan;
  for (int i = 0; i < kObserved; ++i) {
    const auto index = static_cast<std::size_t>(ekf.find_landmark(i));
    const Vector2 z = ekf.observation_model().predict(ekf.pose(), ekf.landmark_position(index));
    scan.observations.push_back({z + sign * Vector2(0.01, 0.001), i});
  }
  return scan;
}

void step(EkfSlam& ekf, const Control& u) {
  static double sign = 1.0;
  sign = -sign;
  for (int k = 0; k < 8; ++k) ekf.predict(u, 0.025);
  ekf.update(local_scan(ekf, sign));
}

void map_sizes(benchmark::internal::Benchmark* b) {
  for (const int variant : {0, 1})
    for (const int n : {500, 1000, 2000, 5000}) b->Args({variant, n});
  b->ArgNames({"compressed", "landmarks"});
}

EkfVariant variant_of(const benchmark::State& state) {
  return state.range(0) == 0 ? EkfVariant::kFull : EkfVariant::kCompressed;
}

double flushes(const EkfSlam& ekf) {
  const auto s = ekf.statistics();
  const auto it = s.find("local_area_flushes");
  return it == s.end() ? 0.0 : it->second;
}

void BM_EkfStep(benchmark::State& state) {
  const int n = static_cast<int>(state.range(1));
  EkfSlam& ekf = cached_map(variant_of(state), n);
  const Control u = circling();
  const double flushes_before = flushes(ekf);
  for (auto _ : state) step(ekf, u);
  state.SetComplexityN(n);
  state.counters["flushes"] = flushes(ekf) - flushes_before;  // 0: the loop stays in one area
}
BENCHMARK(BM_EkfStep)->Apply(map_sizes)->Unit(benchmark::kMicrosecond);

// The price of leaving an area: one step accumulates an update, the flush applies it to the map.
void BM_CompressedEkfFlush(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  EkfSlam& ekf = cached_map(EkfVariant::kCompressed, n);
  const Control u = circling();
  for (auto _ : state) {
    state.PauseTiming();
    step(ekf, u);
    state.ResumeTiming();
    ekf.flush_local_area();
  }
  state.SetComplexityN(n);
}
BENCHMARK(BM_CompressedEkfFlush)->Arg(500)->Arg(1000)->Arg(2000)->Arg(5000)->Unit(benchmark::kMillisecond);

}  // namespace
