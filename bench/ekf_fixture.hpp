#pragma once
// EKF-SLAM filters for the benchmarks, and the heap accounting the memory figures use.
#include <malloc.h>

#include <cstddef>
#include <memory>
#include <numeric>
#include <random>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"

namespace slamkit::bench {

/// The control make_ekf drives with: 3 m/s on a circle of about 80 m radius.
inline Control ekf_control() {
  Control u(2);
  u << 3.0, 0.05;
  return u;
}

/// A joint Gaussian with `n` landmarks, each added 2-30 m from the vehicle one 25 ms prediction
/// after the previous one, so all are correlated through the vehicle as after a real run.
inline std::unique_ptr<JointGaussian> make_joint_gaussian(int n) {
  auto map = std::make_unique<JointGaussian>(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>());
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> range(2.0, 30.0), bearing(-kPi, kPi);
  const Control u = ekf_control();
  for (int i = 0; i < n; ++i) {
    map->predict(u, 0.025);
    map->add_landmark(Vector2(range(rng), bearing(rng)));
  }
  return map;
}

/// EKF-SLAM with known identities over the map of make_joint_gaussian(n), landmark i with id i.
inline std::unique_ptr<EkfSlam> make_ekf(int n) {
  std::vector<int> ids(static_cast<std::size_t>(n));
  std::iota(ids.begin(), ids.end(), 0);
  return std::make_unique<EkfSlam>(make_joint_gaussian(n), ids);
}

/// The map of one size, kept between the runs Google Benchmark makes of that size: at 5000
/// landmarks a map takes seconds to build and holds gigabytes, so it is built once per size, and
/// the previous one is freed before the next is built, so at most one is ever alive.
struct EkfCache {
  std::unique_ptr<JointGaussian> estimator;  // for the estimator's own operations
  std::unique_ptr<EkfSlam> filter;           // for whole scans
  int landmarks = -1;
};

inline EkfCache& ekf_cache() {
  static EkfCache cache;
  return cache;
}

inline JointGaussian& cached_joint_gaussian(int n) {
  EkfCache& cache = ekf_cache();
  if (!cache.estimator || cache.landmarks != n) {
    cache = {};
    cache.estimator = make_joint_gaussian(n);
    cache.landmarks = n;
  }
  return *cache.estimator;
}

inline EkfSlam& cached_ekf(int n) {
  EkfCache& cache = ekf_cache();
  if (!cache.filter || cache.landmarks != n) {
    cache = {};
    cache.filter = make_ekf(n);
    cache.landmarks = n;
  }
  return *cache.filter;
}

/// Frees the cached map, e.g. before a benchmark that measures memory.
inline void drop_cached_ekf() { ekf_cache() = {}; }

/// Bytes the allocator has handed out and not had back, mapped chunks included. The delta across a
/// construction is what the object holds, whatever pages the allocator happens to reuse (an RSS
/// delta is not: freed heap pages stay resident and are handed out again).
inline std::size_t heap_bytes_in_use() {
  const struct mallinfo2 info = mallinfo2();
  return info.uordblks + info.hblkhd;
}

}  // namespace slamkit::bench
