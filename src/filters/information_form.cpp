#include "slamkit/filters/information_form.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <stdexcept>

namespace slamkit {

namespace {
// Landmarks whose columns one solve finds when the whole map's marginals are read.
constexpr std::size_t kMarginalsPerSolve = 32;
}  // namespace

void InformationFormEstimator::add_block(Triplets& triplets, Eigen::Index row, Eigen::Index col,
                                         const Eigen::Ref<const Eigen::MatrixXd>& block) {
  for (Eigen::Index j = 0; j < block.cols(); ++j)
    for (Eigen::Index i = 0; i < block.rows(); ++i) triplets.emplace_back(row + i, col + j, block(i, j));
}

InformationFormEstimator::Sparse InformationFormEstimator::from_triplets(Eigen::Index rows, Eigen::Index cols,
                                                                         const Triplets& triplets) {
  Sparse m(rows, cols);
  m.setFromTriplets(triplets.begin(), triplets.end());  // duplicates are summed
  return m;
}

Eigen::MatrixXd InformationFormEstimator::spd_inverse(const Eigen::MatrixXd& m, const char* what) {
  const Eigen::LLT<Eigen::MatrixXd> llt(m);
  if (llt.info() != Eigen::Success)
    throw std::logic_error(std::string("the information filter met ") + what + " that is not positive definite");
  return llt.solve(Eigen::MatrixXd::Identity(m.rows(), m.cols()));
}

InformationFormEstimator::InformationFormEstimator(std::shared_ptr<const MotionModel> motion,
                                                   std::shared_ptr<const ObservationModel> observation,
                                                   const Pose2& initial_pose, const Matrix3& initial_covariance)
    : EkfEstimator(std::move(motion), std::move(observation), initial_pose) {
  if (!initial_covariance.allFinite()) throw std::invalid_argument("the initial pose covariance must be finite");
  Matrix3 prior = 0.5 * (initial_covariance + initial_covariance.transpose());
  if (Eigen::SelfAdjointEigenSolver<Matrix3>(prior, Eigen::EigenvaluesOnly).eigenvalues().minCoeff() <
      kInitialPoseFloor)
    prior += kInitialPoseFloor * Matrix3::Identity();
  Triplets triplets;
  add_block(triplets, 0, 0, spd_inverse(prior, "an initial pose covariance"));
  omega_ = from_triplets(3, 3, triplets);
}

void InformationFormEstimator::set_information(Sparse omega) {
  omega_ = std::move(omega);
  factorised_ = false;
  vehicle_columns_.resize(0, 0);
  landmark_columns_.clear();
}

bool InformationFormEstimator::factorise() const {
  if (factorised_) return true;
  // The fill-reducing ordering and the factor's pattern depend on Omega's pattern only, which the
  // updates between two factorisations only grow: the same size and count of entries is the same
  // pattern, unless an operation said otherwise (set_information_pattern).
  if (pattern_changed_ || omega_.rows() != analysed_rows_ || omega_.nonZeros() != analysed_nonzeros_) {
    llt_.analyzePattern(omega_);
    analysed_rows_ = omega_.rows();
    analysed_nonzeros_ = omega_.nonZeros();
    pattern_changed_ = false;
  }
  llt_.factorize(omega_);
  ++factorisations_;
  factorised_ = llt_.info() == Eigen::Success;
  return factorised_;
}

Eigen::MatrixXd InformationFormEstimator::covariance_columns(std::size_t first, std::size_t count) const {
  if (!factorise()) throw std::logic_error("the information matrix is not positive definite");
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(omega_.rows(), static_cast<Eigen::Index>(count));
  for (std::size_t i = 0; i < count; ++i)
    unit(static_cast<Eigen::Index>(first + i), static_cast<Eigen::Index>(i)) = 1.0;
  return llt_.solve(unit);
}

const Eigen::MatrixXd& InformationFormEstimator::vehicle_columns() const {
  if (vehicle_columns_.size() == 0) vehicle_columns_ = covariance_columns(0, 3);
  return vehicle_columns_;
}

const Eigen::MatrixXd& InformationFormEstimator::landmark_columns(std::size_t index) const {
  const std::size_t l = landmark_offset(index);
  auto found = landmark_columns_.find(l);
  if (found == landmark_columns_.end()) found = landmark_columns_.emplace(l, covariance_columns(l, 2)).first;
  return found->second;
}

InformationFormEstimator::FoldedMotion InformationFormEstimator::fold(const Sparse& omega, const Matrix3& f,
                                                                      const Matrix3& q, Sparse& folded) {
  const Eigen::Index n = omega.rows();
  // Psi = A^-T Omega A^-1, A = diag(F, I): the information of the moved state before its noise.
  Triplets triplets;
  add_block(triplets, 0, 0, f.inverse());
  for (Eigen::Index i = 3; i < n; ++i) triplets.emplace_back(i, i, 1.0);
  const Sparse a_inverse = from_triplets(n, n, triplets);
  const Sparse psi = Sparse(a_inverse.transpose()) * omega * a_inverse;
  const Matrix3 psi_vv = psi.topLeftCorner(3, 3).toDense();
  FoldedMotion motion;
  motion.gain = (Matrix3::Identity() + q * psi_vv).lu().solve(q);
  motion.gain = (0.5 * (motion.gain + motion.gain.transpose())).eval();
  motion.psi_columns = psi.leftCols(3);
  motion.f = f;
  folded = psi - Sparse(motion.psi_columns * Sparse(motion.gain.sparseView()) * motion.psi_columns.transpose());
  return motion;
}

void InformationFormEstimator::apply_pending_motion() {
  if (pending_f_.isIdentity(0.0) && pending_q_.isZero(0.0) && pending_offset_.isZero(0.0)) return;
  Sparse folded;
  FoldedMotion motion = fold(omega_, pending_f_, pending_q_, folded);
  motion.offset = pending_offset_;
  set_information(std::move(folded));
  pending_f_.setIdentity();
  pending_q_.setZero();
  pending_offset_.setZero();
  motion_folded(motion);
}

Eigen::SparseMatrix<double> InformationFormEstimator::information() const {
  Sparse folded;
  fold(omega_, pending_f_, pending_q_, folded);
  return folded;
}

Matrix3 InformationFormEstimator::pose_covariance() const {
  const Matrix3 moved = pending_f_ * vehicle_columns().topRows<3>() * pending_f_.transpose() + pending_q_;
  return 0.5 * (moved + moved.transpose());
}

Vector2 InformationFormEstimator::landmark_position(std::size_t index) const {
  return x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(index)));
}

