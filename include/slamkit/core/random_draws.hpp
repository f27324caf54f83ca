#pragma once
// Random draws shared across modules: draws fixed by the standard engine alone (the simulators' and
// made odometry's, which a seed must reproduce with every standard library), independent streams per
// particle slot, and pose draws from a Gaussian that may be singular.
#include <Eigen/Cholesky>
#include <cmath>
#include <cstdint>
#include <random>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

/// Uniform on [0, 1) from the top 53 bits: unlike std::uniform_real_distribution its output is fixed
/// by the standard engine alone, so a seed gives the same draws with every standard library.
inline double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

/// Standard normal draws by the Box-Muller transform over uniform01, for the same reason: the
/// standard library's normal_distribution differs between implementations.
class PortableGaussian {
 public:
  explicit PortableGaussian(std::uint64_t seed) : rng_(seed) {}

  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    // 1 - u lies in (0, 1], so the logarithm is finite.
    const double u1 = 1.0 - uniform01(rng_), u2 = uniform01(rng_);
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * kPi * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * kPi * u2);
  }

 private:
  std::mt19937_64 rng_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

/// SplitMix64's output function: seeds for separate generators from (seed, stream) that do not
/// overlap the way seed + stream would.
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// A draw from N(mean, cov), heading wrapped, for a positive semi-definite cov: the motion noise of
/// a two-entry control makes a rank-2 pose covariance, which LDLT factors where LLT would fail.
inline Pose2 sample_gaussian(const Pose2& mean, const Matrix3& cov, std::mt19937_64& rng) {
  const Eigen::LDLT<Matrix3> ldlt(cov);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector3d e;
  for (int i = 0; i < 3; ++i) e[i] = normal(rng);
  const Eigen::Vector3d scaled = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt().cwiseProduct(e);
  const Eigen::Vector3d correlated = ldlt.matrixL() * scaled;
  Pose2 x = mean + ldlt.transpositionsP().transpose() * correlated;
  x[2] = wrap_angle(x[2]);
  return x;
}

}  // namespace slamkit
