#pragma once
// The moment form's storage, shared by JointGaussian and CompressedJointGaussian: the covariance in
// one dense column-major buffer of which only the LOWER triangle is meaningful. Symmetry therefore
// holds by construction (no symmetrisation pass), and every update touches half the matrix. Buffers
// grow by a quarter of their size, so adding a landmark does not reallocate each time (and the square
// buffer is at most 1.56x the covariance). Every temporary of a step lives in a member workspace that
// only grows, so once the map stops growing a step allocates nothing (tests/ekf_allocation_test.cpp).
#include <Eigen/Core>

#include "slamkit/filters/ekf_estimator.hpp"
#include "slamkit/filters/lower_downdate.hpp"

namespace slamkit {

class DenseCovarianceEstimator : public EkfEstimator {
 protected:
  /// Throws std::invalid_argument for a missing model.
  DenseCovarianceEstimator(std::shared_ptr<const MotionModel> motion,
                           std::shared_ptr<const ObservationModel> observation, const Pose2& initial_pose,
                           const Matrix3& initial_covariance);

  void reserve(std::size_t dim) override;
  void squeeze_stored_rows(std::size_t first, std::size_t count) override;
  Matrix2 calibration_covariance() const override { return diagonal_block<2>(kOffsetRow); }
  Matrix23 calibration_pose_covariance() const override { return p_.block<2, 3>(kOffsetRow, 0); }
  Matrix2 landmark_calibration_covariance(std::size_t index) const override {
    return p_.block<2, 2>(static_cast<Eigen::Index>(landmark_offset(index)), kOffsetRow);
  }
  void store_calibration_prior(const Matrix2& covariance) override {
    p_.block<2, 3>(kOffsetRow, 0).setZero();
    p_.block<2, 2>(kOffsetRow, kOffsetRow) = covariance;
  }

  /// Symmetric 2x2 or 3x3 diagonal block from the lower triangle.
  template <int N>
  Eigen::Matrix<double, N, N> diagonal_block(std::size_t offset) const {
    const auto o = static_cast<Eigen::Index>(offset);
    return p_.block<N, N>(o, o).template selfadjointView<Eigen::Lower>();
  }
  /// Stored covariance entry (i, j), read from the lower triangle.
  double stored_entry(std::size_t i, std::size_t j) const {
    return i > j ? p_(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j))
                 : p_(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i));
  }
  /// P -= C C^T on the stored lower triangle, C with dim_ rows (P -= A B^T with b).
  void downdate(const Eigen::Ref<const Eigen::MatrixXd>& c) { downdate(c, c); }
  void downdate(const Eigen::Ref<const Eigen::MatrixXd>& a, const Eigen::Ref<const Eigen::MatrixXd>& b) {
    const auto n = static_cast<Eigen::Index>(dim_);
    downdate_.apply(p_.topLeftCorner(n, n), a, b, pool_.pool.get());
  }

  Eigen::MatrixXd p_;  // capacity x capacity; lower triangle of the leading dim_ x dim_ block is P
  Eigen::Matrix<double, Eigen::Dynamic, 3> scratch3_;  // capacity x 3, reused by the time updates
  // capacity x one column per measurement row of the largest joint update so far: P H^T of the
  // current update.
  Eigen::MatrixXd pht_;
  LowerDowndate downdate_;

 private:
  /// Grows the covariance's buffers to the state's capacity, keeping the first `rows` rows.
  void grow_covariance(std::size_t rows);
};

}  // namespace slamkit
