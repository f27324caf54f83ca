#include "slamkit/filters/information_form.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <stdexcept>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/chi_square.hpp"
#include "slamkit/filters/slam_filter.hpp"

namespace slamkit {

namespace {
// Landmarks whose columns one solve finds when the whole map's marginals are read.
constexpr std::size_t kMarginalsPerSolve = 32;
// The iterated update has converged when no row it reads moves by more (the iterated EKF's).
constexpr double kIterateTolerance = 1e-6;

Eigen::SparseMatrix<double> from_triplets(Eigen::Index rows, Eigen::Index cols,
                                          const std::vector<Eigen::Triplet<double>>& triplets) {
  Eigen::SparseMatrix<double> m(rows, cols);
  m.setFromTriplets(triplets.begin(), triplets.end());
  return m;
}
}  // namespace

template <int N>
Eigen::Matrix<double, N, N> InformationFormEstimator::floored(const Eigen::Matrix<double, N, N>& covariance) {
  Eigen::Matrix<double, N, N> symmetric = 0.5 * (covariance + covariance.transpose());
  const auto eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>>(symmetric, Eigen::EigenvaluesOnly)
                               .eigenvalues();
  if (!(eigenvalues.minCoeff() >= kInitialPoseFloor))
    symmetric += kInitialPoseFloor * Eigen::Matrix<double, N, N>::Identity();
  return symmetric;
}

Eigen::MatrixXd InformationFormEstimator::spd_inverse(const Eigen::MatrixXd& m, const char* what) {
  const Eigen::LLT<Eigen::MatrixXd> llt(m);
  if (llt.info() != Eigen::Success)
    throw FilterBreakdown(std::string("the information filter met ") + what + " that is not positive definite");
  return llt.solve(Eigen::MatrixXd::Identity(m.rows(), m.cols()));
}

InformationFormEstimator::InformationFormEstimator(std::shared_ptr<const MotionModel> motion,
                                                   std::shared_ptr<const ObservationModel> observation,
                                                   const Pose2& initial_pose, const Matrix3& initial_covariance,
                                                   CovarianceRecovery recovery,
                                                   const InformationLinearisation& linearisation)
    : EkfEstimator(std::move(motion), std::move(observation), initial_pose),
      recovery_(recovery),
      linearisation_(linearisation),
      predicted_pose_(initial_pose) {
  if (!initial_covariance.allFinite()) throw std::invalid_argument("the initial pose covariance must be finite");
  if (linearisation.linearisation == Linearisation::kInvariant)
    throw std::invalid_argument("the information filters linearise at the estimate or at first estimates, not on the "
                                "invariant error");
  if (linearisation.update_iterations < 1)
    throw std::invalid_argument("an information filter's update needs at least one linearisation");
  graph_.vehicle() = spd_inverse(floored(initial_covariance), "an initial pose covariance");
}

void InformationFormEstimator::information_changed() {
  factorised_ = false;
  vehicle_columns_.resize(0, 0);
  landmark_columns_.clear();
  local_vehicle_.reset();
  local_joints_.clear();
  prepared_.resize(0, 0);
  prepared_rows_.clear();
}

void InformationFormEstimator::prepare_covariances(std::span<const std::size_t> landmarks) const {
  if (recovery_ != CovarianceRecovery::kLocal || landmarks.empty()) return;
  InformationGraph::Variables asked{true, {landmarks.begin(), landmarks.end()}};
  std::sort(asked.landmarks.begin(), asked.landmarks.end());
  asked.landmarks.erase(std::unique(asked.landmarks.begin(), asked.landmarks.end()), asked.landmarks.end());
  prepared_ = local_covariance(asked);
  prepared_rows_.clear();
  local_vehicle_ = prepared_.topLeftCorner<3, 3>();
  for (std::size_t k = 0; k < asked.landmarks.size(); ++k) {
    const Eigen::Index r = asked.row(k);
    const std::size_t landmark = asked.landmarks[k];
    prepared_rows_[landmark] = r;
    Joint joint;
    joint << prepared_.topLeftCorner<3, 3>(), prepared_.block<3, 2>(0, r), prepared_.block<2, 3>(r, 0),
        prepared_.block<2, 2>(r, r);
    local_joints_[landmark] = joint;
  }
}

bool InformationFormEstimator::factorise() const {
  if (factorised_) return true;
  ++factorisations_;
  factorised_ = factor_.factorise(graph_);
  return factorised_;
}

bool InformationFormEstimator::replace_information(InformationGraph omega) {
  std::swap(omega, graph_);
  information_changed();
  if (factorise()) return true;
  graph_ = std::move(omega);
  information_changed();
  return false;
}

Eigen::MatrixXd InformationFormEstimator::covariance_columns(std::size_t first, std::size_t count) const {
  if (!factorise()) throw FilterBreakdown("the information matrix is not positive definite");
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(factor_.rows(), static_cast<Eigen::Index>(count));
  for (std::size_t i = 0; i < count; ++i)
    unit(static_cast<Eigen::Index>(first + i), static_cast<Eigen::Index>(i)) = 1.0;
  return factor_.solve(unit);
}

const Eigen::MatrixXd& InformationFormEstimator::vehicle_columns() const {
  if (vehicle_columns_.size() == 0) vehicle_columns_ = covariance_columns(0, 3);
  return vehicle_columns_;
}

const Eigen::MatrixXd& InformationFormEstimator::landmark_columns(std::size_t index) const {
  auto found = landmark_columns_.find(index);
  if (found == landmark_columns_.end())
    found = landmark_columns_.emplace(index, covariance_columns(landmark_offset(index), 2)).first;
  return found->second;
}

Eigen::MatrixXd InformationFormEstimator::local_covariance(const InformationGraph::Variables& variables) const {
  const InformationGraph::Variables blanket = graph_.neighbourhood(variables);
  const Eigen::LLT<Eigen::MatrixXd> llt(graph_.gather(blanket));
  if (llt.info() != Eigen::Success) throw FilterBreakdown("the information matrix is not positive definite");
  ++local_recoveries_;
  // The columns of the variables asked about, in their order.
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(blanket.rows(), variables.rows());
  if (variables.vehicle) unit.topLeftCorner<3, 3>().setIdentity();
  for (std::size_t k = 0; k < variables.landmarks.size(); ++k) {
    const auto at = std::lower_bound(blanket.landmarks.begin(), blanket.landmarks.end(), variables.landmarks[k]);
    unit.block<2, 2>(blanket.row(static_cast<std::size_t>(at - blanket.landmarks.begin())), variables.row(k))
        .setIdentity();
  }
  const Eigen::MatrixXd columns = llt.solve(unit);
  return unit.transpose() * columns;
}

const InformationFormEstimator::Joint& InformationFormEstimator::local_joint(std::size_t index) const {
  auto found = local_joints_.find(index);
  if (found == local_joints_.end()) found = local_joints_.emplace(index, local_covariance({true, {index}})).first;
  return found->second;
}

Matrix3 InformationFormEstimator::vehicle_marginal() const {
  if (recovery_ == CovarianceRecovery::kExact) return vehicle_columns().topRows<3>();
  if (!local_vehicle_) local_vehicle_ = local_covariance({true, {}});
  return *local_vehicle_;
}

InformationFormEstimator::FoldedMotion InformationFormEstimator::fold(InformationGraph& graph, const Matrix3& f,
                                                                      const Matrix3& q) {
  // Psi = A^-T Omega A^-1, A = diag(F, I): the information of the moved state before its noise. It
  // differs from Omega in the vehicle's row and column only.
  const Matrix3 f_inverse = f.inverse();
  graph.vehicle() = (f_inverse.transpose() * graph.vehicle() * f_inverse).eval();
  FoldedMotion motion;
  motion.linked.vehicle = true;
  for (InformationGraph::VehicleLink& link : graph.vehicle_links()) {
    link.block = (f_inverse.transpose() * link.block).eval();
    motion.linked.landmarks.push_back(link.landmark);
  }
  motion.psi_columns.resize(motion.linked.rows(), 3);
  motion.psi_columns.topRows<3>() = graph.vehicle();
  for (std::size_t k = 0; k < motion.linked.landmarks.size(); ++k)
    motion.psi_columns.middleRows<2>(motion.linked.row(k)) = graph.vehicle_links()[k].block.transpose();
  const Matrix3 psi_vv = graph.vehicle();
  // Every belief the filters hold determines the pose (a relocation waits for a scan that does), so
  // a vehicle block that is not positive definite is a broken filter, which the fold's inverse would
  // turn into NaN.
  if (Eigen::LLT<Matrix3>(psi_vv).info() != Eigen::Success)
    throw FilterBreakdown("the information filter's vehicle block is no longer positive definite");
  motion.gain = (Matrix3::Identity() + q * psi_vv).lu().solve(q);
  motion.gain = (0.5 * (motion.gain + motion.gain.transpose())).eval();
  motion.f = f;
  // Psi - Psi(:, v) K Psi(v, :) between the linked landmarks. The vehicle's own block and its links,
  // where that difference cancels most when Q dwarfs the vehicle's uncertainty, are set in the
  // forms that do not cancel: (Psi_vv^-1 + Q)^-1 and (I + Psi_vv Q)^-1 Psi_vm (the push-through
  // identity).
  const auto landmark_rows = motion.psi_columns.bottomRows(motion.linked.rows() - 3);
  graph.scatter_add({false, motion.linked.landmarks}, -landmark_rows * motion.gain * landmark_rows.transpose());
  const Matrix3 vehicle = (psi_vv.inverse() + q).inverse();
  graph.vehicle() = 0.5 * (vehicle + vehicle.transpose());
  const Eigen::PartialPivLU<Matrix3> moved(Matrix3::Identity() + psi_vv * q);
  for (std::size_t k = 0; k < motion.linked.landmarks.size(); ++k)
    graph.vehicle_links()[k].block = moved.solve(motion.psi_columns.middleRows<2>(motion.linked.row(k)).transpose());
  return motion;
}

bool InformationFormEstimator::motion_pending() const {
  return !(pending_f_.isIdentity(0.0) && pending_q_.isZero(0.0) && pending_offset_.isZero(0.0));
}

void InformationFormEstimator::apply_pending_motion() {
  if (!motion_pending()) return;
  FoldedMotion motion = fold(graph_, pending_f_, pending_q_);
  motion.offset = pending_offset_;
  information_changed();
  pending_f_.setIdentity();
  pending_q_.setZero();
  pending_offset_.setZero();
  motion_folded(motion);
}

InformationGraph InformationFormEstimator::folded_information() const {
  InformationGraph folded = graph_;
  if (motion_pending()) fold(folded, pending_f_, pending_q_);
  return folded;
}

std::vector<InformationMatrixPanel> InformationFormEstimator::information_panels() const {
  return {{"the exact information matrix", information()}};
}

Matrix3 InformationFormEstimator::pose_covariance() const {
  const Matrix3 moved = pending_f_ * vehicle_marginal() * pending_f_.transpose() + pending_q_;
  return 0.5 * (moved + moved.transpose());
}

Vector2 InformationFormEstimator::landmark_position(std::size_t index) const {
  return x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(index)));
}

