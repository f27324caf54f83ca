#pragma once
// EKF-SLAM filters for the benchmarks, and the heap accounting the memory figures use.
#include <malloc.h>

#include <cstddef>
#include <memory>
#include <random>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/ekf_slam.hpp"

namespace slamkit::bench {

/// The control make_ekf drives with: 3 m/s on a circle of about 80 m radius.
inline Control ekf_control() {
  Control u(2);
  u << 3.0, 0.05;
  return u;
}

/// An EKF with `n` landmarks, each added 2-30 m from the vehicle one 25 ms prediction after the
/// previous one, so all are correlated through the vehicle as after a real run. Landmark i has id i.
inline std::unique_ptr<EkfSlam> make_ekf(int n) {
  auto ekf = std::make_unique<EkfSlam>(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>());
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> range(2.0, 30.0), bearing(-kPi, kPi);
  const Control u = ekf_control();
  for (int i = 0; i < n; ++i) {
    ekf->predict(u, 0.025);
    ekf->add_landmark(Vector2(range(rng), bearing(rng)), i);
  }
  return ekf;
}

struct EkfCache {
  std::unique_ptr<EkfSlam> filter;
  int landmarks = -1;
};

inline EkfCache& ekf_cache() {
  static EkfCache cache;
  return cache;
}

/// The filter of `n` landmarks, kept between the runs Google Benchmark makes of one size: at 5000
/// landmarks a filter takes seconds to build and holds gigabytes, so it is built once per size, and
/// the previous size's filter is freed before the next is built, so at most one is ever alive.
inline EkfSlam& cached_ekf(int n) {
  EkfCache& cache = ekf_cache();
  if (cache.landmarks != n) {
    cache = {};
    cache = {make_ekf(n), n};
  }
  return *cache.filter;
}

/// Frees the cached filter, e.g. before a benchmark that measures memory.
inline void drop_cached_ekf() { ekf_cache() = {}; }

/// Bytes the allocator has handed out and not had back, mapped chunks included. The delta across a
/// construction is what the object holds, whatever pages the allocator happens to reuse (an RSS
/// delta is not: freed heap pages stay resident and are handed out again).
inline std::size_t heap_bytes_in_use() {
  const struct mallinfo2 info = mallinfo2();
  return info.uordblks + info.hblkhd;
}

}  // namespace slamkit::bench