Matrix2 InformationFormEstimator::landmark_covariance(std::size_t index) const {
  const Matrix2 block = landmark_columns(index).middleRows<2>(static_cast<Eigen::Index>(landmark_offset(index)));
  return 0.5 * (block + block.transpose());
}

Matrix2 InformationFormEstimator::landmark_cross_covariance(std::size_t i, std::size_t j) const {
  if (i == j) return landmark_covariance(i);
  // Whichever landmark's columns are already at hand (association asks about one against many).
  if (landmark_columns_.count(landmark_offset(i)) > 0)
    return landmark_columns(i).middleRows<2>(static_cast<Eigen::Index>(landmark_offset(j))).transpose();
  return landmark_columns(j).middleRows<2>(static_cast<Eigen::Index>(landmark_offset(i)));
}

Matrix23 InformationFormEstimator::landmark_pose_covariance(std::size_t index) const {
  return vehicle_columns().middleRows<2>(static_cast<Eigen::Index>(landmark_offset(index))) * pending_f_.transpose();
}

void InformationFormEstimator::landmark_marginals(std::vector<Vector2>& means,
                                                  std::vector<Matrix2>& covariances) const {
  const std::size_t count = num_landmarks();
  means.resize(count);
  covariances.resize(count);
  if (count == 0) return;
  if (!factorise()) throw std::logic_error("the information matrix is not positive definite");
  const Eigen::Index n = omega_.rows();
  for (std::size_t first = 0; first < count; first += kMarginalsPerSolve) {
    const std::size_t chunk = std::min(kMarginalsPerSolve, count - first);
    Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(2 * chunk));
    for (std::size_t i = 0; i < chunk; ++i) {
      const auto l = static_cast<Eigen::Index>(landmark_offset(first + i));
      unit(l, static_cast<Eigen::Index>(2 * i)) = 1.0;
      unit(l + 1, static_cast<Eigen::Index>(2 * i + 1)) = 1.0;
    }
    const Eigen::MatrixXd columns = llt_.solve(unit);
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
  const Matrix3 f = motion_->jacobian_state(xv, u, dt);
  const Matrix3 q = motion_->process_noise(xv, u, dt);
  x_.head<3>() = motion_->predict(xv, u, dt);
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

Eigen::VectorXd InformationFormEstimator::linearised_information(std::span<const LandmarkObservation> batch,
                                                                 bool about_estimate, Triplets& triplets) {
  apply_pending_motion();
  const Pose2 xv = pose();
  Eigen::VectorXd vector = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(dim_));
  for (const LandmarkObservation& o : batch) {
    const auto l = static_cast<Eigen::Index>(landmark_offset(o.index));
    const Vector2 m = landmark_position(o.index);
    PoseJacobian hx;
    LandmarkJacobian hm;
    observation_->jacobians(xv, m, hx, hm);
    Eigen::VectorXd target = observation_->residual(o.z, observation_->predict(xv, m));
    if (about_estimate) target += hx * xv + hm * m;
    const Eigen::MatrixXd r_inverse =
        spd_inverse(Eigen::MatrixXd(o.noise_scale * observation_->noise()), "a measurement noise");
    const Eigen::MatrixXd hx_t = hx.transpose() * r_inverse, hm_t = hm.transpose() * r_inverse;
    add_block(triplets, 0, 0, hx_t * hx);
    add_block(triplets, 0, l, hx_t * hm);
    add_block(triplets, l, 0, hm_t * hx);
    add_block(triplets, l, l, hm_t * hm);
    vector.head<3>() += hx_t * target;
    vector.segment<2>(l) += hm_t * target;
  }
  return vector;
}

