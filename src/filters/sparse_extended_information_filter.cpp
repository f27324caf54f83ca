#include "slamkit/filters/sparse_extended_information_filter.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

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
    : InformationFormEstimator(std::move(motion), std::move(observation), initial_pose, initial_covariance,
                               (validate(options), options.covariance)),
      options_(options) {
  xi_ = Eigen::VectorXd::Zero(x_.size());
  xi_.head<3>() = graph_.vehicle() * x_.head<3>();
}

double SparseExtendedInformationFilter::memory_estimate(std::size_t landmarks, const SeifOptions& options) {
  const double links = 4.0 * static_cast<double>(options.active_landmarks);
  const double per_landmark = sizeof(Matrix2) + sizeof(std::vector<InformationGraph::Link>) +
                              links * sizeof(InformationGraph::Link) + 4.0 * sizeof(double);  // mean and xi
  return static_cast<double>(landmarks) * per_landmark;
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
  // y = A^-T xi + Psi(:, v) c: the moved state's information vector before its noise; the noise then
  // takes Psi(:, v) K y_v from it (the Woodbury form, applied to the vector). Psi(:, v) is non-zero
  // on the linked variables only, and A^-T changes the vehicle's rows only.
  const InformationGraph::Variables& linked = motion.linked;
  Eigen::VectorXd y(linked.rows());
  y.head<3>() = motion.f.transpose().partialPivLu().solve(xi_.head<3>());
  for (std::size_t k = 0; k < linked.landmarks.size(); ++k)
    y.segment<2>(linked.row(k)) = xi_.segment<2>(static_cast<Eigen::Index>(landmark_offset(linked.landmarks[k])));
  y += motion.psi_columns * motion.offset;
  const Eigen::Vector3d y_v = y.head<3>();
  y -= motion.psi_columns * (motion.gain * y_v);
  xi_.head<3>() = y.head<3>();
  for (std::size_t k = 0; k < linked.landmarks.size(); ++k)
    xi_.segment<2>(static_cast<Eigen::Index>(landmark_offset(linked.landmarks[k]))) = y.segment<2>(linked.row(k));
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

namespace {

/// The change to Omega(S, S) that makes m0 passive, for S = (vehicle, m+ of `np` rows, m0 of `n0`)
/// and `block` = Omega(S, S) (conditioned on the rest, m-): Omega1 - Omega2 + Omega3 - block.
Eigen::MatrixXd sparsification_change(const Eigen::MatrixXd& block, Eigen::Index np, Eigen::Index n0) {
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
  const Eigen::Index s = block.rows();
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
  return sparsified - block;
}

}  // namespace

std::vector<std::size_t> SparseExtendedInformationFilter::active_by_recency() const {
  std::vector<std::size_t> order = active_;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return last_seen_[a] > last_seen_[b]; });
  return order;
}

Eigen::MatrixXd SparseExtendedInformationFilter::sparsify(InformationGraph& graph,
                                                          const InformationGraph::Variables& variables,
                                                          std::size_t kept) {
  const auto np = 2 * static_cast<Eigen::Index>(kept);
  const Eigen::Index n0 = 2 * static_cast<Eigen::Index>(variables.landmarks.size()) - np;
  const Eigen::MatrixXd change = sparsification_change(graph.gather(variables), np, n0);
  graph.scatter_add(variables, change);
  // The vehicle's links to m0 are now zero: out of the graph, so that Omega stays sparse.
  for (std::size_t k = kept; k < variables.landmarks.size(); ++k) graph.remove_vehicle_link(variables.landmarks[k]);
  return change;
}

void SparseExtendedInformationFilter::sparsify(std::size_t active) {
  if (active_.size() <= active) return;
  apply_pending_motion();
  // The most recently observed stay active (m+), the rest (m0) are made passive. S: the vehicle,
  // m+, m0, in that order.
  active_ = active_by_recency();
  const InformationGraph::Variables variables{true, active_};
  const Eigen::MatrixXd change = sparsify(graph_, variables, active);
  information_changed();
  Eigen::VectorXd mean(variables.rows());
  mean.head<3>() = x_.head<3>();
  for (std::size_t k = 0; k < active_.size(); ++k)
    mean.segment<2>(variables.row(k)) = landmark_position(active_[k]);
  const Eigen::VectorXd xi_change = change * mean;
  xi_.head<3>() += xi_change.head<3>();
  for (std::size_t k = 0; k < active_.size(); ++k)
    xi_.segment<2>(static_cast<Eigen::Index>(landmark_offset(active_[k]))) += xi_change.segment<2>(variables.row(k));
  deactivated_ += active_.size() - active;
  ++sparsifications_;
  active_.resize(active);
}

