#include "slamkit/filters/sparse_extended_information_filter.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <stdexcept>
#include <string>

#include "slamkit/core/angles.hpp"

namespace slamkit {

void validate(const SeifOptions& options) {
  if (options.active_landmarks < 1 || options.active_landmarks > SeifOptions::kMaxActiveLandmarks)
    throw std::invalid_argument("seif_active_landmarks must be an integer from 1 to " +
                                std::to_string(SeifOptions::kMaxActiveLandmarks) + ", found " +
                                std::to_string(options.active_landmarks));
  if (options.recovery_sweeps < 0 || options.recovery_sweeps > SeifOptions::kMaxRecoverySweeps)
    throw std::invalid_argument("seif_recovery_sweeps must be an integer from 0 (exact) to " +
                                std::to_string(SeifOptions::kMaxRecoverySweeps) + ", found " +
                                std::to_string(options.recovery_sweeps));
}

SparseExtendedInformationFilter::SparseExtendedInformationFilter(std::shared_ptr<const MotionModel> motion,
                                                                 std::shared_ptr<const ObservationModel> observation,
                                                                 const Pose2& initial_pose,
                                                                 const Matrix3& initial_covariance,
                                                                 const SeifOptions& options)
    : InformationFormEstimator(std::move(motion), std::move(observation), initial_pose, initial_covariance),
      options_((validate(options), options)) {
  xi_ = Eigen::VectorXd::Zero(x_.size());
  xi_.head<3>() = omega_.topLeftCorner(3, 3).toDense() * x_.head<3>();
}

void SparseExtendedInformationFilter::reserve(std::size_t dim) {
  EkfEstimator::reserve(dim);
  if (xi_.size() < x_.size()) xi_.conservativeResize(x_.size());
}

void SparseExtendedInformationFilter::squeeze_stored_rows(std::size_t first, std::size_t count) {
  std::copy(xi_.data() + first + count, xi_.data() + dim_, xi_.data() + first);
  InformationFormEstimator::squeeze_stored_rows(first, count);
}

void SparseExtendedInformationFilter::motion_folded(const FoldedMotion& motion) {
  const auto n = static_cast<Eigen::Index>(dim_);
  // y = A^-T xi + Psi(:, v) c: the moved state's information vector before its noise; the noise then
  // takes Psi(:, v) K y_v from it (the Woodbury form, applied to the vector).
  Eigen::VectorXd y = xi_.head(n);
  y.head<3>() = motion.f.transpose().partialPivLu().solve(xi_.head<3>());
  y += motion.psi_columns * motion.offset;
  const Eigen::Vector3d y_v = y.head<3>();
  xi_.head(n) = y - motion.psi_columns * (motion.gain * y_v);
}

void SparseExtendedInformationFilter::activate(std::size_t index) {
  if (std::find(active_.begin(), active_.end(), index) == active_.end()) active_.push_back(index);
  last_seen_[index] = scans_;
}

void SparseExtendedInformationFilter::begin_scan() {
  ++scans_;
  apply_pending_motion();
  sparsify(options_.active_landmarks);
}

void SparseExtendedInformationFilter::sparsify(std::size_t active) {
  if (active_.size() <= active) return;
  apply_pending_motion();
  // The most recently observed stay active (m+), the rest (m0) are made passive.
  std::stable_sort(active_.begin(), active_.end(),
                   [&](std::size_t a, std::size_t b) { return last_seen_[a] > last_seen_[b]; });
  const std::size_t kept = active, passive = active_.size() - kept;
  // S: the vehicle, m+, m0, in that order.
  std::vector<Eigen::Index> rows = {0, 1, 2};
  for (const std::size_t index : active_)
    for (Eigen::Index r = 0; r < 2; ++r) rows.push_back(static_cast<Eigen::Index>(landmark_offset(index)) + r);
  const auto s = static_cast<Eigen::Index>(rows.size());
  const Eigen::Index np = 2 * static_cast<Eigen::Index>(kept), n0 = 2 * static_cast<Eigen::Index>(passive);
  std::vector<Eigen::Index> position(dim_, -1);
  for (Eigen::Index i = 0; i < s; ++i) position[static_cast<std::size_t>(rows[static_cast<std::size_t>(i)])] = i;
  Eigen::MatrixXd block = Eigen::MatrixXd::Zero(s, s);  // Omega(S, S): conditioned on m-
  for (Eigen::Index j = 0; j < s; ++j)
    for (Sparse::InnerIterator it(omega_, rows[static_cast<std::size_t>(j)]); it; ++it)
      if (const Eigen::Index i = position[static_cast<std::size_t>(it.row())]; i >= 0) block(i, j) = it.value();

  const auto marginalise = [](const Eigen::MatrixXd& m, Eigen::Index keep_first, Eigen::Index keep) {
    // The marginal over rows [keep_first, keep_first + keep) of a canonical form over all of m's.
    std::vector<Eigen::Index> out;
    for (Eigen::Index i = 0; i < m.rows(); ++i)
      if (i < keep_first || i >= keep_first + keep) out.push_back(i);
    const auto k = static_cast<Eigen::Index>(out.size());
    Eigen::MatrixXd kept_block = m.block(keep_first, keep_first, keep, keep);
    Eigen::MatrixXd cross(keep, k), other(k, k);
    for (Eigen::Index j = 0; j < k; ++j) {
      cross.col(j) = m.block(keep_first, out[static_cast<std::size_t>(j)], keep, 1);
      for (Eigen::Index i = 0; i < k; ++i)
        other(i, j) = m(out[static_cast<std::size_t>(i)], out[static_cast<std::size_t>(j)]);
    }
    const Eigen::LLT<Eigen::MatrixXd> llt(other);
    if (llt.info() != Eigen::Success) throw std::logic_error("SEIF sparsification: a block is not positive definite");
    return Eigen::MatrixXd(kept_block - cross * llt.solve(cross.transpose()));
  };
  // Omega1 = p(x, m+ | m-): m0 marginalised out of the block.
  const Eigen::MatrixXd joint = marginalise(block, 0, 3 + np);
  // Omega2 = p(m+ | m-): the vehicle marginalised out of Omega1.
  const Eigen::MatrixXd landmarks_kept = marginalise(joint, 3, np);
  // Omega3 = p(m) restricted to S: the vehicle marginalised out (its links all lie in S).
  const Eigen::MatrixXd map = marginalise(block, 3, np + n0);
  Eigen::MatrixXd sparsified = Eigen::MatrixXd::Zero(s, s);
  sparsified.topLeftCorner(3 + np, 3 + np) = joint;
  sparsified.block(3, 3, np, np) -= landmarks_kept;
  sparsified.bottomRightCorner(np + n0, np + n0) += map;
  sparsified = (0.5 * (sparsified + sparsified.transpose())).eval();
  const Eigen::MatrixXd change = sparsified - block;

  Eigen::VectorXd mean(s);
  for (Eigen::Index i = 0; i < s; ++i) mean[i] = x_[rows[static_cast<std::size_t>(i)]];
  const Eigen::VectorXd xi_change = change * mean;
  Triplets triplets;
  for (Eigen::Index j = 0; j < s; ++j) {
    xi_[rows[static_cast<std::size_t>(j)]] += xi_change[j];
    for (Eigen::Index i = 0; i < s; ++i)
      if (change(i, j) != 0.0)
        triplets.emplace_back(rows[static_cast<std::size_t>(i)], rows[static_cast<std::size_t>(j)], change(i, j));
  }
  Sparse updated = omega_ + from_triplets(omega_.rows(), omega_.cols(), triplets);
  // The vehicle's links to m0 are now zero: out of the pattern, so that Omega stays sparse.
  std::vector<char> passive_row(dim_, 0);
  for (std::size_t k = kept; k < active_.size(); ++k)
    for (std::size_t r = 0; r < 2; ++r) passive_row[landmark_offset(active_[k]) + r] = 1;
  updated.prune([&](Eigen::Index row, Eigen::Index col, double) {
    return !((row < 3 && passive_row[static_cast<std::size_t>(col)]) ||
             (col < 3 && passive_row[static_cast<std::size_t>(row)]));
  });
  set_information_pattern(std::move(updated));
  deactivated_ += passive;
  ++sparsifications_;
  active_.resize(kept);
}

bool SparseExtendedInformationFilter::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  Triplets triplets;
  const Eigen::VectorXd measured = linearised_information(batch, true, triplets);  // after the motion's fold
  const auto n = static_cast<Eigen::Index>(dim_);
  xi_.head(n) += measured;
  set_information(omega_ + from_triplets(n, n, triplets));
  for (const LandmarkObservation& o : batch) activate(o.index);
  recover_mean();
  return true;
}