Matrix2 InformationFormEstimator::landmark_covariance(std::size_t index) const {
  const Matrix2 block = recovery_ == CovarianceRecovery::kLocal
                            ? Matrix2(local_joint(index).bottomRightCorner<2, 2>())
                            : Matrix2(landmark_columns(index).middleRows<2>(
                                  static_cast<Eigen::Index>(landmark_offset(index))));
  return 0.5 * (block + block.transpose());
}

Matrix2 InformationFormEstimator::landmark_cross_covariance(std::size_t i, std::size_t j) const {
  if (i == j) return landmark_covariance(i);
  if (recovery_ == CovarianceRecovery::kLocal) {
    const auto a = prepared_rows_.find(i), b = prepared_rows_.find(j);
    if (a != prepared_rows_.end() && b != prepared_rows_.end()) return prepared_.block<2, 2>(a->second, b->second);
    return local_covariance({false, {i, j}}).topRightCorner<2, 2>();
  }
  // Whichever landmark's columns are already at hand (association asks about one against many).
  if (landmark_columns_.count(i) > 0)
    return landmark_columns(i).middleRows<2>(static_cast<Eigen::Index>(landmark_offset(j))).transpose();
  return landmark_columns(j).middleRows<2>(static_cast<Eigen::Index>(landmark_offset(i)));
}

