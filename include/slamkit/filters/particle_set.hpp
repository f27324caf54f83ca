#pragma once
// The weighted particles of a particle filter, whatever a particle carries (landmark FastSLAM's pose
// and landmark tree, grid FastSLAM's pose and occupancy grid): their log-weights, the normalised
// weights the estimates read, the best particle, resampling by a policy, a random stream per
// particle slot, the Gaussian the cloud stands for, and the tallies every particle filter reports
// (the mean effective sample size, resamples, weight collapses).
//
// A particle is any copyable type with a `Pose2 pose` and the `Matrix3 pose_cov` of the Gaussian it
// keeps about it (zero for a particle that is a point).
//
// A scan goes through it in two steps, so that a filter can read the best particle of the scan
// (its associations, say) before resampling moves the particles:
//   weigh(log_likelihoods);  // particle i's weight times exp(log_likelihoods[i]), normalised
//   resample_if_due();       // by the policy, on the effective sample size
//
// Log-weights are kept normalised (their log-sum-exp is zero), so they keep their precision however
// long the run: a weight far below the smallest double stays a finite log-weight that a later scan
// can raise again, where storing log(weight) would make it minus infinity for good.
//
// Slot i's random stream is the same whichever particle sits in slot i, and is seeded from (seed, i),
// so a run does not depend on how the slots are shared among threads.
//
// A resampled particle is a copy of its parent; the particles' maps and paths share their storage,
// so a copy costs O(1) whatever the map's size. The copies go through a second vector kept between
// scans so that resampling does not allocate once the set has run.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/random_draws.hpp"
#include "slamkit/core/types.hpp"
#include "slamkit/filters/resampling.hpp"

namespace slamkit {

template <class Particle>
class ParticleSet {
 public:
  /// `count` copies of `prototype` with equal weights; `seed` seeds the slots' streams and the
  /// resampling draws.
  ParticleSet(std::size_t count, const Particle& prototype, ResampleMethod method, const ResamplePolicy& policy,
              std::uint64_t seed)
      : particles_(count, prototype),
        log_weights_(count, -std::log(static_cast<double>(count))),
        weights_(count, 1.0 / static_cast<double>(count)),
        method_(method),
        policy_(policy),
        rng_(splitmix64(seed ^ 0x526573616d706c65ULL)) {
    if (count == 0) throw std::invalid_argument("a particle set needs at least one particle");
    streams_.reserve(count);
    for (std::size_t i = 0; i < count; ++i) streams_.emplace_back(splitmix64(splitmix64(seed) ^ i));
    next_.reserve(count);
    parents_.reserve(count);
  }

  std::size_t size() const { return particles_.size(); }
  Particle& operator[](std::size_t i) { return particles_[i]; }
  const Particle& operator[](std::size_t i) const { return particles_[i]; }
  Particle& front() { return particles_.front(); }
  const Particle& front() const { return particles_.front(); }
  auto begin() { return particles_.begin(); }
  auto end() { return particles_.end(); }
  auto begin() const { return particles_.begin(); }
  auto end() const { return particles_.end(); }

  /// Normalised: non-negative, summing to one.
  const std::vector<double>& weights() const { return weights_; }
  /// The highest-weight particle; after resampling, the first copy of the highest-weight parent drawn.
  std::size_t best() const { return best_; }
  const Particle& best_particle() const { return particles_[best_]; }
  /// The scans weighed so far.
  std::size_t weighed_scans() const { return scans_; }
  /// Slot i's random stream: one thread may draw from it while others draw from theirs.
  std::mt19937_64& stream(std::size_t slot) { return streams_[slot]; }

