#include "slamkit/filters/dense_covariance.hpp"

#include <algorithm>

#include "slamkit/filters/huge_pages.hpp"

namespace slamkit {

DenseCovarianceEstimator::DenseCovarianceEstimator(std::shared_ptr<const MotionModel> motion,
                                                   std::shared_ptr<const ObservationModel> observation,
                                                   const Pose2& initial_pose, const Matrix3& initial_covariance)
    : EkfEstimator(std::move(motion), std::move(observation), initial_pose) {
  grow_covariance(0);
  p_.topLeftCorner<3, 3>() = initial_covariance;
}

void DenseCovarianceEstimator::reserve(std::size_t dim) {
  if (dim <= static_cast<std::size_t>(x_.size())) return;
  EkfEstimator::reserve(dim);
  grow_covariance(dim_);
}

void DenseCovarianceEstimator::grow_covariance(std::size_t rows) {
  const Eigen::Index grown = x_.size();
  // Not cleared: every entry outside the lower triangle of the leading dim_ x dim_ block is written
  // before it is read.
  Eigen::MatrixXd p(grown, grown);
  advise_huge_pages(p.data(), sizeof(double) * static_cast<std::size_t>(p.size()));
  const auto n = static_cast<Eigen::Index>(rows);
  if (n > 0) p.topLeftCorner(n, n).triangularView<Eigen::Lower>() = p_.topLeftCorner(n, n);
  p_.swap(p);
  scratch3_.resize(grown, 3);
  pht_.resize(grown, std::max<Eigen::Index>(2, pht_.cols()));
}

void DenseCovarianceEstimator::squeeze_stored_rows(std::size_t first, std::size_t count) {
  const std::size_t n = dim_, end = first + count;
  // Close the gap in the lower triangle column by column. Columns left of the rows shift their
  // rows below the gap up by `count`, in place; columns right of it come from `count` columns
  // further right.
  const auto stride = static_cast<std::size_t>(p_.rows());
  double* base = p_.data();
  for (std::size_t c = 0; c + count < n; ++c) {
    double* dst = base + c * stride;
    if (c < first) {
      std::copy(dst + end, dst + n, dst + first);
    } else {
      const double* src = base + (c + count) * stride;
      std::copy(src + c + count, src + n, dst + c);
    }
  }
}

}  // namespace slamkit
