#include "slamkit/filters/extended_information_filter.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <stdexcept>
#include <vector>

#include "slamkit/core/angles.hpp"

namespace slamkit {

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

void add_block(Triplets& triplets, Eigen::Index row, Eigen::Index col, const Eigen::Ref<const Eigen::MatrixXd>& block) {
  for (Eigen::Index j = 0; j < block.cols(); ++j)
    for (Eigen::Index i = 0; i < block.rows(); ++i) triplets.emplace_back(row + i, col + j, block(i, j));
}

Eigen::SparseMatrix<double> from_triplets(Eigen::Index rows, Eigen::Index cols, const Triplets& triplets) {
  Eigen::SparseMatrix<double> m(rows, cols);
  m.setFromTriplets(triplets.begin(), triplets.end());  // duplicates are summed
  return m;
}

// The inverse of a symmetric positive definite block; throws std::logic_error naming `what` if it is not.
template <class Square>
Square spd_inverse(const Square& m, const char* what) {
  const Eigen::LLT<Square> llt(m);
  if (llt.info() != Eigen::Success) throw std::logic_error(std::string("the information filter met ") + what +
                                                           " that is not positive definite");
  return llt.solve(Square::Identity(m.rows(), m.cols()));
}

// Landmarks whose columns one solve finds when the whole map's marginals are read.
constexpr std::size_t kMarginalsPerSolve = 32;

}  // namespace

ExtendedInformationFilter::ExtendedInformationFilter(std::shared_ptr<const MotionModel> motion,
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

void ExtendedInformationFilter::set_information(Sparse omega) {
  omega_ = std::move(omega);
  factorised_ = false;
  vehicle_columns_.resize(0, 0);
  landmark_columns_.clear();
}

bool ExtendedInformationFilter::factorise() const {
  if (factorised_) return true;
  // The fill-reducing ordering and the factor's pattern depend on Omega's pattern only, which the
  // updates between two factorisations only grow: the same size and count of entries is the same
  // pattern, except after a fusion, which prunes.
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

Eigen::MatrixXd ExtendedInformationFilter::covariance_columns(std::size_t first, std::size_t count) const {
  if (!factorise()) throw std::logic_error("the information matrix is not positive definite");
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(omega_.rows(), static_cast<Eigen::Index>(count));
  for (std::size_t i = 0; i < count; ++i) unit(static_cast<Eigen::Index>(first + i), static_cast<Eigen::Index>(i)) = 1.0;
  return llt_.solve(unit);
}

const Eigen::MatrixXd& ExtendedInformationFilter::vehicle_columns() const {
  if (vehicle_columns_.size() == 0) vehicle_columns_ = covariance_columns(0, 3);
  return vehicle_columns_;
}

const Eigen::MatrixXd& ExtendedInformationFilter::landmark_columns(std::size_t index) const {
  const std::size_t l = landmark_offset(index);
  auto found = landmark_columns_.find(l);
  if (found == landmark_columns_.end()) found = landmark_columns_.emplace(l, covariance_columns(l, 2)).first;
  return found->second;
}

ExtendedInformationFilter::Sparse ExtendedInformationFilter::with_motion(const Sparse& omega, const Matrix3& f,
                                                                         const Matrix3& q) {
  const Eigen::Index n = omega.rows();
  // Psi = A^-T Omega A^-1, A = diag(F, I): the information of the moved state before its noise.
  Triplets triplets;
  add_block(triplets, 0, 0, f.inverse());
  for (Eigen::Index i = 3; i < n; ++i) triplets.emplace_back(i, i, 1.0);
  const Sparse a_inverse = from_triplets(n, n, triplets);
  const Sparse psi = Sparse(a_inverse.transpose()) * omega * a_inverse;
  const Matrix3 psi_vv = psi.topLeftCorner(3, 3).toDense();
  Matrix3 k = (Matrix3::Identity() + q * psi_vv).lu().solve(q);
  k = (0.5 * (k + k.transpose())).eval();
  const Sparse columns = psi.leftCols(3);
  return psi - Sparse(columns * Sparse(k.sparseView()) * columns.transpose());
}

void ExtendedInformationFilter::apply_pending_motion() {
  if (pending_f_.isIdentity(0.0) && pending_q_.isZero(0.0)) return;
  set_information(with_motion(omega_, pending_f_, pending_q_));
  pending_f_.setIdentity();
  pending_q_.setZero();
}

Eigen::SparseMatrix<double> ExtendedInformationFilter::information() const {
  return with_motion(omega_, pending_f_, pending_q_);
}

Matrix3 ExtendedInformationFilter::pose_covariance() const {
  const Matrix3 moved = pending_f_ * vehicle_columns().topRows<3>() * pending_f_.transpose() + pending_q_;
  return 0.5 * (moved + moved.transpose());
}

Vector2 ExtendedInformationFilter::landmark_position(std::size_t index) const {
  return x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(index)));
}

