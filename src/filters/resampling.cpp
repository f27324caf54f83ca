#include "slamkit/filters/resampling.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "slamkit/core/names.hpp"

namespace slamkit {

namespace {

/// Uniform in [0, 1) from the top 53 bits: every value a multiple of 2^-53, none rounded up to 1.
double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

void require_weights(std::span<const double> weights) {
  if (weights.empty()) throw std::invalid_argument("resampling needs at least one weight");
}

double total(std::span<const double> weights) {
  double sum = 0.0;
  for (const double w : weights) sum += w;
  return sum;
}

/// Appends to `out`, for each of the sorted points p_0 <= p_1 <= ... (given as point(k), in units of
/// the total weight), the index of the weight whose cumulative interval holds it.
template <class Point>
void select(std::span<const double> weights, std::size_t count, Point point, std::vector<std::size_t>& out) {
  const std::size_t last = weights.size() - 1;
  // A point rounded up to the total would fall off the end onto trailing zero weights; the
  // cumulative sum below adds in the same order as total(), so it reaches exactly this value.
  const double below_total = std::nextafter(total(weights), 0.0);
  std::size_t i = 0;
  double cumulative = weights[0];
  for (std::size_t k = 0; k < count; ++k) {
    const double p = std::min(point(k), below_total);
    while (p >= cumulative && i < last) cumulative += weights[++i];
    out.push_back(i);
  }
}

/// `count` draws from the weights (not necessarily normalised), appended in sorted order. Sorted
/// uniforms are the normalised partial sums of count + 1 exponential variates (the uniform order
/// statistics), which makes the draw O(N) instead of a binary search per draw.
void draw_multinomial(std::span<const double> weights, std::size_t count, std::mt19937_64& rng,
                      std::vector<double>& points, std::vector<std::size_t>& out) {
  if (count == 0) return;
  points.resize(count);
  double sum = 0.0;
  for (double& p : points) {
    sum += -std::log1p(-uniform01(rng));
    p = sum;
  }
  sum += -std::log1p(-uniform01(rng));
  const double scale = total(weights) / sum;
  select(weights, count, [&](std::size_t k) { return points[k] * scale; }, out);
}

void multinomial(std::span<const double> weights, std::mt19937_64& rng, ResampleScratch& scratch,
                 std::vector<std::size_t>& out) {
  draw_multinomial(weights, weights.size(), rng, scratch.points, out);
}

void stratified(std::span<const double> weights, std::mt19937_64& rng, std::vector<std::size_t>& out) {
  const std::size_t n = weights.size();
  const double step = total(weights) / static_cast<double>(n);
  select(weights, n, [&](std::size_t k) { return (static_cast<double>(k) + uniform01(rng)) * step; }, out);
}

void systematic(std::span<const double> weights, std::mt19937_64& rng, std::vector<std::size_t>& out) {
  const std::size_t n = weights.size();
  const double step = total(weights) / static_cast<double>(n);
  const double offset = uniform01(rng);
  select(weights, n, [&](std::size_t k) { return (static_cast<double>(k) + offset) * step; }, out);
}

void residual(std::span<const double> weights, std::mt19937_64& rng, ResampleScratch& scratch,
              std::vector<std::size_t>& out) {
  const std::size_t n = weights.size();
  const double scale = static_cast<double>(n) / total(weights);
  scratch.whole.clear();
  scratch.residual.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double expected = weights[i] * scale;
    const double whole = std::floor(expected);
    scratch.whole.insert(scratch.whole.end(), static_cast<std::size_t>(whole), i);
    scratch.residual[i] = expected - whole;
  }
  scratch.rest.clear();
  draw_multinomial(scratch.residual, n - scratch.whole.size(), rng, scratch.points, scratch.rest);
  out.resize(n);
  std::merge(scratch.whole.begin(), scratch.whole.end(), scratch.rest.begin(), scratch.rest.end(), out.begin());
}

std::vector<std::size_t> resample_returning(ResampleMethod method, std::span<const double> weights,
                                            std::mt19937_64& rng) {
  ResampleScratch scratch;
  std::vector<std::size_t> parents;
  resample(method, weights, rng, scratch, parents);
  return parents;
}

}  // namespace

ResampleMethod parse_resample_method(const std::string& name) {
  if (name == "multinomial") return ResampleMethod::kMultinomial;
  if (name == "stratified") return ResampleMethod::kStratified;
  if (name == "systematic") return ResampleMethod::kSystematic;
  if (name == "residual") return ResampleMethod::kResidual;
  throw std::invalid_argument(
      unknown_name_message("resampling method", name, {"multinomial", "stratified", "systematic", "residual"}));
}

std::string to_string(ResampleMethod method) {
  switch (method) {
    case ResampleMethod::kMultinomial: return "multinomial";
    case ResampleMethod::kStratified: return "stratified";
    case ResampleMethod::kSystematic: return "systematic";
    case ResampleMethod::kResidual: return "residual";
  }
  return "systematic";
}