std::size_t SparseExtendedInformationFilter::add_landmark(const InitialLandmark& landmark) {
  const FactorVector factor = append_landmark_factor(landmark);
  const std::size_t index = num_landmarks() - 1;
  xi_.head<3>() += factor.vehicle;
  xi_.segment<2>(static_cast<Eigen::Index>(landmark_offset(index))) = factor.landmark;
  last_seen_.push_back(scans_);
  activate(index);
  return index;
}

void SparseExtendedInformationFilter::remove_landmark(std::size_t index) {
  apply_pending_motion();
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  // Marginalised: xi_r - Omega_rm Omega_mm^-1 xi_m, with Omega's Schur complement.
  const Eigen::MatrixXd own = spd_inverse(omega_.block(l, l, 2, 2).toDense(), "a landmark's information block");
  const Eigen::VectorXd weights = own * xi_.segment<2>(l);
  xi_.head(static_cast<Eigen::Index>(dim_)) -= omega_.middleCols(l, 2) * weights;
  set_information(marginalised(index));
  remove_stored_landmark(index);
  last_seen_.erase(last_seen_.begin() + static_cast<std::ptrdiff_t>(index));
  std::erase(active_, index);
  for (std::size_t& a : active_)
    if (a > index) --a;
  if (next_relaxed_ >= num_landmarks()) next_relaxed_ = 0;
}