Matrix23 InformationFormEstimator::landmark_pose_covariance(std::size_t index) const {
  if (recovery_ == CovarianceRecovery::kLocal)
    return local_joint(index).bottomLeftCorner<2, 3>() * pending_f_.transpose();
  return vehicle_columns().middleRows<2>(static_cast<Eigen::Index>(landmark_offset(index))) * pending_f_.transpose();
}

void InformationFormEstimator::landmark_marginals(std::vector<Vector2>& means,
                                                  std::vector<Matrix2>& covariances) const {
  const std::size_t count = num_landmarks();
  means.resize(count);
  covariances.resize(count);
  if (count == 0) return;
  if (recovery_ == CovarianceRecovery::kLocal) {
    for (std::size_t i = 0; i < count; ++i) {
      means[i] = landmark_position(i);
      covariances[i] = landmark_covariance(i);
    }
    return;
  }
  if (!factorise()) throw FilterBreakdown("the information matrix is not positive definite");
  const Eigen::Index n = factor_.rows();
  for (std::size_t first = 0; first < count; first += kMarginalsPerSolve) {
    const std::size_t chunk = std::min(kMarginalsPerSolve, count - first);
    Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(2 * chunk));
    for (std::size_t i = 0; i < chunk; ++i) {
      const auto l = static_cast<Eigen::Index>(landmark_offset(first + i));
      unit(l, static_cast<Eigen::Index>(2 * i)) = 1.0;
      unit(l + 1, static_cast<Eigen::Index>(2 * i + 1)) = 1.0;
    }
    const Eigen::MatrixXd columns = factor_.solve(unit);
    for (std::size_t i = 0; i < chunk; ++i) {
      const auto l = static_cast<Eigen::Index>(landmark_offset(first + i));
      const Matrix2 block = columns.block<2, 2>(l, static_cast<Eigen::Index>(2 * i));
      means[first + i] = landmark_position(first + i);
      covariances[first + i] = 0.5 * (block + block.transpose());
    }
  }
}

