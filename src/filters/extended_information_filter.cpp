#include "slamkit/filters/extended_information_filter.hpp"

#include <vector>

#include "slamkit/core/angles.hpp"

namespace slamkit {

bool ExtendedInformationFilter::update_landmark(const LandmarkObservation& observation) {
  return update_landmarks(std::span<const LandmarkObservation>(&observation, 1));
}

bool ExtendedInformationFilter::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  const Pose2 xv = pose();
  Triplets triplets;
  Eigen::VectorXd information_gain = Eigen::VectorXd::Zero(n);  // H^T R^-1 nu
  for (const LandmarkObservation& o : batch) {
    const auto l = static_cast<Eigen::Index>(landmark_offset(o.index));
    const Vector2 m = landmark_position(o.index);
    PoseJacobian hx;
    LandmarkJacobian hm;
    observation_->jacobians(xv, m, hx, hm);
    const Measurement nu = observation_->residual(o.z, observation_->predict(xv, m));
    const Eigen::MatrixXd r_inverse =
        spd_inverse(Eigen::MatrixXd(o.noise_scale * observation_->noise()), "a measurement noise");
    const Eigen::MatrixXd hx_t = hx.transpose() * r_inverse, hm_t = hm.transpose() * r_inverse;
    add_block(triplets, 0, 0, hx_t * hx);
    add_block(triplets, 0, l, hx_t * hm);
    add_block(triplets, l, 0, hm_t * hx);
    add_block(triplets, l, l, hm_t * hm);
    information_gain.head<3>() += hx_t * nu;
    information_gain.segment<2>(l) += hm_t * nu;
  }
  Sparse prior = omega_;
  set_information(omega_ + from_triplets(n, n, triplets));
  if (!factorise()) {
    set_information_pattern(std::move(prior));
    return false;
  }
  // The EKF's x += P H^T S^-1 nu, in information form: (Omega + H^T R^-1 H)^-1 H^T R^-1 nu.
  x_.head(n) += solve(information_gain);
  x_[2] = wrap_angle(x_[2]);
  return true;
}

std::size_t ExtendedInformationFilter::add_landmark(const InitialLandmark& landmark) {
  apply_pending_motion();
  const auto l = static_cast<Eigen::Index>(dim_);
  const Matrix2 information = spd_inverse(landmark.covariance, "a new landmark's covariance given the pose");
  reserve(dim_ + 2);
  x_.segment<2>(l) = landmark.mean;
  // The factor m - Gx x_v, its Jacobian [-Gx I] over (vehicle, landmark).
  const Eigen::Matrix<double, 3, 2> coupling = -landmark.gx.transpose() * information;
  Triplets triplets;
  add_block(triplets, 0, 0, -coupling * landmark.gx);
  add_block(triplets, 0, l, coupling);
  add_block(triplets, l, 0, coupling.transpose());
  add_block(triplets, l, l, information);
  Sparse grown = omega_;
  grown.conservativeResize(l + 2, l + 2);
  set_information(grown + from_triplets(l + 2, l + 2, triplets));
  append_landmark_rows(2);
  return num_landmarks() - 1;
}

void ExtendedInformationFilter::remove_landmark(std::size_t index) {
  apply_pending_motion();
  set_information(marginalised(index));
  remove_stored_landmark(index);
}

bool ExtendedInformationFilter::fuse_landmarks(std::span<const LandmarkPair> pairs) {
  if (pairs.empty()) return true;
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  // x = T y with y the state in which each duplicate's rows hold e = m_duplicate - m_original.
  std::vector<char> duplicate_row;
  const Sparse t = fusion_transform(pairs, duplicate_row);
  const Sparse fused = Sparse(t.transpose()) * omega_ * t;
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
  Sparse prior = omega_;
  set_information_pattern(conditioned_on_fusion(fused, duplicate_row));
  if (!factorise()) {
    set_information_pattern(std::move(prior));
    return false;
  }
  x_.head(n) += solve(shift);
  x_[2] = wrap_angle(x_[2]);
  for (const LandmarkPair& pair : pairs)
    x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(pair.duplicate))) =
        x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(pair.original)));
  return true;
}

}  // namespace slamkit
