// JointGaussian's inverse-distance landmarks (bearing only): their start with the origin in the state,
// the test of a bearing's linear reach, and the conversion to a point. The updates that predict
// them live with the others in joint_gaussian.cpp.
#include <Eigen/Core>
#include <span>
#include <stdexcept>

#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/models/inverse_distance.hpp"

namespace slamkit {

Eigen::Matrix<double, 2, 4> JointGaussian::point_jacobian(std::size_t index) const {
  Eigen::Matrix<double, 2, 4> j = Eigen::Matrix<double, 2, 4>::Zero();
  if (!inverse_distance_[index]) {
    j.leftCols<2>().setIdentity();
    return j;
  }
  j.leftCols<2>() =
      inverse_distance_point(index, x_).position_jacobian(x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(index))));
  j.rightCols<2>().setIdentity();
  return j;
}

std::size_t JointGaussian::add_inverse_distance_landmark(const Measurement& z, const InverseDistanceOptions& options) {
  if (!keeps_inverse_distance())
    throw std::logic_error("the invariant EKF's error is that of points; inverse-distance landmarks are kept by the "
                           "standard and first-estimates linearisations");
  require_bearing_only(*observation_, "an inverse-distance landmark");
  validate(options);
  reserve(dim_ + 4);
  apply_pending_motion();
  const InverseDistanceStart start = inverse_distance_start(*observation_, pose(), z, options);
  const Matrix3 vehicle = diagonal_block<3>(0);
  const InitialLandmark& p = start.parameters;
  write_rows(dim_, p.mean, p.gx, p.gx * vehicle * p.gx.transpose() + p.covariance);
  write_rows(dim_ + 2, start.origin, start.origin_gx, start.origin_gx * vehicle * start.origin_gx.transpose());
  append_landmark_rows(4);
  first_estimates_.push_back(start.origin);
  inverse_distance_.push_back(true);
  ++inverse_distance_held_;
  return num_landmarks() - 1;
}

bool JointGaussian::beyond_linear_reach(std::size_t index) const {
  if (!inverse_distance_[index]) return false;
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  return inverse_distance_point(index, x_).bearing_spread(*observation_, pose(), x_.segment<2>(l), p_(l + 1, l + 1)) >
         kInverseDistanceMaxBearingSpread;
}

void JointGaussian::convert_where_linear(std::span<const LandmarkObservation> batch) {
  for (const LandmarkObservation& o : batch) {
    if (!inverse_distance_[o.index]) continue;
    const auto l = static_cast<Eigen::Index>(landmark_offset(o.index));
    if (inverse_distance_point(o.index, x_).linearity(*observation_, pose(), x_.segment<2>(l), p_(l + 1, l + 1)) <
        kInverseDistanceLinearityThreshold)
      convert_to_point(o.index);
  }
}

void JointGaussian::convert_to_point(std::size_t index) {
  if (!inverse_distance_[index]) return;
  apply_pending_motion();
  const std::size_t offset = landmark_offset(index);
  const auto l = static_cast<Eigen::Index>(offset);
  const auto n = static_cast<Eigen::Index>(dim_);
  const Eigen::Matrix<double, 2, 4> j = point_jacobian(index);
  const Matrix2 g = j.leftCols<2>();
  const Matrix2 block = j * diagonal_block<4>(offset) * j.transpose();
  const Vector2 origin = x_.segment<2>(l + 2);
  x_.segment<2>(l) = inverse_distance_point(index, x_).position(x_.segment<2>(l));
  // The point's first estimate is where its first-estimates Jacobians had the landmark: the ray's
  // end taken from the origin's first estimate, so that the unobservable turn keeps its components.
  first_estimates_[index] += x_.segment<2>(l) - origin;
  // P(m, :) = G P(p, :) + P(origin, :) to first order, on the stored lower triangle: the four rows'
  // blocks left of them and their column blocks below them; the origin's rows then leave.
  for (Eigen::Index c = 0; c < l; ++c) p_.block<2, 1>(l, c) = g * p_.block<2, 1>(l, c) + p_.block<2, 1>(l + 2, c);
  for (Eigen::Index r = l + 4; r < n; ++r)
    p_.block<1, 2>(r, l) = p_.block<1, 2>(r, l) * g.transpose() + p_.block<1, 2>(r, l + 2);
  p_.block<2, 2>(l, l) = 0.5 * (block + block.transpose());
  remove_stored_rows(offset + 2, 2);
  inverse_distance_[index] = false;
  --inverse_distance_held_;
  ++inverse_distance_converted_;
}

}  // namespace slamkit