Matrix2 ExtendedInformationFilter::landmark_covariance(std::size_t index) const {
  const Matrix2 block = landmark_columns(index).middleRows<2>(static_cast<Eigen::Index>(landmark_offset(index)));
  return 0.5 * (block + block.transpose());
}

Matrix2 ExtendedInformationFilter::landmark_cross_covariance(std::size_t i, std::size_t j) const {
  if (i == j) return landmark_covariance(i);
  // Whichever landmark's columns are already at hand (association asks about one against many).
  if (landmark_columns_.count(landmark_offset(i)) > 0)
    return landmark_columns(i).middleRows<2>(static_cast<Eigen::Index>(landmark_offset(j))).transpose();
  return landmark_columns(j).middleRows<2>(static_cast<Eigen::Index>(landmark_offset(i)));
}

Matrix23 ExtendedInformationFilter::landmark_pose_covariance(std::size_t index) const {
  return vehicle_columns().middleRows<2>(static_cast<Eigen::Index>(landmark_offset(index))) * pending_f_.transpose();
}

void ExtendedInformationFilter::landmark_marginals(std::vector<Vector2>& means,
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

Eigen::VectorXd ExtendedInformationFilter::state() const { return x_.head(static_cast<Eigen::Index>(dim_)); }

Eigen::MatrixXd ExtendedInformationFilter::covariance() const {
  Eigen::MatrixXd p = covariance_columns(0, dim_);
  // Through the pending motion: P -> A P A^T + B Q B^T with A = diag(F, I).
  p.topRows<3>() = (pending_f_ * p.topRows<3>()).eval();
  p.leftCols<3>() = (p.leftCols<3>() * pending_f_.transpose()).eval();
  p.topLeftCorner<3, 3>() += pending_q_;
  return 0.5 * (p + p.transpose());
}

void ExtendedInformationFilter::predict(const Control& u, double dt) {
  const Pose2 xv = x_.head<3>();
  const Matrix3 f = motion_->jacobian_state(xv, u, dt);
  const Matrix3 q = motion_->process_noise(xv, u, dt);
  x_.head<3>() = motion_->predict(xv, u, dt);
  pending_f_ = f * pending_f_;
  pending_q_ = f * pending_q_ * f.transpose() + q;
}

void ExtendedInformationFilter::inflate_pose(const Matrix3& q) { pending_q_ += q; }

bool ExtendedInformationFilter::update_landmark(const LandmarkObservation& observation) {
  return update_landmarks(std::span<const LandmarkObservation>(&observation, 1));
}

bool ExtendedInformationFilter::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  const Pose2 xv = pose();
  Triplets triplets;
  Eigen::VectorXd information_gain = Eigen::VectorXd::Zero(n);  // H^T R^-1 nu
  for (const LandmarkObservation& o : batch) {
    const auto l = static_cast<Eigen::Index>(landmark_offset(o.index));
    const Vector2 m = landmark_position(o.index);
    PoseJacobian hx;
    LandmarkJacobian hm;
    observation_->jacobians(xv, m, hx, hm);
    const Measurement nu = observation_->residual(o.z, observation_->predict(xv, m));
    const Eigen::MatrixXd r_inverse =
        spd_inverse(Eigen::MatrixXd(o.noise_scale * observation_->noise()), "a measurement noise");
    const Eigen::MatrixXd hx_t = hx.transpose() * r_inverse, hm_t = hm.transpose() * r_inverse;
    add_block(triplets, 0, 0, hx_t * hx);
    add_block(triplets, 0, l, hx_t * hm);
    add_block(triplets, l, 0, hm_t * hx);
    add_block(triplets, l, l, hm_t * hm);
    information_gain.head<3>() += hx_t * nu;
    information_gain.segment<2>(l) += hm_t * nu;
  }
  Sparse prior = omega_;
  set_information(omega_ + from_triplets(n, n, triplets));
  if (!factorise()) {
    set_information(std::move(prior));
    pattern_changed_ = true;
    return false;
  }
  // The EKF's x += P H^T S^-1 nu, in information form: (Omega + H^T R^-1 H)^-1 H^T R^-1 nu.
  x_.head(n) += llt_.solve(information_gain);
  x_[2] = wrap_angle(x_[2]);
  return true;
}