bool SparseExtendedInformationFilter::fuse_landmarks(std::span<const LandmarkPair> pairs) {
  if (pairs.empty()) return true;
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  std::vector<char> duplicate_row;
  const Sparse t = fusion_transform(pairs, duplicate_row);
  // In the fused variables (x = T y) the canonical form is (T^T Omega T, T^T xi); conditioning on
  // e = 0 keeps the rest's rows of both. Each e is then an independent unit block at the original's
  // position until the duplicate is removed.
  const Sparse prior = omega_;
  Eigen::VectorXd xi = Sparse(t.transpose()) * xi_.head(n);
  for (const LandmarkPair& pair : pairs)
    xi.segment<2>(static_cast<Eigen::Index>(landmark_offset(pair.duplicate))) = landmark_position(pair.original);
  set_information_pattern(conditioned_on_fusion(Sparse(t.transpose()) * omega_ * t, duplicate_row));
  if (!factorise()) {
    set_information_pattern(prior);
    return false;
  }
  xi_.head(n) = xi;
  x_.head(n) = solve(xi);
  x_[2] = wrap_angle(x_[2]);
  for (const LandmarkPair& pair : pairs) {
    // The original takes over the duplicate's links, and with them its place among the active.
    if (std::find(active_.begin(), active_.end(), pair.duplicate) != active_.end()) activate(pair.original);
    last_seen_[pair.original] = std::max(last_seen_[pair.original], last_seen_[pair.duplicate]);
  }
  return true;
}

void SparseExtendedInformationFilter::relax_block(Eigen::Index first, Eigen::Index size) {
  // mu_b = Omega_bb^-1 (xi_b - sum over the other rows j of Omega_bj mu_j); Omega is symmetric, so
  // the block's columns give its rows.
  Eigen::Vector3d rest = Eigen::Vector3d::Zero();
  rest.head(size) = xi_.segment(first, size);
  Matrix3 own = Matrix3::Zero();
  for (Eigen::Index c = 0; c < size; ++c)
    for (Sparse::InnerIterator it(omega_, first + c); it; ++it) {
      const Eigen::Index r = it.row();
      if (r >= first && r < first + size)
        own(r - first, c) = it.value();
      else
        rest[c] -= it.value() * x_[r];
    }
  if (size == 3)
    x_.head<3>() = own.llt().solve(rest);
  else
    x_.segment<2>(first) = own.topLeftCorner<2, 2>().llt().solve(rest.head<2>());
}

void SparseExtendedInformationFilter::recover_mean() {
  const auto n = static_cast<Eigen::Index>(dim_);
  if (options_.recovery_sweeps == 0) {
    if (!factorise()) throw std::logic_error("the information matrix is not positive definite");
    x_.head(n) = solve(xi_.head(n));
  } else {
    // The vehicle, the active landmarks (the ones the step moved), and the next ones in turn, so
    // that every landmark is relaxed now and then.
    std::vector<std::size_t> blocks = active_;
    const std::size_t count = num_landmarks();
    for (std::size_t k = 0; k < std::min(options_.active_landmarks, count); ++k) {
      blocks.push_back(next_relaxed_);
      next_relaxed_ = (next_relaxed_ + 1) % count;
    }
    for (int sweep = 0; sweep < options_.recovery_sweeps; ++sweep) {
      relax_block(0, 3);
      for (const std::size_t index : blocks) relax_block(static_cast<Eigen::Index>(landmark_offset(index)), 2);
    }
  }
  // The heading wrapped, the belief moved with it: xi = Omega mu for the shifted mean.
  const double wrapped = wrap_angle(x_[2]);
  if (wrapped != x_[2]) {
    xi_.head(n) += omega_.col(2) * (wrapped - x_[2]);
    x_[2] = wrapped;
  }
}

void SparseExtendedInformationFilter::add_statistics(std::map<std::string, double>& statistics) const {
  InformationFormEstimator::add_statistics(statistics);
  statistics["seif_active_landmarks"] = static_cast<double>(active_.size());
  statistics["seif_sparsifications"] = static_cast<double>(sparsifications_);
  statistics["seif_deactivated"] = static_cast<double>(deactivated_);
}

}  // namespace slamkit
