#pragma once
// Chi-square distribution functions for consistency tests: the bounds a NEES (or NIS) value should
// fall within if the filter's covariance is honest. Computed here rather than tabulated because the
// degrees of freedom of an averaged NEES (dof x runs) are whatever the experiment makes them.
//
// Functions throw std::invalid_argument for degrees of freedom outside (0, 1e10] or a
// probability/confidence outside its range.

namespace slamkit::eval {

/// P(X <= x) for X ~ chi2(dof). dof may be fractional. 0 for x <= 0, 1 for x = +inf; a NaN x gives
/// NaN. The relative error is ~1e-14 in the body of the distribution; it grows with the size of
/// ln P in the far lower tail (3e-13 at P = 1e-200, dof = 1e5; 2e-12 there at dof = 1e6).
double chi_square_cdf(double x, double dof);

/// The x with chi_square_cdf(x, dof) == p, to ~1e-14 relative (~1e-13 where x is below ~1e-100).
/// p must lie in [0, 1]: p = 0 gives 0, p = 1 gives +inf. Upper-tail probabilities are resolved
/// through the complement, so a p such as 1 - 1e-12 is as accurate as 1e-12. A quantile below the
/// smallest double comes out as 0 or the smallest subnormal.
double chi_square_quantile(double p, double dof);

struct Interval {
  double lo = 0.0;
  double hi = 0.0;

  bool contains(double v) const { return v >= lo && v <= hi; }
};

/// The two-sided interval holding `confidence` of the chi2(dof) mass, equal tails:
/// [q((1 - c) / 2), q((1 + c) / 2)]. confidence must lie strictly between 0 and 1.
Interval chi_square_interval(double confidence, double dof);

/// Bounds for the average of `runs` independent NEES values of dimension `dof` (Bar-Shalom et al.,
/// "Estimation with Applications to Tracking and Navigation", sec. 5.4): runs x average is
/// chi2(dof x runs), so the interval is chi_square_interval(confidence, dof * runs) / runs. dof and
/// runs must be >= 1.
Interval averaged_nees_interval(double confidence, int dof, int runs);

}  // namespace slamkit::eval