InformationFormEstimator::FactorVector InformationFormEstimator::append_landmark_factor(
    const InitialLandmark& landmark) {
  apply_pending_motion();
  const auto l = static_cast<Eigen::Index>(dim_);
  const Matrix2 information = spd_inverse(landmark.covariance, "a new landmark's covariance given the pose");
  reserve(dim_ + 2);
  x_.segment<2>(l) = landmark.mean;
  const Vector2 offset = landmark.mean - landmark.gx * x_.head<3>();
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
  return {coupling * offset, information * offset};
}

InformationFormEstimator::Sparse InformationFormEstimator::marginalised(std::size_t index) const {
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  // Omega - Omega(:, m) Omega(m, m)^-1 Omega(m, :).
  const Sparse columns = omega_.middleCols(l, 2);
  const Eigen::MatrixXd own = spd_inverse(omega_.block(l, l, 2, 2).toDense(), "a landmark's information block");
  return omega_ - Sparse(columns * Sparse(own.sparseView()) * columns.transpose());
}

void InformationFormEstimator::squeeze_stored_rows(std::size_t first, std::size_t count) {
  const auto n = static_cast<Eigen::Index>(dim_), f = static_cast<Eigen::Index>(first),
             c = static_cast<Eigen::Index>(count);
  Triplets triplets;
  for (Eigen::Index r = 0; r < n; ++r)
    if (r < f || r >= f + c) triplets.emplace_back(r < f ? r : r - c, r, 1.0);
  const Sparse keep = from_triplets(n - c, n, triplets);
  set_information(keep * omega_ * Sparse(keep.transpose()));
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
  statistics["information_nonzeros"] = static_cast<double>(omega_.nonZeros());
  statistics["information_factorisations"] = static_cast<double>(factorisations_);
}

}  // namespace slamkit
