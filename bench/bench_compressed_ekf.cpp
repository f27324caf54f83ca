// The compressed EKF against the full one: the cost of a step (8 time updates and a scan of 15
// known landmarks) as the map grows, with the vehicle inside one local area. The full EKF's step is
// O(n^2); the compressed one's depends on the area only, so it stays flat. What the compressed
// filter defers is paid once per area, by the flush (BM_CompressedEkfFlush), O(n^2 dim(A)).
//
// The map: 30 landmarks around the vehicle (the area's) and the rest hundreds of metres to
// kilometres away, all correlated through the vehicle as after a real run.
#include <benchmark/benchmark.h>

#include <memory>
#include <numeric>
#include <random>
#include <type_traits>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/compressed_joint_gaussian.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"

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

/// Adds the map's n landmarks to an empty estimator, the vehicle circling.
template <class Estimator>
void fill(Estimator& map, int n) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> near(2.0, 25.0), far(200.0, 3000.0), bearing(-kPi, kPi);
  const Control u = circling();
  for (int i = 0; i < n; ++i) {
    map.predict(u, 0.025);
    const double range = i < kLocalLandmarks ? near(rng) : far(rng);
    map.add_landmark(Vector2(range, bearing(rng)));
    // Landmarks added in an area join it; flushing now and then keeps the far ones out of the next.
    if constexpr (std::is_same_v<Estimator, CompressedJointGaussian>)
      if (i % kBuildBatch == kBuildBatch - 1) map.flush_local_area();
  }
  if constexpr (std::is_same_v<Estimator, CompressedJointGaussian>) map.flush_local_area();
}

std::unique_ptr<CompressedJointGaussian> make_compressed_map(int n) {
  const double sensor_range = SensorLimits{}.max_range;
  auto map = std::make_unique<CompressedJointGaussian>(std::make_shared<AckermannModel>(),
                                                       std::make_shared<RangeBearingModel>(), sensor_range);
  fill(*map, n);
  return map;
}

/// EKF-SLAM with known identities over the map, landmark i with id i.
std::unique_ptr<EkfSlam> make_filter(EkfVariant variant, int n) {
  std::unique_ptr<EkfEstimator> map;
  if (variant == EkfVariant::kCompressed) {
    map = make_compressed_map(n);
  } else {
    auto full =
        std::make_unique<JointGaussian>(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>());
    fill(*full, n);
    map = std::move(full);
  }
  std::vector<int> ids(static_cast<std::size_t>(n));
  std::iota(ids.begin(), ids.end(), 0);
  return std::make_unique<EkfSlam>(std::move(map), ids);
}

/// One map alive at a time: at 5000 landmarks each holds gigabytes.
struct Cache {
  std::unique_ptr<EkfSlam> filter;
  std::unique_ptr<CompressedJointGaussian> compressed;  // on its own, to flush it by hand
  EkfVariant variant = EkfVariant::kFull;
  int landmarks = -1;
};

Cache& cache() {
  static Cache cache;
  return cache;
}

EkfSlam& cached_filter(EkfVariant variant, int n) {
  Cache& c = cache();
  if (!c.filter || c.landmarks != n || c.variant != variant) {
    c = {};
    c.filter = make_filter(variant, n);
    c.variant = variant;
    c.landmarks = n;
  }
  return *c.filter;
}

CompressedJointGaussian& cached_compressed_map(int n) {
  Cache& c = cache();
  if (!c.compressed || c.landmarks != n) {
    c = {};
    c.compressed = make_compressed_map(n);
    c.landmarks = n;
  }
  return *c.compressed;
}

// The measurements miss the prediction by a little, so the update has work to do; the sign
// alternates from scan to scan, because a constant bias would drag the estimate out of its local area
// over the thousands of steps of a benchmark's repetitions, and every step after that would flush.
Vector2 local_measurement(const EkfEstimator& map, std::size_t index, double sign) {
  return map.observation_model().predict(map.pose(), map.landmark_position(index)) + sign * Vector2(0.01, 0.001);
}

double next_sign() {
  static double sign = 1.0;
  sign = -sign;
  return sign;
}

/// 8 time updates and a scan of the kObserved landmarks near the vehicle, through the filter.
void step(EkfSlam& ekf, const Control& u) {
  const double sign = next_sign();
  for (int k = 0; k < 8; ++k) ekf.predict(ControlEvent{0.0, 0.025, u});
  ScanEvent scan;
  for (int i = 0; i < kObserved; ++i) {
    const auto index = static_cast<std::size_t>(ekf.find_landmark(i));
    scan.observations.push_back({local_measurement(ekf.estimator(), index, sign), i});
  }
  ekf.update(scan);
}

/// The same on the estimator alone.
void step(CompressedJointGaussian& map, const Control& u) {
  const double sign = next_sign();
  for (int k = 0; k < 8; ++k) map.predict(u, 0.025);
  map.begin_scan();
  for (int i = 0; i < kObserved; ++i) {
    const auto index = static_cast<std::size_t>(i);
    map.update_landmark(index, local_measurement(map, index, sign));
  }
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
  EkfSlam& ekf = cached_filter(variant_of(state), n);
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
  CompressedJointGaussian& map = cached_compressed_map(n);
  const Control u = circling();
  for (auto _ : state) {
    state.PauseTiming();
    step(map, u);
    state.ResumeTiming();
    map.flush_local_area();
  }
  state.SetComplexityN(n);
}
BENCHMARK(BM_CompressedEkfFlush)->Arg(500)->Arg(1000)->Arg(2000)->Arg(5000)->Unit(benchmark::kMillisecond);

}  // namespace
