#include "slamkit/filters/exactly_sparse_information_filter.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <numeric>
#include <utility>

#include <fmt/format.h>

namespace slamkit {

namespace {

// An eigenvalue of the pose's information below this times the largest is taken as a direction the
// observations do not determine (roundoff leaves about 1e-16 in the directions they do not).
constexpr double kUndetermined = 1e-9;

int determined_directions(const Matrix3& information) {
  const Eigen::Vector3d eigenvalues = Eigen::SelfAdjointEigenSolver<Matrix3>(information).eigenvalues();
  const double largest = eigenvalues.maxCoeff();
  if (!(largest > 0.0)) return 0;
  return static_cast<int>((eigenvalues.array() > kUndetermined * largest).count());
}

}  // namespace

ExactlySparseInformationFilter::ExactlySparseInformationFilter(std::shared_ptr<const MotionModel> motion,
                                                               std::shared_ptr<const ObservationModel> observation,
                                                               const Pose2& initial_pose,
                                                               const Matrix3& initial_covariance,
                                                               const EseifOptions& options,
                                                               const InformationLinearisation& linearisation)
    : SparseInformationFilter(std::move(motion), std::move(observation), initial_pose, initial_covariance,
                              (validate(options, "eseif"), options), linearisation) {}

bool ExactlySparseInformationFilter::over_bound(std::span<const LandmarkObservation> batch) const {
  std::vector<std::size_t> linked = active_;
  for (const LandmarkObservation& o : batch) linked.push_back(o.index);
  std::sort(linked.begin(), linked.end());
  return static_cast<std::size_t>(std::unique(linked.begin(), linked.end()) - linked.begin()) >
         options().active_landmarks;
}

std::vector<std::size_t> ExactlySparseInformationFilter::relocation_set(
    std::span<const LandmarkObservation> batch) const {
  std::vector<std::size_t> order(batch.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return graph_.own(batch[a].index).trace() > graph_.own(batch[b].index).trace();
  });
  const Pose2 xv = pose();
  Matrix3 determined = Matrix3::Zero();
  int directions = 0;
  // Half the bound: a relocated pose as well determined as the scan allows (two landmarks' worth of
  // heading makes later updates' linearisations err), and room for half a bound of landmarks before
  // the next relocation.
  const std::size_t relocating = std::max<std::size_t>(1, options().active_landmarks / 2);
  std::vector<std::size_t> chosen;
  std::vector<char> taken(batch.size(), 0);
  for (const std::size_t k : order) {
    if (directions == 3) break;
    const LandmarkObservation& o = batch[k];
    PoseJacobian hx;
    LandmarkJacobian hm;
    update_jacobians(o.index, xv, landmark_position(o.index), hx, hm);
    const Eigen::MatrixXd noise = o.noise_scale * observation_model().noise();
    const Matrix3 with = determined + hx.transpose() * noise.llt().solve(Eigen::MatrixXd(hx));
    const int now = determined_directions(with);
    if (now <= directions) continue;
    determined = with;
    directions = now;
    chosen.push_back(k);
    taken[k] = 1;
  }
  if (directions < 3) return {};
  for (const std::size_t k : order)
    if (chosen.size() < relocating && !taken[k]) chosen.push_back(k);
  return chosen;
}

bool ExactlySparseInformationFilter::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  solve_mean_where_factorised();
  move_anchors(batch);
  // One linearisation point for the whole scan, alpha's and beta's updates alike.
  const LinearisationPoint at = linearisation_point(batch);
  if (!over_bound(batch)) {
    absorb(batch, at);
    recover_mean();
    return true;
  }
  const std::vector<std::size_t> beta_positions = relocation_set(batch);
  if (beta_positions.empty()) {
    ++deferred_;
    absorb(batch, at);
    recover_mean();
    return true;
  }
  std::vector<LandmarkObservation> alpha, beta;
  std::vector<char> in_beta(batch.size(), 0);
  for (const std::size_t k : beta_positions) {
    in_beta[k] = 1;
    beta.push_back(batch[k]);
  }
  for (std::size_t k = 0; k < batch.size(); ++k)
    if (!in_beta[k]) alpha.push_back(batch[k]);
  absorb(alpha, at);
  // The vehicle marginalised out, then back with no information: beta's update alone places it,
  // linearised where alpha's was.
  marginalise({true, {}}, &xi_);
  graph_.vehicle().setZero();
  xi_.head<3>().setZero();
  information_changed();
  const std::vector<std::size_t> updated = std::exchange(active_, {});
  absorb(beta, at);
  ++relocations_;
  recover_mean(updated);
  return true;
}

std::vector<InformationMatrixPanel> ExactlySparseInformationFilter::information_panels() const {
  return {{fmt::format("ESEIF: {} landmarks linked to the vehicle (eseif_active_landmarks {})", active_.size(),
                       options().active_landmarks),
           information()}};
}

void ExactlySparseInformationFilter::add_statistics(std::map<std::string, double>& statistics) const {
  SparseInformationFilter::add_statistics(statistics);
  statistics["eseif_active_landmarks"] = static_cast<double>(active_.size());
  statistics["eseif_relocations"] = static_cast<double>(relocations_);
  statistics["eseif_relocations_deferred"] = static_cast<double>(deferred_);
}

}  // namespace slamkit
