#pragma once
// The shape of a measurement's noise, beyond its covariance R: Gaussian (eq. 7 as written), or
// Student-t, whose heavy tails let a range read long by multipath or a misread bearing count for
// little instead of pulling the estimate (and, in a particle filter, instead of killing every
// particle that explained the rest of the scan). The known-identity gate still rejects gross
// outliers; the t likelihood handles those between one standard deviation and the gate.
//
// A Kalman update cannot take a t likelihood exactly. With a t as a scale mixture of Gaussians,
// N(nu; 0, S / w) with w ~ Gamma(dof / 2, dof / 2), the weight's expectation given the innovation nu
// of squared Mahalanobis distance m2 = nu^T S^-1 nu in d dimensions is (dof + d) / (dof + m2): the
// update uses R divided by it (one step of the variational scheme of Roth, Ozkan and Gustafsson,
// 2013). It is never made smaller than R: an innovation that is close should not make the filter more
// confident than its sensor, only a far one less.
//
// Multipath and a radio's non-line-of-sight path only ever lengthen a range, so such a sensor's
// outliers are read long (student-t-long). Where an outlier is decided, in the delayed start's fit
// (filters/landmark_initialiser.hpp), only a range read long may be left out: a range read short of a
// candidate position is evidence against it. The filters' updates and FastSLAM's weights keep the
// symmetric t: there an innovation is measured from a landmark estimate that the long ranges it has
// already taken in may have pushed outwards, so a good range can look short of it.
#include <string>

namespace slamkit {

enum class LikelihoodKind { kGaussian, kStudentT, kStudentTLong };

/// "gaussian", "student-t" or "student-t-long"; throws std::invalid_argument naming the accepted
/// values otherwise.
LikelihoodKind parse_likelihood_kind(const std::string& name);
std::string to_string(LikelihoodKind kind);

struct MeasurementLikelihood {
  LikelihoodKind kind = LikelihoodKind::kGaussian;
  /// Degrees of freedom of the t; the smaller, the heavier its tails (1 is the Cauchy, infinity
  /// the Gaussian). 4 is common for robust filtering: it keeps 95% of a Gaussian's efficiency.
  double dof = 4.0;

  /// Whether outliers are expected (either t).
  bool robust() const { return kind != LikelihoodKind::kGaussian; }
  /// Whether outliers are ranges read long (student-t-long), which needs a sensor that measures
  /// range.
  bool outliers_read_long() const { return kind == LikelihoodKind::kStudentTLong; }
  /// The factor R is multiplied by for an innovation at squared Mahalanobis distance m2 in d
  /// dimensions (1 for the Gaussian, or an m2 no greater than d).
  double noise_inflation(double m2, int d) const;
  /// log p(nu) for an innovation of squared Mahalanobis distance m2 under covariance S (its log
  /// determinant log_det_s), in d dimensions.
  double log_density(double m2, int d, double log_det_s) const;
};

/// Throws std::invalid_argument for degrees of freedom that are not positive and finite.
void validate(const MeasurementLikelihood& likelihood);

/// Throws std::invalid_argument if the likelihood takes outliers to be ranges read long and
/// `model_name`'s measurement has no range (range_row < 0).
void require_range_for(const MeasurementLikelihood& likelihood, int range_row, const std::string& model_name);

}  // namespace slamkit
