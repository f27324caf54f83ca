#include "slamkit/core/chi_square.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace slamkit::eval {

namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The expansions below need O(sqrt(dof)) terms, which bounds the dof that can be served in
// reasonable time; 1e10 is far beyond any NEES dimension times run count.
constexpr double kMaxDof = 1e10;

void check_dof(double dof) {
  if (!(dof > 0.0 && dof <= kMaxDof))
    throw std::invalid_argument("chi-square degrees of freedom must lie in (0, 1e10], got " +
                                std::to_string(dof));
}

/// Both regularized incomplete gamma functions, P(a, y) = gamma(a, y) / Gamma(a) and Q = 1 - P.
/// Whichever of the two is evaluated directly is accurate to relative precision; the other is its
/// complement. Callers that need a small tail probability read the directly evaluated one, which is
/// always the smaller of the two away from y ~ a.
struct GammaPQ {
  double p;
  double q;
};

/// ln(y^a e^-y / Gamma(a)), the factor shared by the series and the continued fraction and the
/// density of ln(y) for y ~ Gamma(a); in logs because each part overflows long before the product does.
double log_prefactor(double a, double y) {
  if (a < 100.0) return a * std::log(y) - y - std::lgamma(a);
  // For large a the three terms above are each ~ a ln a but cancel to O(ln a) near y ~ a, leaving an
  // absolute error of ~ eps a ln a (1e-10 at a = 5e4). Regrouped about y = a with Stirling's series
  // lgamma(a) = (a - 1/2) ln a - a + ln(2 pi) / 2 + S(a), only O(sqrt(a))-sized terms remain there.
  const double d = y - a;
  // log1p is exact near y = a, where it matters; far from a, y - a has lost y's low digits and y / a
  // is the better argument (the result is then large and needs no absolute precision).
  const double log_ratio = std::abs(d) < 0.5 * a ? std::log1p(d / a) : std::log(y / a);
  const double inv_a2 = 1.0 / (a * a);
  // S(a) truncated after the a^-5 term: the next is 1 / (1680 a^7) < 1e-17 for a >= 100.
  const double stirling = (1.0 / 12.0 - inv_a2 * (1.0 / 360.0 - inv_a2 / 1260.0)) / a;
  return a * log_ratio - d + 0.5 * std::log(a / (2.0 * std::numbers::pi)) - stirling;
}

GammaPQ regularized_gamma(double a, double y) {
  if (y <= 0.0) return {0.0, 1.0};
  if (y == kInf) return {1.0, 0.0};
  const double prefactor = std::exp(log_prefactor(a, y));
  // Both expansions need O(sqrt(a)) terms when y is close to a (the terms' decay rate there is
  // ~ exp(-n^2 / 2a)), so the iteration cap has to grow with a.
  const long max_iterations = 1000 + static_cast<long>(50.0 * std::sqrt(a));

  if (y < a + 1.0) {
    // Series gamma(a, y) = y^a e^-y sum_n y^n / (a (a+1) ... (a+n)): every term is positive, so it
    // has no cancellation, and below y = a + 1 the term ratio y / (a + n) is below 1 from the start.
    double term = 1.0 / a;
    double sum = term;
    for (long n = 1; n <= max_iterations; ++n) {
      term *= y / (a + static_cast<double>(n));
      sum += term;
      if (term < sum * kEps) {
        const double p = std::min(1.0, prefactor * sum);
        return {p, 1.0 - p};
      }
    }
  } else {
    // Legendre's continued fraction for Gamma(a, y) = y^a e^-y / (y + 1 - a - 1 (1 - a) / (y + 3 - a
    // - 2 (2 - a) / (y + 5 - a - ...))), evaluated front to back with the modified Lentz method so
    // the number of terms need not be fixed in advance. It converges quickly for y > a + 1, exactly
    // where the series would be slow.
    constexpr double kTiny = 1e-300;  // stands in for a zero denominator, as Lentz prescribes
    double b = y + 1.0 - a;
    double c = 1.0 / kTiny;
    double d = 1.0 / b;
    double fraction = d;
    for (long i = 1; i <= max_iterations; ++i) {
      const double an = -static_cast<double>(i) * (static_cast<double>(i) - a);
      b += 2.0;
      d = an * d + b;
      if (std::abs(d) < kTiny) d = kTiny;
      c = b + an / c;
      if (std::abs(c) < kTiny) c = kTiny;
      d = 1.0 / d;
      const double delta = c * d;
      fraction *= delta;
      if (std::abs(delta - 1.0) < kEps) {
        const double q = std::min(1.0, prefactor * fraction);
        return {1.0 - q, q};
      }
    }
  }
  throw std::runtime_error("incomplete gamma function did not converge for a = " + std::to_string(a) +
                           ", y = " + std::to_string(y));
}

}  // namespace