Eigen::VectorXd InformationFormEstimator::state() const { return x_.head(static_cast<Eigen::Index>(dim_)); }

Eigen::MatrixXd InformationFormEstimator::covariance() const {
  Eigen::MatrixXd p = covariance_columns(0, dim_);
  // Through the pending motion: P -> A P A^T + B Q B^T with A = diag(F, I).
  p.topRows<3>() = (pending_f_ * p.topRows<3>()).eval();
  p.leftCols<3>() = (p.leftCols<3>() * pending_f_.transpose()).eval();
  p.topLeftCorner<3, 3>() += pending_q_;
  return 0.5 * (p + p.transpose());
}

void InformationFormEstimator::predict(const Control& u, double dt) {
  const Pose2 xv = x_.head<3>();
  const Matrix3 q = motion_->process_noise(xv, u, dt);
  x_.head<3>() = motion_->predict(xv, u, dt);
  const Matrix3 f = linearisation_.linearisation == Linearisation::kFirstEstimates
                        ? MotionModel::jacobian_between(predicted_pose_, x_.head<3>())
                        : motion_->jacobian_state(xv, u, dt);
  predicted_pose_ = x_.head<3>();
  // Linearised at the estimate: x_v -> F x_v + (f(mu_v) - F mu_v), with f(mu_v) as stored, its
  // heading wrapped. The offset is not wrapped: it carries the wrap, so that the composed motion
  // takes the information form's implied heading where the estimate's is (the next step's offset,
  // taken about the wrapped heading, cancels the wrap's share of F's heading column).
  const Eigen::Vector3d offset = x_.head<3>() - f * xv;
  pending_f_ = f * pending_f_;
  pending_q_ = f * pending_q_ * f.transpose() + q;
  pending_offset_ = f * pending_offset_ + offset;
}

