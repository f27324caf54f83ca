#include "slamkit/filters/extended_information_filter.hpp"

#include <vector>

#include "slamkit/core/angles.hpp"

namespace slamkit {

bool ExtendedInformationFilter::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  apply_pending_motion();  // before the copy kept for a refusal, so that a refusal keeps the fold
  move_implausible_anchors(batch, nullptr);  // so does the FEJ-EKF's
  const auto n = static_cast<Eigen::Index>(dim_);
  const InformationGraph prior = graph_;
  Eigen::VectorXd information_gain = Eigen::VectorXd::Zero(n);  // H^T R^-1 nu
  add_linearised_information(batch, false, information_gain, linearisation_point(batch));
  if (!factorise()) {
    graph_ = prior;
    information_changed();
    return false;
  }
  // The EKF's x += P H^T S^-1 nu, in information form: (Omega + H^T R^-1 H)^-1 H^T R^-1 nu.
  // (Iterated: nu = z - h(x_i) + H (x_i - x), the iterated EKF's last step.)
  x_.head(n) += solve(information_gain);
  x_[2] = wrap_angle(x_[2]);
  return true;
}

std::size_t ExtendedInformationFilter::add_landmark(const InitialLandmark& landmark) {
  append_landmark_factor(landmark);  // the mean carries what the factor's vector would
  return num_landmarks() - 1;
}

void ExtendedInformationFilter::remove_landmark(std::size_t index) {
  apply_pending_motion();
  marginalise({false, {index}});
  remove_stored_landmark(index);
}

bool ExtendedInformationFilter::fuse_landmarks(std::span<const LandmarkPair> pairs) {
  if (pairs.empty()) return true;
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  // x = T y with y the state in which each duplicate's rows hold e = m_duplicate - m_original.
  std::vector<char> duplicate_row;
  const Sparse t = fusion_transform(pairs, duplicate_row);
  const Sparse fused = Sparse(t.transpose()) * graph_.to_sparse() * t;
  Eigen::VectorXd difference = Eigen::VectorXd::Zero(n);  // y's e rows, zero elsewhere
  for (const LandmarkPair& pair : pairs) {
    const auto d = static_cast<Eigen::Index>(landmark_offset(pair.duplicate));
    difference.segment<2>(d) = x_.segment<2>(d) - landmark_position(pair.original);
  }
  // Given e = 0 the rest keeps its block of information, and its mean, mu_r - Omega_rr^-1 Omega_re
  // (e - mu_e) given e, moves by Omega_rr^-1 Omega_re mu_e.
  Eigen::VectorXd shift = fused * difference;
  for (Eigen::Index i = 0; i < n; ++i)
    if (duplicate_row[static_cast<std::size_t>(i)]) shift[i] = 0.0;
  if (!replace_information(InformationGraph::from_sparse(conditioned_on_fusion(fused, duplicate_row)))) return false;
  x_.head(n) += solve(shift);
  x_[2] = wrap_angle(x_[2]);
  for (const LandmarkPair& pair : pairs)
    x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(pair.duplicate))) =
        x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(pair.original)));
  return true;
}

}  // namespace slamkit