std::size_t ExtendedInformationFilter::add_landmark(const InitialLandmark& landmark) {
  apply_pending_motion();
  const auto l = static_cast<Eigen::Index>(dim_);
  const Matrix2 information = spd_inverse(landmark.covariance, "a new landmark's covariance given the pose");
  reserve(dim_ + 2);
  x_.segment<2>(l) = landmark.mean;
  // The factor m - Gx x_v, its Jacobian [-Gx I] over (vehicle, landmark).
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
  return num_landmarks() - 1;
}

void ExtendedInformationFilter::remove_landmark(std::size_t index) {
  apply_pending_motion();
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  // Marginalised: Omega - Omega(:, m) Omega(m, m)^-1 Omega(m, :), whose rows of m then go.
  const Sparse columns = omega_.middleCols(l, 2);
  const Matrix2 own = spd_inverse(Matrix2(omega_.block(l, l, 2, 2).toDense()), "a landmark's information block");
  set_information(omega_ - Sparse(columns * Sparse(own.sparseView()) * columns.transpose()));
  remove_stored_landmark(index);
}

void ExtendedInformationFilter::squeeze_stored_rows(std::size_t first, std::size_t count) {
  const auto n = static_cast<Eigen::Index>(dim_), f = static_cast<Eigen::Index>(first),
             c = static_cast<Eigen::Index>(count);
  Triplets triplets;
  for (Eigen::Index r = 0; r < n; ++r)
    if (r < f || r >= f + c) triplets.emplace_back(r < f ? r : r - c, r, 1.0);
  const Sparse keep = from_triplets(n - c, n, triplets);
  set_information(keep * omega_ * Sparse(keep.transpose()));
}

bool ExtendedInformationFilter::fuse_landmarks(std::span<const LandmarkPair> pairs) {
  if (pairs.empty()) return true;
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  // x = T y with y the state in which each duplicate's rows hold e = m_duplicate - m_original.
  std::vector<char> duplicate_row(dim_, 0);
  Eigen::VectorXd difference = Eigen::VectorXd::Zero(n);  // y's e rows, zero elsewhere
  Triplets triplets;
  for (Eigen::Index i = 0; i < n; ++i) triplets.emplace_back(i, i, 1.0);
  for (const LandmarkPair& pair : pairs) {
    const auto d = static_cast<Eigen::Index>(landmark_offset(pair.duplicate));
    const auto o = static_cast<Eigen::Index>(landmark_offset(pair.original));
    for (Eigen::Index i = 0; i < 2; ++i) {
      triplets.emplace_back(d + i, o + i, 1.0);
      duplicate_row[static_cast<std::size_t>(d + i)] = 1;
    }
    difference.segment<2>(d) = x_.segment<2>(d) - x_.segment<2>(o);
  }
  const Sparse t = from_triplets(n, n, triplets);
  Sparse conditioned = Sparse(t.transpose()) * omega_ * t;
  // Given e = 0 the rest keeps its block of information, and its mean, mu_r - Omega_rr^-1 Omega_re
  // (e - mu_e) given e, moves by Omega_rr^-1 Omega_re mu_e.
  Eigen::VectorXd shift = conditioned * difference;
  for (Eigen::Index i = 0; i < n; ++i)
    if (duplicate_row[static_cast<std::size_t>(i)]) shift[i] = 0.0;
  conditioned.prune([&](Eigen::Index row, Eigen::Index col, double) {
    return !duplicate_row[static_cast<std::size_t>(row)] && !duplicate_row[static_cast<std::size_t>(col)];
  });
  triplets.clear();
  for (Eigen::Index i = 0; i < n; ++i)
    if (duplicate_row[static_cast<std::size_t>(i)]) triplets.emplace_back(i, i, 1.0);
  Sparse prior = omega_;
  set_information(conditioned + from_triplets(n, n, triplets));
  pattern_changed_ = true;
  if (!factorise()) {
    set_information(std::move(prior));
    pattern_changed_ = true;
    return false;
  }
  x_.head(n) += llt_.solve(shift);
  x_[2] = wrap_angle(x_[2]);
  for (const LandmarkPair& pair : pairs)
    x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(pair.duplicate))) =
        x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(pair.original)));
  return true;
}

void ExtendedInformationFilter::add_statistics(std::map<std::string, double>& statistics) const {
  statistics["information_nonzeros"] = static_cast<double>(omega_.nonZeros());
  statistics["information_factorisations"] = static_cast<double>(factorisations_);
}

}  // namespace slamkit