bool ResamplePolicy::should_resample(std::size_t scans, double ess, std::size_t particles) const {
  switch (kind) {
    case Kind::kAlways: return true;
    case Kind::kEvery: return scans % static_cast<std::size_t>(every) == 0;
    case Kind::kEss: return ess < ess_fraction * static_cast<double>(particles);
  }
  return false;
}

ResamplePolicy parse_resample_policy(const std::string& text) {
  constexpr const char* kForms = "expected always, every:K (K an integer >= 1) or ess:F (0 < F <= 1)";
  ResamplePolicy policy;
  if (text == "always") {
    policy.kind = ResamplePolicy::Kind::kAlways;
    return policy;
  }
  const auto colon = text.find(':');
  const std::string kind = text.substr(0, colon);
  const std::string value = colon == std::string::npos ? std::string() : text.substr(colon + 1);
  const char* first = value.data();
  const char* last = value.data() + value.size();
  if (kind == "every" && colon != std::string::npos) {
    int k = 0;
    const auto [end, ec] = std::from_chars(first, last, k);
    if (ec == std::errc() && end == last && k >= 1) {
      policy.kind = ResamplePolicy::Kind::kEvery;
      policy.every = k;
      return policy;
    }
    throw std::invalid_argument(fmt::format("bad resampling policy '{}': K must be an integer >= 1; {}", text, kForms));
  }
  if (kind == "ess" && colon != std::string::npos) {
    double f = 0.0;
    const auto [end, ec] = std::from_chars(first, last, f);
    if (ec == std::errc() && end == last && f > 0.0 && f <= 1.0) {
      policy.kind = ResamplePolicy::Kind::kEss;
      policy.ess_fraction = f;
      return policy;
    }
    throw std::invalid_argument(fmt::format("bad resampling policy '{}': F must be a number in (0, 1]; {}", text, kForms));
  }
  throw std::invalid_argument(
      fmt::format("unknown resampling policy '{}'{}; {}", text, did_you_mean(kind, {"always", "every", "ess"}), kForms));
}

std::string to_string(const ResamplePolicy& policy) {
  switch (policy.kind) {
    case ResamplePolicy::Kind::kAlways: return "always";
    case ResamplePolicy::Kind::kEvery: return fmt::format("every:{}", policy.every);
    case ResamplePolicy::Kind::kEss: return fmt::format("ess:{}", policy.ess_fraction);
  }
  return "always";
}

double effective_sample_size(std::span<const double> weights) {
  double sum_sq = 0.0;
  for (const double w : weights) sum_sq += w * w;
  return sum_sq > 0.0 ? 1.0 / sum_sq : 0.0;
}

std::optional<double> normalize_log_weights(std::span<const double> log_weights, std::vector<double>& weights) {
  weights.resize(log_weights.size());
  double max = -std::numeric_limits<double>::infinity();
  for (const double lw : log_weights)
    if (std::isfinite(lw)) max = std::max(max, lw);
  if (!std::isfinite(max)) {
    std::fill(weights.begin(), weights.end(), 1.0 / static_cast<double>(weights.size()));
    return std::nullopt;
  }
  // Shifting by the largest log-weight makes the largest term exp(0) = 1, so the sum is >= 1 and
  // neither overflows nor underflows whatever the scale of the log-likelihoods.
  double sum = 0.0;
  for (std::size_t i = 0; i < weights.size(); ++i) {
    weights[i] = std::isfinite(log_weights[i]) ? std::exp(log_weights[i] - max) : 0.0;
    sum += weights[i];
  }
  for (double& w : weights) w /= sum;
  return max + std::log(sum);
}

std::vector<std::size_t> resample_multinomial(std::span<const double> weights, std::mt19937_64& rng) {
  return resample_returning(ResampleMethod::kMultinomial, weights, rng);
}

std::vector<std::size_t> resample_stratified(std::span<const double> weights, std::mt19937_64& rng) {
  return resample_returning(ResampleMethod::kStratified, weights, rng);
}

std::vector<std::size_t> resample_systematic(std::span<const double> weights, std::mt19937_64& rng) {
  return resample_returning(ResampleMethod::kSystematic, weights, rng);
}

std::vector<std::size_t> resample_residual(std::span<const double> weights, std::mt19937_64& rng) {
  return resample_returning(ResampleMethod::kResidual, weights, rng);
}

std::vector<std::size_t> resample(ResampleMethod method, std::span<const double> weights,
                                  std::mt19937_64& rng) {
  return resample_returning(method, weights, rng);
}

void resample(ResampleMethod method, std::span<const double> weights, std::mt19937_64& rng,
              ResampleScratch& scratch, std::vector<std::size_t>& parents) {
  require_weights(weights);
  parents.clear();
  parents.reserve(weights.size());
  switch (method) {
    case ResampleMethod::kMultinomial: return multinomial(weights, rng, scratch, parents);
    case ResampleMethod::kStratified: return stratified(weights, rng, parents);
    case ResampleMethod::kSystematic: return systematic(weights, rng, parents);
    case ResampleMethod::kResidual: return residual(weights, rng, scratch, parents);
  }
  throw std::invalid_argument("unknown resampling method");
}

}  // namespace slamkit
