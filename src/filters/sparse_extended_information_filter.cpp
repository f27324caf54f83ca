#include "slamkit/filters/sparse_extended_information_filter.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "slamkit/filters/slam_filter.hpp"

namespace slamkit {

SparseExtendedInformationFilter::SparseExtendedInformationFilter(std::shared_ptr<const MotionModel> motion,
                                                                 std::shared_ptr<const ObservationModel> observation,
                                                                 const Pose2& initial_pose,
                                                                 const Matrix3& initial_covariance,
                                                                 const SeifOptions& options,
                                                                 const InformationLinearisation& linearisation)
    : SparseInformationFilter(std::move(motion), std::move(observation), initial_pose, initial_covariance,
                              (validate(options, "seif"), options), linearisation) {}

void SparseExtendedInformationFilter::begin_scan() {
  SparseInformationFilter::begin_scan();
  sparsify(options().active_landmarks);
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
    if (llt.info() != Eigen::Success) throw FilterBreakdown("SEIF sparsification: a block is not positive definite");
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
                   [&](std::size_t a, std::size_t b) { return last_seen(a) > last_seen(b); });
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
  add_to_rows(variables, change * rows_of(variables, x_), xi_);
  deactivated_ += active_.size() - active;
  ++sparsifications_;
  active_.resize(active);
}

std::vector<InformationMatrixPanel> SparseExtendedInformationFilter::information_panels() const {
  InformationGraph graph = folded_information();
  if (active_.size() <= options().active_landmarks)
    return {{fmt::format("SEIF: {} landmarks linked to the vehicle, within seif_active_landmarks {}", active_.size(),
                         options().active_landmarks),
             graph.to_sparse()}};
  std::vector<InformationMatrixPanel> panels;
  panels.push_back({fmt::format("SEIF before sparsification: {} landmarks linked to the vehicle", active_.size()),
                    graph.to_sparse()});
  const std::size_t kept = options().active_landmarks;
  sparsify(graph, {true, active_by_recency()}, kept);
  panels.push_back({fmt::format("after: {} linked (seif_active_landmarks {})", kept, options().active_landmarks),
                    graph.to_sparse()});
  return panels;
}

bool SparseExtendedInformationFilter::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  solve_mean_where_factorised();
  move_anchors(batch);
  absorb(batch, linearisation_point(batch));
  recover_mean();
  return true;
}

void SparseExtendedInformationFilter::add_statistics(std::map<std::string, double>& statistics) const {
  SparseInformationFilter::add_statistics(statistics);
  statistics["seif_active_landmarks"] = static_cast<double>(active_.size());
  statistics["seif_sparsifications"] = static_cast<double>(sparsifications_);
  statistics["seif_deactivated"] = static_cast<double>(deactivated_);
}

}  // namespace slamkit
