#include "slamkit/models/measurement_likelihood.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "slamkit/core/names.hpp"

namespace slamkit {

LikelihoodKind parse_likelihood_kind(const std::string& name) {
  if (name == "gaussian") return LikelihoodKind::kGaussian;
  if (name == "student-t") return LikelihoodKind::kStudentT;
  if (name == "student-t-long") return LikelihoodKind::kStudentTLong;
  throw std::invalid_argument(unknown_name_message("likelihood", name, {"gaussian", "student-t", "student-t-long"}));
}

std::string to_string(LikelihoodKind kind) {
  switch (kind) {
    case LikelihoodKind::kStudentT:
      return "student-t";
    case LikelihoodKind::kStudentTLong:
      return "student-t-long";
    case LikelihoodKind::kGaussian:
      break;
  }
  return "gaussian";
}

double MeasurementLikelihood::noise_inflation(double m2, int d) const {
  if (!robust() || !(m2 > d)) return 1.0;
  return (dof + m2) / (dof + d);
}

double MeasurementLikelihood::log_density(double m2, int d, double log_det_s) const {
  const double half_d = 0.5 * d;
  if (!robust()) return -0.5 * m2 - half_d * std::log(2.0 * std::numbers::pi) - 0.5 * log_det_s;
  return std::lgamma(0.5 * (dof + d)) - std::lgamma(0.5 * dof) - half_d * std::log(dof * std::numbers::pi) -
         0.5 * log_det_s - 0.5 * (dof + d) * std::log1p(m2 / dof);
}

void require_range_for(const MeasurementLikelihood& likelihood, int range_row, const std::string& model_name) {
  if (likelihood.outliers_read_long() && range_row < 0)
    throw std::invalid_argument("the likelihood 'student-t-long' takes outliers to be ranges read long; the " +
                                model_name + " measurement has no range (use 'student-t')");
}

void validate(const MeasurementLikelihood& likelihood) {
  if (!(likelihood.dof > 0.0) || !std::isfinite(likelihood.dof))
    throw std::invalid_argument("the t likelihood's degrees of freedom must be positive and finite");
}

}  // namespace slamkit
