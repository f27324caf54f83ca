// The EKF's covariance downdate against the machine's floating-point peak, both measured in the same
// run, on one core and on all of them.
//
// BM_FmaPeak: fused multiply-adds on 16 independent vectors of the widest width the build has, per
// thread: what the cores can do at most (2 flops per lane per multiply-add). BM_CovarianceDowndate:
// the kernel alone (LowerDowndate, P -= C C^T on the lower triangle with 2k = 20 columns, a scan of
// 10 observations). BM_EkfJointUpdate: the whole joint update of 10 observations through
// JointGaussian (Jacobians, P H^T, S and its factor, the triangular solve, the downdate), with only
// the downdate's flops counted, so its figure is a lower bound. Each reports GFLOP/s and "of_peak",
// its GFLOP/s over BM_FmaPeak's for the same number of threads, measured in this process.
//
// Time is the process's CPU time (all its threads), not wall time: on a shared machine a process
// gets a varying share of the cores, and CPU time measures what the code does with the time it is
// given. So every rate here is GFLOP per CPU-second, i.e. per core; with T threads on T otherwise
// idle cores the wall-clock rate is T times that.
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <algorithm>
#include <atomic>
#include <ctime>
#include <map>
#include <numeric>
#include <thread>
#include <vector>

#include "ekf_fixture.hpp"
#include "slamkit/filters/lower_downdate.hpp"
#include "slamkit/filters/worker_pool.hpp"

namespace {

using namespace slamkit;

using Packet = Eigen::internal::packet_traits<double>::type;
constexpr int kLanes = Eigen::internal::packet_traits<double>::size;
constexpr int kChains = 16;  // independent accumulators: more than FMA latency x pipes on current cores
constexpr int kObservations = 10;

unsigned all_cores() { return std::max(1U, std::thread::hardware_concurrency()); }

double fma_chains(long iterations) {
  using namespace Eigen::internal;
  Packet acc[kChains];
  for (int c = 0; c < kChains; ++c) acc[c] = pset1<Packet>(1.0 + c * 1e-3);
  const Packet a = pset1<Packet>(0.9999999), b = pset1<Packet>(1e-7);
  for (long i = 0; i < iterations; ++i)
    for (int c = 0; c < kChains; ++c) acc[c] = pmadd(acc[c], a, b);
  Packet sum = acc[0];
  for (int c = 1; c < kChains; ++c) sum = padd(sum, acc[c]);
  double lanes[kLanes];
  pstoreu(lanes, sum);
  return std::accumulate(lanes, lanes + kLanes, 0.0);
}

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// GFLOP per CPU-second of `threads` threads each running fma_chains, best of three tries.
double measure_peak(unsigned threads) {
  constexpr long kIterations = 20'000'000;
  double best = 0.0;
  for (int attempt = 0; attempt < 3; ++attempt) {
    std::atomic<bool> go{false};
    std::vector<std::thread> workers;
    std::vector<double> sink(threads);
    for (unsigned t = 0; t < threads; ++t)
      workers.emplace_back([&, t] {
        while (!go.load()) std::this_thread::yield();
        sink[t] = fma_chains(kIterations);
      });
    const double begin = process_cpu_seconds();
    go = true;
    for (std::thread& w : workers) w.join();
    const double seconds = process_cpu_seconds() - begin;
    benchmark::DoNotOptimize(sink.data());
    best = std::max(best, 2.0 * kChains * kLanes * static_cast<double>(kIterations) * threads / seconds * 1e-9);
  }
  return best;
}

/// The peak for `threads`, measured once per process.
double peak_gflops(unsigned threads) {
  static std::map<unsigned, double> measured;
  const auto it = measured.find(threads);
  if (it != measured.end()) return it->second;
  return measured[threads] = measure_peak(threads);
}

void report(benchmark::State& state, double flops_per_iteration, unsigned threads) {
  const double gflops = flops_per_iteration * static_cast<double>(state.iterations()) * 1e-9;
  state.counters["GFLOPs"] = benchmark::Counter(gflops, benchmark::Counter::kIsRate);
  // of_peak: GFLOP/s over the peak; a rate counter divides by the run's time, as GFLOPs does.
  state.counters["of_peak"] = benchmark::Counter(gflops / peak_gflops(threads), benchmark::Counter::kIsRate);
  state.counters["threads"] = threads;
}

void thread_args(benchmark::internal::Benchmark* b, std::vector<long> landmarks) {
  for (const long n : landmarks)
    for (const unsigned t : {1U, all_cores()}) {
      b->Args({n, static_cast<long>(t)});
      if (all_cores() == 1) break;
    }
}

void BM_FmaPeak(benchmark::State& state) {
  const auto threads = static_cast<unsigned>(state.range(0));
  for (auto _ : state) state.counters["GFLOPs"] = measure_peak(threads);
  state.counters["threads"] = threads;
}
BENCHMARK(BM_FmaPeak)->Arg(1)->Arg(all_cores())->Iterations(1)->Unit(benchmark::kMillisecond);

void BM_CovarianceDowndate(benchmark::State& state) {
  const auto n = static_cast<Eigen::Index>(3 + 2 * state.range(0));
  const auto threads = static_cast<unsigned>(state.range(1));
  constexpr Eigen::Index k = 2 * kObservations;
  // Small entries: the repeated subtraction stays far from overflow however long it runs.
  Eigen::MatrixXd p = Eigen::MatrixXd::Identity(n, n);
  const Eigen::MatrixXd c = 1e-4 * Eigen::MatrixXd::Random(n, k);
  WorkerPool pool(threads);
  LowerDowndate downdate;
  for (auto _ : state) {
    downdate.apply(p, c, c, &pool);
    benchmark::ClobberMemory();
  }
  report(state, 2.0 * LowerDowndate::fused_multiply_adds(static_cast<double>(n), k), threads);
}
// 150 landmarks: P (730 KB) stays in the second-level cache, so the figure is the kernel's
// arithmetic and its edges (the diagonal, the last rows short of a vector), not memory.
BENCHMARK(BM_CovarianceDowndate)
    ->Apply([](benchmark::internal::Benchmark* b) { thread_args(b, {150, 1000, 5000}); })
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);

void BM_EkfJointUpdate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto threads = static_cast<unsigned>(state.range(1));
  JointGaussian& ekf = bench::cached_joint_gaussian(n);
  ekf.use_threads(threads);
  // The landmarks added last are the ones near the vehicle, as a scan would see them.
  std::vector<LandmarkObservation> batch;
  for (int i = n - kObservations; i < n; ++i) {
    const auto index = static_cast<std::size_t>(i);
    const Vector2 z = ekf.observation_model().predict(ekf.pose(), ekf.landmark_position(index));
    batch.push_back({index, z + Vector2(0.01, 0.001)});
  }
  for (auto _ : state) benchmark::DoNotOptimize(ekf.update_landmarks(batch));
  ekf.use_threads(1);
  report(state, 2.0 * LowerDowndate::fused_multiply_adds(static_cast<double>(ekf.state_dim()), 2 * kObservations),
         threads);
}
BENCHMARK(BM_EkfJointUpdate)
    ->Apply([](benchmark::internal::Benchmark* b) { thread_args(b, {1000, 5000}); })
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