void InformationFormEstimator::inflate_pose(const Matrix3& q) { pending_q_ += q; }

bool InformationFormEstimator::move_implausible_anchors(std::span<const LandmarkObservation> batch,
                                                        Eigen::VectorXd* vector) {
  if (linearisation_.linearisation != Linearisation::kFirstEstimates) return false;
  apply_pending_motion();
  static const double gate = eval::chi_square_quantile(kPlausibleAnchorProbability, 2.0);
  bool moved_any = false;
  for (const LandmarkObservation& o : batch) {
    Vector2& anchor = first_estimates_[o.index];
    const Vector2 moved = landmark_position(o.index) - anchor;
    // Cov(m - p) over the vehicle's position.
    const Matrix2 cross = landmark_pose_covariance(o.index).leftCols<2>();
    const Matrix2 relative =
        landmark_covariance(o.index) - cross - cross.transpose() + pose_covariance().topLeftCorner<2, 2>();
    const Eigen::LLT<Matrix2> llt(relative);
    if (llt.info() != Eigen::Success || moved.dot(llt.solve(moved)) <= gate) continue;
    // Omega -> M^-T Omega M^-1, M^-1 = I - u e_theta^T with u = J (m - anchor) in the landmark's
    // rows: Omega - w e_theta^T - e_theta w^T + (u^T Omega_ll u) e_theta e_theta^T, w = Omega(:, l) u,
    // which is non-zero over the landmark's neighbourhood and the vehicle only.
    InformationGraph::Variables changed = graph_.neighbourhood({false, {o.index}});
    changed.vehicle = true;
    const Eigen::MatrixXd before = graph_.gather(changed);
    const auto position = std::find(changed.landmarks.begin(), changed.landmarks.end(), o.index);
    const Eigen::Index l = changed.row(static_cast<std::size_t>(position - changed.landmarks.begin()));
    const Vector2 u(-moved[1], moved[0]);
    const Eigen::VectorXd w = before.middleCols<2>(l) * u;
    Eigen::MatrixXd change = Eigen::MatrixXd::Zero(changed.rows(), changed.rows());
    change.col(2) -= w;
    change.row(2) -= w.transpose();
    change(2, 2) += u.dot(before.block<2, 2>(l, l) * u);
    graph_.scatter_add(changed, change);
    if (vector) add_to_rows(changed, change * rows_of(changed, x_), *vector);
    information_changed();
    anchor = landmark_position(o.index);
    ++anchors_moved_;
    moved_any = true;
  }
  return moved_any;
}

void InformationFormEstimator::update_jacobians(std::size_t index, const Pose2& vehicle, const Vector2& landmark,
                                                PoseJacobian& hx, LandmarkJacobian& hm) const {
  if (linearisation_.linearisation == Linearisation::kFirstEstimates)
    observation_->jacobians(predicted_pose_, first_estimates_[index], hx, hm);
  else
    observation_->jacobians(vehicle, landmark, hx, hm);
}