std::vector<InformationMatrixPanel> SparseExtendedInformationFilter::information_panels() const {
  InformationGraph graph = folded_information();
  if (active_.size() <= options_.active_landmarks)
    return {{fmt::format("SEIF: {} landmarks linked to the vehicle, within seif_active_landmarks {}", active_.size(),
                         options_.active_landmarks),
             graph.to_sparse()}};
  std::vector<InformationMatrixPanel> panels;
  panels.push_back({fmt::format("SEIF before sparsification: {} landmarks linked to the vehicle", active_.size()),
                    graph.to_sparse()});
  const std::size_t kept = options_.active_landmarks;
  sparsify(graph, {true, active_by_recency()}, kept);
  panels.push_back({fmt::format("after: {} linked (seif_active_landmarks {})", kept, options_.active_landmarks),
                    graph.to_sparse()});
  return panels;
}

bool SparseExtendedInformationFilter::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  add_linearised_information(batch, true, xi_);
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
  // Marginalised: xi_r - Omega_rm Omega_mm^-1 xi_m over m's neighbours r, with Omega's Schur complement.
  const Vector2 weights = spd_inverse(graph_.own(index), "a landmark's information block") *
                          xi_.segment<2>(static_cast<Eigen::Index>(landmark_offset(index)));
  if (const InformationGraph::VehicleBlock* link = graph_.vehicle_link(index)) xi_.head<3>() -= *link * weights;
  for (const InformationGraph::Link& link : graph_.links(index))
    xi_.segment<2>(static_cast<Eigen::Index>(landmark_offset(link.landmark))) -= link.block.transpose() * weights;
  marginalise(index);
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
  Eigen::VectorXd xi = Sparse(t.transpose()) * xi_.head(n);
  for (const LandmarkPair& pair : pairs)
    xi.segment<2>(static_cast<Eigen::Index>(landmark_offset(pair.duplicate))) = landmark_position(pair.original);
  InformationGraph prior = InformationGraph::from_sparse(
      conditioned_on_fusion(Sparse(t.transpose()) * graph_.to_sparse() * t, duplicate_row));
  std::swap(prior, graph_);
  information_changed();
  if (!factorise()) {
    graph_ = std::move(prior);
    information_changed();
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

void SparseExtendedInformationFilter::relax_vehicle() {
  // mu_b = Omega_bb^-1 (xi_b - sum over the other variables j of Omega_bj mu_j).
  Eigen::Vector3d rest = xi_.head<3>();
  for (const InformationGraph::VehicleLink& link : graph_.vehicle_links())
    rest -= link.block * landmark_position(link.landmark);
  x_.head<3>() = graph_.vehicle().llt().solve(rest);
}

void SparseExtendedInformationFilter::relax_landmark(std::size_t index) {
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  Vector2 rest = xi_.segment<2>(l);
  if (const InformationGraph::VehicleBlock* link = graph_.vehicle_link(index))
    rest -= link->transpose() * x_.head<3>();
  for (const InformationGraph::Link& link : graph_.links(index))
    rest -= link.block * landmark_position(link.landmark);
  x_.segment<2>(l) = graph_.own(index).llt().solve(rest);
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
      relax_vehicle();
      for (const std::size_t index : blocks) relax_landmark(index);
    }
  }
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

void SparseExtendedInformationFilter::add_statistics(std::map<std::string, double>& statistics) const {
  InformationFormEstimator::add_statistics(statistics);
  statistics["seif_active_landmarks"] = static_cast<double>(active_.size());
  statistics["seif_sparsifications"] = static_cast<double>(sparsifications_);
  statistics["seif_deactivated"] = static_cast<double>(deactivated_);
}

}  // namespace slamkit