  /// The weighted mean pose (the heading's circular mean).
  Pose2 mean_pose() const {
    Pose2 mean = Pose2::Zero();
    double sin_sum = 0.0, cos_sum = 0.0;
    for (std::size_t i = 0; i < particles_.size(); ++i) {
      const Pose2& x = particles_[i].pose;
      mean.template head<2>() += weights_[i] * x.template head<2>();
      sin_sum += weights_[i] * std::sin(x[2]);
      cos_sum += weights_[i] * std::cos(x[2]);
    }
    mean[2] = std::atan2(sin_sum, cos_sum);
    return mean;
  }
  /// The mixture's covariance about the mean pose: the particles' spread plus the mean of the
  /// covariances they keep.
  Matrix3 pose_covariance() const {
    const Pose2 mean = mean_pose();
    Matrix3 covariance = Matrix3::Zero();
    for (std::size_t i = 0; i < particles_.size(); ++i) {
      Eigen::Vector3d d = particles_[i].pose - mean;
      d[2] = wrap_angle(d[2]);
      covariance += weights_[i] * (d * d.transpose() + particles_[i].pose_cov);
    }
    return 0.5 * (covariance + covariance.transpose());
  }
  std::vector<WeightedPose> pose_samples() const {
    std::vector<WeightedPose> samples(particles_.size());
    for (std::size_t i = 0; i < particles_.size(); ++i) samples[i] = {particles_[i].pose, weights_[i]};
    return samples;
  }

  /// Multiplies particle i's weight by exp(log_likelihoods[i]) and normalises. A NaN or infinite
  /// log-likelihood counts as zero weight; when every particle gets zero weight the scan told nothing
  /// (counted as a weight collapse) and the weights become equal.
  void weigh(std::span<const double> log_likelihoods) {
    if (log_likelihoods.size() != particles_.size())
      throw std::invalid_argument("a particle set is weighed with one log-likelihood per particle");
    for (std::size_t i = 0; i < particles_.size(); ++i) log_weights_[i] += log_likelihoods[i];
    if (const std::optional<double> log_sum = normalize_log_weights(log_weights_, weights_)) {
      for (double& lw : log_weights_) lw = std::isfinite(lw) ? lw - *log_sum : -std::numeric_limits<double>::infinity();
    } else {
      ++collapses_;
      equalise();
    }
    best_ = static_cast<std::size_t>(std::max_element(weights_.begin(), weights_.end()) - weights_.begin());
    ess_ = effective_sample_size(weights_);
    ess_sum_ += ess_;
    ++scans_;
  }

  /// Resamples when the policy asks for it after the scans weighed so far; returns whether it did.
  bool resample_if_due() {
    if (!policy_.should_resample(scans_, ess_, particles_.size())) return false;
    resample(method_, weights_, rng_, scratch_, parents_);
    for (const std::size_t parent : parents_) next_.push_back(particles_[parent]);
    std::size_t new_best = 0;
    for (std::size_t j = 1; j < parents_.size(); ++j)
      if (weights_[parents_[j]] > weights_[parents_[new_best]]) new_best = j;
    best_ = new_best;
    particles_.swap(next_);
    // Emptied now, not at the next resampling: the parents' copies it holds would keep their maps'
    // storage shared, so that every write copied.
    next_.clear();
    equalise();
    ++resamples_;
    return true;
  }

  /// The tallies of the scans weighed so far: particles, ess_mean, resamples, weight_collapses.
  void add_statistics(std::map<std::string, double>& statistics) const {
    const auto n = static_cast<double>(particles_.size());
    statistics["particles"] = n;
    statistics["ess_mean"] = scans_ > 0 ? ess_sum_ / static_cast<double>(scans_) : n;
    statistics["resamples"] = static_cast<double>(resamples_);
    statistics["weight_collapses"] = static_cast<double>(collapses_);
  }

 private:
  void equalise() {
    std::fill(weights_.begin(), weights_.end(), 1.0 / static_cast<double>(particles_.size()));
    std::fill(log_weights_.begin(), log_weights_.end(), -std::log(static_cast<double>(particles_.size())));
  }

  std::vector<Particle> particles_, next_;
  std::vector<double> log_weights_, weights_;
  ResampleMethod method_;
  ResamplePolicy policy_;
  std::mt19937_64 rng_;
  std::vector<std::mt19937_64> streams_;
  ResampleScratch scratch_;
  std::vector<std::size_t> parents_;
  std::size_t best_ = 0, scans_ = 0, resamples_ = 0, collapses_ = 0;
  double ess_ = 0.0, ess_sum_ = 0.0;
};

}  // namespace slamkit