InformationFormEstimator::LinearisationPoint InformationFormEstimator::linearisation_point(
    std::span<const LandmarkObservation> batch) const {
  LinearisationPoint at{pose(), {}};
  InformationGraph::Variables read{true, {}};  // the rows the batch reads
  for (const LandmarkObservation& o : batch)
    if (at.landmarks.emplace(o.index, landmark_position(o.index)).second) read.landmarks.push_back(o.index);
  if (linearisation_.update_iterations == 1) return at;
  prepare_covariances(read.landmarks);
  const Eigen::Index rows = read.rows();
  Eigen::MatrixXd p(rows, rows);
  Eigen::VectorXd prior(rows);
  p.topLeftCorner<3, 3>() = pose_covariance();
  prior.head<3>() = at.vehicle;
  std::unordered_map<std::size_t, Eigen::Index> row_of;
  for (std::size_t k = 0; k < read.landmarks.size(); ++k) {
    const std::size_t index = read.landmarks[k];
    const Eigen::Index r = read.row(k);
    row_of[index] = r;
    prior.segment<2>(r) = at.landmarks[index];
    p.block<2, 3>(r, 0) = landmark_pose_covariance(index);
    p.block<3, 2>(0, r) = p.block<2, 3>(r, 0).transpose();
    for (std::size_t j = 0; j <= k; ++j) {
      const Eigen::Index c = read.row(j);
      p.block<2, 2>(r, c) = landmark_cross_covariance(index, read.landmarks[j]);
      // The diagonal block is its own mirror: copying it onto itself would read what it overwrites.
      if (j < k) p.block<2, 2>(c, r) = p.block<2, 2>(r, c).transpose();
    }
  }
  const auto d = static_cast<Eigen::Index>(observation_->dim());
  const auto measured = static_cast<Eigen::Index>(batch.size()) * d;
  Eigen::MatrixXd h(measured, rows), noise = Eigen::MatrixXd::Zero(measured, measured);
  Eigen::VectorXd nu(measured);
  for (std::size_t i = 0; i < batch.size(); ++i)
    noise.block(static_cast<Eigen::Index>(i) * d, static_cast<Eigen::Index>(i) * d, d, d) =
        batch[i].noise_scale * observation_->noise();
  // Gauss-Newton on the measurement with the prior's covariance, as the iterated EKF: the next
  // iterate is mu + P H^T S^-1 (z - h(x_i) + H (x_i - mu)) with H the Jacobian at x_i.
  Eigen::VectorXd iterate = prior, linearised = prior;
  for (int iteration = 1;; ++iteration) {
    linearised = iterate;
    h.setZero();
    Eigen::VectorXd from_prior = iterate - prior;
    from_prior[2] = wrap_angle(from_prior[2]);
    for (std::size_t i = 0; i < batch.size(); ++i) {
      const Eigen::Index r = row_of[batch[i].index], m = static_cast<Eigen::Index>(i) * d;
      const Pose2 xv = iterate.head<3>();
      const Vector2 landmark = iterate.segment<2>(r);
      PoseJacobian hx;
      LandmarkJacobian hm;
      observation_->jacobians(xv, landmark, hx, hm);
      h.block(m, 0, d, 3) = hx;
      h.block(m, r, d, 2) = hm;
      nu.segment(m, d) = observation_->residual(batch[i].z, observation_->predict(xv, landmark));
    }
    nu += h * from_prior;
    if (iteration == linearisation_.update_iterations) break;
    const Eigen::MatrixXd pht = p * h.transpose();
    const Eigen::LLT<Eigen::MatrixXd> s(h * pht + noise);
    if (s.info() != Eigen::Success) break;  // the update then reports it
    Eigen::VectorXd next = prior + pht * s.solve(nu);
    next[2] = wrap_angle(next[2]);
    Eigen::VectorXd moved = next - iterate;
    moved[2] = wrap_angle(moved[2]);
    iterate = next;
    if (moved.cwiseAbs().maxCoeff() < kIterateTolerance) break;
  }
  // The standard update keeps the Jacobians of the last linearisation, first estimates are taken
  // about the last iterate: the iterated EKF's choices, so that the EIF stays its oracle.
  const Eigen::VectorXd& chosen =
      linearisation_.linearisation == Linearisation::kFirstEstimates ? iterate : linearised;
  at.vehicle = chosen.head<3>();
  for (const auto& [index, r] : row_of) at.landmarks[index] = chosen.segment<2>(r);
  return at;
}

