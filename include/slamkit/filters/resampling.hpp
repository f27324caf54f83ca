#pragma once
// Resampling for particle filters: the four standard schemes (Douc, Cappe and Moulines, "Comparison
// of resampling schemes for particle filtering", 2005), the policies deciding when to resample, and
// the log-weight normalisation that feeds them.
//
// Every scheme is unbiased: particle i gets N w_i copies on average. They differ in the variance of
// the copy counts, i.e. in how much randomness resampling itself adds:
//
//   multinomial  N independent draws                            copies ~ Binomial(N, w_i)
//   stratified   one uniform draw in each of the N strata        floor(N w_i) - 1 <= copies <= ceil(N w_i) + 1
//   systematic   one uniform offset shared by all N strata       floor(N w_i) <= copies <= ceil(N w_i)
//   residual     floor(N w_i) copies, the rest multinomial       copies >= floor(N w_i)
//
// All run in O(N): uniforms are generated already sorted and merged with the cumulative weights.
// The uniforms come from the generator's raw bits through a fixed transform, not the standard
// library's distributions, so a seed selects the same particles with every standard library.
#include <cstddef>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <vector>

namespace slamkit {

enum class ResampleMethod { kMultinomial, kStratified, kSystematic, kResidual };

/// "multinomial", "stratified", "systematic" or "residual"; throws std::invalid_argument naming the
/// accepted values otherwise.
ResampleMethod parse_resample_method(const std::string& name);
std::string to_string(ResampleMethod method);

/// When to resample, decided after each scan's weight update.
struct ResamplePolicy {
  enum class Kind {
    kAlways,  // after every scan
    kEvery,   // after every `every`-th scan
    kEss,     // when the effective sample size drops below ess_fraction * N
  };
  Kind kind = Kind::kEss;
  int every = 1;
  double ess_fraction = 0.5;

  /// `scans` counts the scans processed so far, this one included (1 after the first).
  bool should_resample(std::size_t scans, double ess, std::size_t particles) const;
};

/// "always", "every:K" (K an integer >= 1) or "ess:F" (F in (0, 1]); throws std::invalid_argument
/// with what was wrong and the accepted forms otherwise.
ResamplePolicy parse_resample_policy(const std::string& text);
/// The form parse_resample_policy reads.
std::string to_string(const ResamplePolicy& policy);

/// ESS = 1 / sum w_i^2 of normalised weights: N for uniform weights, 1 when one particle has all.
double effective_sample_size(std::span<const double> weights);

/// Normalises log-weights into `weights` (resized to match) by log-sum-exp, and returns the
/// log-sum-exp (the log of the normaliser). A NaN or infinite log-weight counts as zero weight.
/// Returns nullopt, with uniform weights, when no log-weight is finite: the measurement ruled out
/// every particle, and no particle is better than another.
std::optional<double> normalize_log_weights(std::span<const double> log_weights, std::vector<double>& weights);

/// Each scheme takes normalised weights (non-negative, summing to 1 up to rounding; the sum is
/// used as given, so rounding cannot run a draw off the end) and returns N = weights.size() parent
/// indices in non-decreasing order. Throws std::invalid_argument for empty weights.
std::vector<std::size_t> resample_multinomial(std::span<const double> weights, std::mt19937_64& rng);
std::vector<std::size_t> resample_stratified(std::span<const double> weights, std::mt19937_64& rng);
std::vector<std::size_t> resample_systematic(std::span<const double> weights, std::mt19937_64& rng);
std::vector<std::size_t> resample_residual(std::span<const double> weights, std::mt19937_64& rng);
std::vector<std::size_t> resample(ResampleMethod method, std::span<const double> weights,
                                  std::mt19937_64& rng);

/// The working vectors of the schemes, kept by a caller that resamples repeatedly so that, once
/// they have grown to the particle count, resampling does not allocate.
struct ResampleScratch {
  std::vector<double> points;      // multinomial draws: sorted uniforms
  std::vector<double> residual;    // residual: the fractional parts of N w_i
  std::vector<std::size_t> whole;  // residual: the floor(N w_i) copies
  std::vector<std::size_t> rest;   // residual: the copies drawn from the fractional parts
};

/// resample() into `parents` (its contents replaced), the same draw from the same generator state.
void resample(ResampleMethod method, std::span<const double> weights, std::mt19937_64& rng,
              ResampleScratch& scratch, std::vector<std::size_t>& parents);

}  // namespace slamkit