double chi_square_cdf(double x, double dof) {
  check_dof(dof);
  if (std::isnan(x)) return x;
  return regularized_gamma(0.5 * dof, 0.5 * x).p;
}

double chi_square_quantile(double p, double dof) {
  check_dof(dof);
  if (!(p >= 0.0 && p <= 1.0))
    throw std::invalid_argument("chi-square quantile needs a probability in [0, 1], got " +
                                std::to_string(p));
  if (p == 0.0) return 0.0;
  if (p == 1.0) return kInf;

  const double a = 0.5 * dof;
  // Above the median the root is found on Q = 1 - p instead of P = p: 1 - p is exact there
  // (Sterbenz), and Q is evaluated directly in the upper tail, so no digits are lost to 1 - P.
  const bool upper = p > 0.5;
  const double target = upper ? 1.0 - p : p;
  // Solved for u = ln(x / 2): the quantile spans hundreds of orders of magnitude across p and dof,
  // and in u bisection and the stopping tolerance are both relative precision in x. The residual is
  // increasing in u in both branches.
  const auto residual = [&](double u) {
    const GammaPQ g = regularized_gamma(a, std::exp(u));
    return upper ? target - g.q : g.p - target;
  };
  // d P(a, e^u) / du, the density of u.
  const auto slope = [&](double u) { return std::exp(log_prefactor(a, std::exp(u))); };

  // gamma(a, y) <= y^a / a (drop e^-t from its integrand), so P(a, y) <= y^a / Gamma(a + 1) and the
  // y solving y^a / Gamma(a + 1) = p lies at or below the quantile. For small p it is also very close.
  double u_lo = (std::log(p) + std::lgamma(a + 1.0)) / a;
  double r_lo = residual(u_lo);
  if (r_lo == 0.0) return 2.0 * std::exp(u_lo);
  double u_hi = std::max(u_lo, std::log(a)) + 1.0;
  double r_hi = residual(u_hi);
  while (r_hi < 0.0) {
    u_lo = u_hi;
    r_lo = r_hi;
    u_hi += 1.0;
    r_hi = residual(u_hi);
  }

  // Newton's method, kept inside the bracket: a step that would leave it, or that is not at least
  // halving the step before last (Newton stalling far from the root), is replaced by bisection, so
  // the iteration converges no matter how poor the start. The bracket test is inclusive because a
  // converged Newton step rounds to no step at all, landing on the endpoint u just became.
  double u = std::abs(r_lo) < std::abs(r_hi) ? u_lo : u_hi;
  double r = std::abs(r_lo) < std::abs(r_hi) ? r_lo : r_hi;
  double last_step = u_hi - u_lo;
  double step_before_last = last_step;
  // Bisection alone would reach the tolerance from any bracket in well under 300 steps.
  for (int iteration = 0; iteration < 300; ++iteration) {
    double next = u - r / slope(u);
    if (!(next >= u_lo && next <= u_hi) || std::abs(next - u) > 0.5 * std::abs(step_before_last))
      next = 0.5 * (u_lo + u_hi);
    step_before_last = last_step;
    last_step = next - u;
    u = next;
    // Relative precision in x, floored at a few ulps of u where |u| is large (x near underflow).
    const double tolerance = std::max(2e-14, 4.0 * kEps * std::abs(u));
    if (std::abs(last_step) <= tolerance || u_hi - u_lo <= tolerance) break;
    r = residual(u);
    if (r == 0.0) break;
    (r < 0.0 ? u_lo : u_hi) = u;
  }
  return 2.0 * std::exp(u);
}

Interval chi_square_interval(double confidence, double dof) {
  if (!(confidence > 0.0 && confidence < 1.0))
    throw std::invalid_argument("confidence must lie strictly between 0 and 1, got " +
                                std::to_string(confidence));
  const double tail = 0.5 * (1.0 - confidence);
  return {chi_square_quantile(tail, dof), chi_square_quantile(1.0 - tail, dof)};
}

Interval averaged_nees_interval(double confidence, int dof, int runs) {
  if (dof < 1 || runs < 1)
    throw std::invalid_argument("averaged NEES needs dof >= 1 and runs >= 1, got dof " + std::to_string(dof) +
                                ", runs " + std::to_string(runs));
  const Interval sum = chi_square_interval(confidence, static_cast<double>(dof) * runs);
  return {sum.lo / runs, sum.hi / runs};
}

}  // namespace slamkit::eval