void InformationFormEstimator::add_linearised_information(std::span<const LandmarkObservation> batch,
                                                          bool about_estimate, Eigen::VectorXd& vector,
                                                          const LinearisationPoint& at) {
  apply_pending_motion();
  const Pose2 xv = pose();
  Pose2 vehicle_offset = at.vehicle - xv;
  vehicle_offset[2] = wrap_angle(vehicle_offset[2]);
  for (const LandmarkObservation& o : batch) {
    const auto l = static_cast<Eigen::Index>(landmark_offset(o.index));
    const Vector2 m = landmark_position(o.index);
    const Vector2 m_at = at.landmarks.at(o.index);
    PoseJacobian hx;
    LandmarkJacobian hm;
    update_jacobians(o.index, at.vehicle, m_at, hx, hm);
    Eigen::VectorXd target = observation_->residual(o.z, observation_->predict(at.vehicle, m_at));
    target += hx * vehicle_offset + hm * (m_at - m);
    if (about_estimate) target += hx * xv + hm * m;
    const Eigen::MatrixXd r_inverse =
        spd_inverse(Eigen::MatrixXd(o.noise_scale * observation_->noise()), "a measurement noise");
    const Eigen::MatrixXd hx_t = hx.transpose() * r_inverse, hm_t = hm.transpose() * r_inverse;
    graph_.vehicle() += hx_t * hx;
    graph_.add_vehicle_link(o.index, hx_t * hm);
    graph_.own(o.index) += hm_t * hm;
    vector.head<3>() += hx_t * target;
    vector.segment<2>(l) += hm_t * target;
  }
  information_changed();
}

InformationFormEstimator::FactorVector InformationFormEstimator::append_landmark_factor(
    const InitialLandmark& landmark) {
  apply_pending_motion();
  const auto l = static_cast<Eigen::Index>(dim_);
  // A measurement that places the landmark exactly along some direction (a range of zero, say)
  // gives a singular covariance, which the information form cannot hold.
  const Matrix2 information =
      spd_inverse(floored(landmark.covariance), "a new landmark's covariance given the pose");
  reserve(dim_ + 2);
  x_.segment<2>(l) = landmark.mean;
  first_estimates_.push_back(landmark.mean);
  const Vector2 offset = landmark.mean - landmark.gx * x_.head<3>();
  const Eigen::Matrix<double, 3, 2> coupling = -landmark.gx.transpose() * information;
  graph_.vehicle() -= coupling * landmark.gx;
  graph_.add_vehicle_link(graph_.append_landmark(information), coupling);
  information_changed();
  append_landmark_rows(2);
  return {coupling * offset, information * offset};
}

void InformationFormEstimator::marginalise(const InformationGraph::Variables& variable, Eigen::VectorXd* vector) {
  // Omega_nn - Omega_nm Omega_mm^-1 Omega_mn over m's neighbours n, and xi_n - Omega_nm Omega_mm^-1 xi_m.
  if (variable.landmarks.size() != (variable.vehicle ? 0u : 1u))
    throw std::logic_error("marginalise: the vehicle or one landmark, not both or several");
  InformationGraph::Variables blanket = graph_.neighbourhood(variable);
  InformationGraph::Variables both;  // the variable and its blanket
  if (variable.vehicle) {
    both = blanket;
    blanket.vehicle = false;
  } else {
    std::erase(blanket.landmarks, variable.landmarks.front());
    both = blanket;
    both.landmarks.push_back(variable.landmarks.front());
  }
  const Eigen::MatrixXd joint = graph_.gather(both);
  const Eigen::Index r = blanket.rows(), v = variable.rows();
  // The variable's rows come first in `both` if it is the vehicle, last if it is a landmark.
  const Eigen::Index first = variable.vehicle ? 0 : r, blanket_first = variable.vehicle ? v : 0;
  const Eigen::MatrixXd cross = joint.block(blanket_first, first, r, v);
  const Eigen::LLT<Eigen::MatrixXd> own(joint.block(first, first, v, v));
  if (own.info() != Eigen::Success)
    throw FilterBreakdown("marginalisation: an information block is not positive definite");
  if (vector) add_to_rows(blanket, -cross * own.solve(rows_of(variable, *vector)), *vector);
  if (variable.vehicle)
    graph_.isolate_vehicle();
  else
    graph_.isolate(variable.landmarks.front());
  graph_.scatter_add(blanket, -cross * own.solve(cross.transpose()));
  information_changed();
}

