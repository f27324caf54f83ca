#include "slamkit/filters/sparse_information_filter.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/slam_filter.hpp"

namespace slamkit {

void validate(const SparseInformationOptions& options, std::string_view prefix) {
  if (options.active_landmarks < 1 || options.active_landmarks > SparseInformationOptions::kMaxActiveLandmarks)
    throw std::invalid_argument(fmt::format("{}_active_landmarks must be an integer from 1 to {}, found {}", prefix,
                                            SparseInformationOptions::kMaxActiveLandmarks, options.active_landmarks));
  if (options.recovery_sweeps < 0 || options.recovery_sweeps > SparseInformationOptions::kMaxRecoverySweeps)
    throw std::invalid_argument(fmt::format("{}_recovery_sweeps must be an integer from 0 (exact) to {}, found {}",
                                            prefix, SparseInformationOptions::kMaxRecoverySweeps,
                                            options.recovery_sweeps));
}

SparseInformationFilter::SparseInformationFilter(std::shared_ptr<const MotionModel> motion,
                                                 std::shared_ptr<const ObservationModel> observation,
                                                 const Pose2& initial_pose, const Matrix3& initial_covariance,
                                                 const SparseInformationOptions& options,
                                                 const InformationLinearisation& linearisation)
    : InformationFormEstimator(std::move(motion), std::move(observation), initial_pose, initial_covariance,
                               options.covariance, linearisation),
      options_(options) {
  xi_ = Eigen::VectorXd::Zero(x_.size());
  xi_.head<3>() = graph_.vehicle() * x_.head<3>();
}

double SparseInformationFilter::memory_estimate(std::size_t landmarks, const SparseInformationOptions& options) {
  const double links = 4.0 * static_cast<double>(options.active_landmarks);
  const double per_landmark = sizeof(Matrix2) + sizeof(std::vector<InformationGraph::Link>) +
                              links * sizeof(InformationGraph::Link) + 4.0 * sizeof(double);  // mean and xi
  return static_cast<double>(landmarks) * per_landmark;
}

void SparseInformationFilter::reserve(std::size_t dim) {
  EkfEstimator::reserve(dim);
  if (xi_.size() < x_.size()) xi_.conservativeResize(x_.size());
}

void SparseInformationFilter::squeeze_stored_rows(std::size_t first, std::size_t count) {
  std::copy(xi_.data() + first + count, xi_.data() + dim_, xi_.data() + first);
  InformationFormEstimator::squeeze_stored_rows(first, count);
}

void SparseInformationFilter::motion_folded(const FoldedMotion& motion) {
  // y = A^-T xi + Psi(:, v) c: the moved state's information vector before its noise; the noise then
  // takes Psi(:, v) K y_v from it (the Woodbury form, applied to the vector). Psi(:, v) is non-zero
  // on the linked variables only, and A^-T changes the vehicle's rows only.
  const Eigen::VectorXd before = rows_of(motion.linked, xi_);
  Eigen::VectorXd y = before;
  y.head<3>() = motion.f.transpose().partialPivLu().solve(before.head<3>());
  y += motion.psi_columns * motion.offset;
  const Eigen::Vector3d y_v = y.head<3>();
  y -= motion.psi_columns * (motion.gain * y_v);
  add_to_rows(motion.linked, y - before, xi_);
}

void SparseInformationFilter::activate(std::size_t index) {
  if (std::find(active_.begin(), active_.end(), index) == active_.end()) active_.push_back(index);
  last_seen_[index] = scans_;
}

void SparseInformationFilter::activate_vehicle_links() {
  for (const InformationGraph::VehicleLink& link : graph_.vehicle_links())
    if (std::find(active_.begin(), active_.end(), link.landmark) == active_.end()) active_.push_back(link.landmark);
}

void SparseInformationFilter::move_anchors(std::span<const LandmarkObservation> batch) {
  if (move_implausible_anchors(batch, &xi_)) activate_vehicle_links();
}

void SparseInformationFilter::begin_scan() {
  ++scans_;
  apply_pending_motion();
}

void SparseInformationFilter::absorb(std::span<const LandmarkObservation> batch, const LinearisationPoint& at) {
  add_linearised_information(batch, true, xi_, at);
  for (const LandmarkObservation& o : batch) activate(o.index);
}

std::size_t SparseInformationFilter::add_landmark(const InitialLandmark& landmark) {
  const FactorVector factor = append_landmark_factor(landmark);
  const std::size_t index = num_landmarks() - 1;
  xi_.head<3>() += factor.vehicle;
  xi_.segment<2>(static_cast<Eigen::Index>(landmark_offset(index))) = factor.landmark;
  last_seen_.push_back(scans_);
  activate(index);
  return index;
}

void SparseInformationFilter::remove_landmark(std::size_t index) {
  apply_pending_motion();
  marginalise({false, {index}}, &xi_);
  remove_stored_landmark(index);
  last_seen_.erase(last_seen_.begin() + static_cast<std::ptrdiff_t>(index));
  std::erase(active_, index);
  for (std::size_t& a : active_)
    if (a > index) --a;
  // An active landmark's removal links the vehicle to its neighbours.
  activate_vehicle_links();
  if (next_relaxed_ >= num_landmarks()) next_relaxed_ = 0;
}

bool SparseInformationFilter::fuse_landmarks(std::span<const LandmarkPair> pairs) {
  if (pairs.empty()) return true;
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  std::vector<char> duplicate_row;
  const Sparse t = fusion_transform(pairs, duplicate_row);
  // In the fused variables (x = T y) the canonical form is (T^T Omega T, T^T xi); conditioning on
  // e = 0 keeps the rest's rows of both. Each e is then an independent unit block at the original's
  // position until the duplicate is removed.
  Eigen::VectorXd xi = Sparse(t.transpose()) * xi_.head(n);
  for (const LandmarkPair& pair : pairs)
    xi.segment<2>(static_cast<Eigen::Index>(landmark_offset(pair.duplicate))) = landmark_position(pair.original);
  if (!replace_information(InformationGraph::from_sparse(
          conditioned_on_fusion(Sparse(t.transpose()) * graph_.to_sparse() * t, duplicate_row))))
    return false;
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

void SparseInformationFilter::relax_vehicle() {
  // mu_b = Omega_bb^-1 (xi_b - sum over the other variables j of Omega_bj mu_j).
  Eigen::Vector3d rest = xi_.head<3>();
  for (const InformationGraph::VehicleLink& link : graph_.vehicle_links())
    rest -= link.block * landmark_position(link.landmark);
  x_.head<3>() = graph_.vehicle().llt().solve(rest);
}

void SparseInformationFilter::relax_landmark(std::size_t index) {
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  Vector2 rest = xi_.segment<2>(l);
  if (const InformationGraph::VehicleBlock* link = graph_.vehicle_link(index))
    rest -= link->transpose() * x_.head<3>();
  for (const InformationGraph::Link& link : graph_.links(index))
    rest -= link.block * landmark_position(link.landmark);
  x_.segment<2>(l) = graph_.own(index).llt().solve(rest);
}

void SparseInformationFilter::solve_mean_where_factorised() {
  if (options_.recovery_sweeps == 0 || motion_pending() || !factorised_for_covariances()) return;
  const auto n = static_cast<Eigen::Index>(dim_);
  x_.head(n) = solve(xi_.head(n));
  wrap_heading();
}

void SparseInformationFilter::recover_mean(std::span<const std::size_t> moved) {
  const auto n = static_cast<Eigen::Index>(dim_);
  if (options_.recovery_sweeps == 0) {
    if (!factorise()) throw FilterBreakdown("the information matrix is not positive definite");
    x_.head(n) = solve(xi_.head(n));
  } else {
    // The vehicle, the active landmarks (the ones the step moved), and the next ones in turn, so
    // that every landmark is relaxed now and then.
    std::vector<std::size_t> blocks = active_;
    blocks.insert(blocks.end(), moved.begin(), moved.end());
    const std::size_t count = num_landmarks();
    for (std::size_t k = 0; k < std::min(options_.active_landmarks, count); ++k) {
      blocks.push_back(next_relaxed_);
      next_relaxed_ = (next_relaxed_ + 1) % count;
    }
    for (int sweep = 0; sweep < options_.recovery_sweeps; ++sweep) {
      relax_vehicle();
      for (const std::size_t index : blocks) relax_landmark(index);
    }
  }
  wrap_heading();
}

void SparseInformationFilter::wrap_heading() {
  // The heading wrapped, the belief moved with it: xi = Omega mu for the shifted mean.
  const double wrapped = wrap_angle(x_[2]);
  if (wrapped != x_[2]) {
    // Omega's heading column: the vehicle block's, and each link's heading row.
    const double shift = wrapped - x_[2];
    xi_.head<3>() += graph_.vehicle().col(2) * shift;
    for (const InformationGraph::VehicleLink& link : graph_.vehicle_links())
      xi_.segment<2>(static_cast<Eigen::Index>(landmark_offset(link.landmark))) +=
          link.block.row(2).transpose() * shift;
    x_[2] = wrapped;
  }
}

}  // namespace slamkit