Eigen::VectorXd InformationFormEstimator::rows_of(const InformationGraph::Variables& variables,
                                                  const Eigen::VectorXd& vector) const {
  Eigen::VectorXd rows(variables.rows());
  if (variables.vehicle) rows.head<3>() = vector.head<3>();
  for (std::size_t k = 0; k < variables.landmarks.size(); ++k)
    rows.segment<2>(variables.row(k)) =
        vector.segment<2>(static_cast<Eigen::Index>(landmark_offset(variables.landmarks[k])));
  return rows;
}

void InformationFormEstimator::add_to_rows(const InformationGraph::Variables& variables,
                                           const Eigen::VectorXd& change, Eigen::VectorXd& vector) const {
  if (variables.vehicle) vector.head<3>() += change.head<3>();
  for (std::size_t k = 0; k < variables.landmarks.size(); ++k)
    vector.segment<2>(static_cast<Eigen::Index>(landmark_offset(variables.landmarks[k]))) +=
        change.segment<2>(variables.row(k));
}

void InformationFormEstimator::squeeze_stored_rows(std::size_t first, std::size_t /*count: a landmark's 2*/) {
  const std::size_t index = (first - 3) / 2;
  graph_.remove_landmark(index);
  first_estimates_.erase(first_estimates_.begin() + static_cast<std::ptrdiff_t>(index));
  information_changed();
}

InformationFormEstimator::Sparse InformationFormEstimator::fusion_transform(std::span<const LandmarkPair> pairs,
                                                                            std::vector<char>& duplicate_row) const {
  const auto n = static_cast<Eigen::Index>(dim_);
  duplicate_row.assign(dim_, 0);
  Triplets triplets;
  for (Eigen::Index i = 0; i < n; ++i) triplets.emplace_back(i, i, 1.0);
  for (const LandmarkPair& pair : pairs) {
    const auto d = static_cast<Eigen::Index>(landmark_offset(pair.duplicate));
    const auto o = static_cast<Eigen::Index>(landmark_offset(pair.original));
    for (Eigen::Index i = 0; i < 2; ++i) {
      triplets.emplace_back(d + i, o + i, 1.0);
      duplicate_row[static_cast<std::size_t>(d + i)] = 1;
    }
  }
  return from_triplets(n, n, triplets);
}

InformationFormEstimator::Sparse InformationFormEstimator::conditioned_on_fusion(
    Sparse omega, const std::vector<char>& duplicate_row) {
  omega.prune([&](Eigen::Index row, Eigen::Index col, double) {
    return !duplicate_row[static_cast<std::size_t>(row)] && !duplicate_row[static_cast<std::size_t>(col)];
  });
  Triplets triplets;
  for (Eigen::Index i = 0; i < omega.rows(); ++i)
    if (duplicate_row[static_cast<std::size_t>(i)]) triplets.emplace_back(i, i, 1.0);
  return omega + from_triplets(omega.rows(), omega.cols(), triplets);
}

void InformationFormEstimator::add_statistics(std::map<std::string, double>& statistics) const {
  statistics["information_nonzeros"] = static_cast<double>(graph_.nonzeros());
  statistics["information_factorisations"] = static_cast<double>(factorisations_);
  statistics["information_local_recoveries"] = static_cast<double>(local_recoveries_);
  if (linearisation_.linearisation == Linearisation::kFirstEstimates)
    statistics["first_estimates_moved"] = static_cast<double>(anchors_moved_);
}

}  // namespace slamkit
