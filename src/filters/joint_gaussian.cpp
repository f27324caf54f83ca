#include "slamkit/filters/joint_gaussian.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/chi_square.hpp"

namespace slamkit {

namespace {
// An iterate that moves no row the batch reads by more than this (metres, radians) has converged.
constexpr double kIterateTolerance = 1e-6;

// Eigen's matrix-product kernels pack their operands into buffers that live on the stack up to
// EIGEN_STACK_ALLOCATION_LIMIT (128 KB) and come from the heap above it. A product over the whole
// covariance (a tall n x k operand) passes that limit once the map has a few hundred landmarks, so
// the triangular solve that spans it is cut into row tiles whose packed operands stay below it.
constexpr Eigen::Index kPackedBytes = 96 * 1024;
Eigen::Index tile_rows(Eigen::Index depth) {
  return std::clamp<Eigen::Index>(kPackedBytes / (static_cast<Eigen::Index>(sizeof(double)) * std::max<Eigen::Index>(depth, 1)),
                                  16, 512);
}

// The exponential of SE_{1+n}(2) at the heading phi: exp(xi) X turns every position p of X about the
// origin and adds V(phi) xi_p, p -> R(phi) p + V(phi) xi_p, and the heading by phi. With the
// invariant error written in the standard error's coordinates, xi_p = d_p - phi J p (J the 90-degree
// rotation), a correction d moves the position p to R(phi) p + V(phi) (d_p - phi J p).
struct GroupExponential {
  explicit GroupExponential(double phi) : phi(phi) {
    const double c = std::cos(phi), sn = std::sin(phi);
    const double a = std::abs(phi) < 1e-9 ? 1.0 - phi * phi / 6.0 : sn / phi;
    const double b = std::abs(phi) < 1e-9 ? phi / 2.0 : (1.0 - c) / phi;
    rot << c, -sn, sn, c;
    v << a, -b, b, a;
  }
  Vector2 move(const Vector2& p, const Vector2& d) const { return rot * p + v * (d - phi * perp(p)); }
  static Vector2 perp(const Vector2& p) { return Vector2(-p[1], p[0]); }

  double phi;
  Matrix2 rot, v;
};

}  // namespace

JointGaussian::JointGaussian(std::shared_ptr<const MotionModel> motion,
                             std::shared_ptr<const ObservationModel> observation, const Pose2& initial_pose,
                             const Matrix3& initial_covariance, Linearisation linearisation, int update_iterations)
    : DenseCovarianceEstimator(std::move(motion), std::move(observation), initial_pose, initial_covariance),
      linearisation_(linearisation),
      update_iterations_(update_iterations),
      predicted_pose_(x_.head<3>()) {
  if (update_iterations_ < 1 || update_iterations_ > kMaxUpdateIterations)
    throw std::invalid_argument("EKF update iterations must be from 1 to " + std::to_string(kMaxUpdateIterations) +
                                ", found " + std::to_string(update_iterations_));
}

Vector2 JointGaussian::landmark_position(std::size_t index) const {
  const Vector2 stored = x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(index)));
  return inverse_distance_[index] ? inverse_distance_point(index, x_).position(stored) : stored;
}

Matrix2 JointGaussian::landmark_covariance(std::size_t index) const {
  const std::size_t l = landmark_offset(index);
  if (!inverse_distance_[index]) return diagonal_block<2>(l);
  const Eigen::Matrix<double, 2, 4> j = point_jacobian(index);
  const Matrix2 point = j * diagonal_block<4>(l) * j.transpose();
  return 0.5 * (point + point.transpose());
}

Matrix2 JointGaussian::landmark_cross_covariance(std::size_t i, std::size_t j) const {
  if (i == j) return landmark_covariance(i);
  const auto a = static_cast<Eigen::Index>(landmark_offset(i));
  const auto b = static_cast<Eigen::Index>(landmark_offset(j));
  // Only the lower triangle is stored: the block with the larger row offset holds the pair.
  if (!inverse_distance_[i] && !inverse_distance_[j])  // two points, as JCBB asks for every pair
    return a > b ? Matrix2(p_.block<2, 2>(a, b)) : Matrix2(p_.block<2, 2>(b, a).transpose());
  const auto rows_i = static_cast<Eigen::Index>(landmark_rows(i)), rows_j = static_cast<Eigen::Index>(landmark_rows(j));
  Eigen::Matrix4d stored = Eigen::Matrix4d::Zero();
  if (a > b)
    stored.topLeftCorner(rows_i, rows_j) = p_.block(a, b, rows_i, rows_j);
  else
    stored.topLeftCorner(rows_i, rows_j) = p_.block(b, a, rows_j, rows_i).transpose();
  return point_jacobian(i) * stored * point_jacobian(j).transpose();
}

Matrix23 JointGaussian::landmark_pose_covariance(std::size_t index) const {
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  if (!inverse_distance_[index]) return p_.block<2, 3>(l, 0) * pending_motion_.transpose();
  return point_jacobian(index) * p_.block<4, 3>(l, 0) * pending_motion_.transpose();
}

Eigen::VectorXd JointGaussian::state() const { return x_.head(static_cast<Eigen::Index>(dim_)); }

Eigen::MatrixXd JointGaussian::covariance() const {
  const auto n = static_cast<Eigen::Index>(dim_);
  Eigen::MatrixXd full = p_.topLeftCorner(n, n).selfadjointView<Eigen::Lower>();
  full.block(3, 0, n - 3, 3) = full.block(3, 0, n - 3, 3) * pending_motion_.transpose();
  full.block(0, 3, 3, n - 3) = full.block(3, 0, n - 3, 3).transpose();
  return full;
}

void JointGaussian::apply_pending_motion() {
  const auto m = static_cast<Eigen::Index>(dim_) - 3;
  if (pending_motion_.isIdentity(0.0) || m == 0) {
    pending_motion_.setIdentity();
    return;
  }
  auto pmv = p_.block(3, 0, m, 3);
  scratch3_.topRows(m).noalias() = pmv * pending_motion_.transpose();
  pmv = scratch3_.topRows(m);
  pending_motion_.setIdentity();
}

void JointGaussian::predict(const Control& u, double dt) {
  const Pose2 xv = x_.head<3>();
  const Matrix3 q = motion_->process_noise(xv, u, dt);
  x_.head<3>() = motion_->predict(xv, u, dt);
  const Matrix3 f = linearisation_ == Linearisation::kFirstEstimates
                        ? MotionModel::jacobian_between(predicted_pose_, x_.head<3>())
                        : motion_->jacobian_state(xv, u, dt);
  predicted_pose_ = x_.head<3>();
  p_.topLeftCorner<3, 3>() = f * diagonal_block<3>(0) * f.transpose() + q;
  // Landmarks are static: only the map-vehicle cross-covariance P_mv changes, to P_mv F^T. The Fs of
  // the controls between two scans are multiplied together and applied to P_mv once, when it is
  // next needed: the same product, O(1) per control instead of O(n).
  pending_motion_ = f * pending_motion_;
}

void JointGaussian::inflate_pose(const Matrix3& q) {
  // The cross-covariances do not change (the noise is independent of the state), nor does the
  // motion still pending for them.
  p_.topLeftCorner<3, 3>() = diagonal_block<3>(0) + q;
}

template <int D>
void JointGaussian::add_column_block(std::size_t offset, const LandmarkRows<D>& h,
                                     Eigen::Ref<Eigen::Matrix<double, Eigen::Dynamic, D>> out) const {
  const auto n = static_cast<Eigen::Index>(dim_);
  const auto l = static_cast<Eigen::Index>(offset);
  // Rows above the block come from the transposed row block.
  out.topRows(l).noalias() += p_.block(l, 0, 2, l).transpose() * h.transpose();
  out.template middleRows<2>(l).noalias() += diagonal_block<2>(offset) * h.transpose();
  out.bottomRows(n - l - 2).noalias() += p_.block(l + 2, l, n - l - 2, 2) * h.transpose();
}

template <int D>
void JointGaussian::covariance_times_jacobian(std::size_t lm_offset, const PoseRows<D>& hx, const LandmarkRows<D>& hm,
                                              const LandmarkRows<D>* horigin, int calibrated, double distance,
                                              Eigen::Ref<Eigen::Matrix<double, Eigen::Dynamic, D>> out) const {
  const auto n = static_cast<Eigen::Index>(dim_);
  // H = [hx 0 .. 0 hm (horigin) 0 .. 0], so P H^T = P(:, vehicle) hx^T + P(:, landmark) hm^T
  // (+ P(:, origin) horigin^T), each column block read from the lower triangle.
  out.template topRows<3>().noalias() = diagonal_block<3>(0) * hx.transpose();
  out.bottomRows(n - 3).noalias() = p_.block(3, 0, n - 3, 3) * hx.transpose();
  add_column_block<D>(lm_offset, hm, out);
  if (horigin) add_column_block<D>(lm_offset + 2, *horigin, out);
  if (calibrated >= 0) {
    // P(:, offset) + distance P(:, scale), each column read from the lower triangle.
    const Vector2 hp(1.0, distance);
    auto column = out.col(calibrated);
    column.template head<3>() += p_.block<2, 3>(kOffsetRow, 0).transpose() * hp;
    column.template segment<2>(kOffsetRow) += diagonal_block<2>(kOffsetRow) * hp;
    column.tail(n - kScaleRow - 1) += p_.block(kScaleRow + 1, kOffsetRow, n - kScaleRow - 1, 2) * hp;
  }
}

bool JointGaussian::update_landmark(const LandmarkObservation& observation) {
  if (update_iterations_ > 1) return update_landmarks(std::span<const LandmarkObservation>(&observation, 1));
  const bool updated = with_measurement_dim(
      observation_->dim(), [&]<int D>(std::integral_constant<int, D>) { return update_one<D>(observation); });
  if (updated && inverse_distance_held_ > 0) convert_where_linear(std::span<const LandmarkObservation>(&observation, 1));
  return updated;
}

template <int D>
bool JointGaussian::update_one(const LandmarkObservation& observation) {
  const std::size_t index = observation.index;
  const Measurement& z = observation.z;
  apply_pending_motion();
  if (linearisation_ == Linearisation::kFirstEstimates) anchor_where_plausible(index);
  const std::size_t l = landmark_offset(index);
  const auto li = static_cast<Eigen::Index>(l);
  const auto n = static_cast<Eigen::Index>(dim_);
  PoseRows<D> hx;
  LandmarkRows<D> hm, horigin;
  Measurement zhat = predict_linearised<D>(index, x_, linearisation_, hx, hm, horigin);
  const bool with_origin = inverse_distance_[index];
  const int calibrated = calibrated_row();
  const double distance = calibrated >= 0 ? calibrate<D>(x_, zhat, hx, hm) : 0.0;
  const MeasurementVector<D> nu = observation_->residual(z, zhat);

  auto pht = pht_.leftCols<D>().topRows(n);  // columns known at compile time: the DxD products stay fixed-size
  covariance_times_jacobian<D>(l, hx, hm, with_origin ? &horigin : nullptr, calibrated, distance, pht);
  MeasurementSquare<D> s = hx * pht.template topRows<3>() + hm * pht.template middleRows<2>(li);
  if (with_origin) s += horigin * pht.template middleRows<2>(li + 2);
  if (calibrated >= 0) s.row(calibrated) += pht.row(kOffsetRow) + distance * pht.row(kScaleRow);
  s += observation.noise_scale * MeasurementSquare<D>(observation_->noise());
  s = (0.5 * (s + s.transpose())).eval();
  const Eigen::LLT<MeasurementSquare<D>> llt(s);
  if (llt.info() != Eigen::Success) return false;

  // Eq. (10): x += W nu with W = P H^T S^-1.
  const MeasurementVector<D> weights = llt.solve(nu);
  if (linearisation_ == Linearisation::kInvariant) {
    batch_nu_.resize(std::max<Eigen::Index>(batch_nu_.size(), n));
    batch_nu_.head(n).noalias() = pht * weights;
  } else {
    x_.head(n).noalias() += pht * weights;
    x_[2] = wrap_angle(x_[2]);
  }

  // Eq. (11): P -= W S W^T = C C^T with C = P H^T L^-T (S = L L^T). L^-T is upper triangular, so C
  // is formed in place; for two rows by hand, column 1 first because it still needs the old column 0.
  if constexpr (D == 2) {
    const Matrix2 lower = llt.matrixL();
    const double a00 = 1.0 / lower(0, 0), a11 = 1.0 / lower(1, 1);
    const double a01 = -lower(1, 0) * a00 * a11;
    auto c0 = pht.col(0);
    auto c1 = pht.col(1);
    c1 = a01 * c0 + a11 * c1;
    c0 *= a00;
  } else {
    llt.matrixU().template solveInPlace<Eigen::OnTheRight>(pht);
  }
  downdate(pht);
  if (linearisation_ == Linearisation::kInvariant) correct(batch_nu_.head(n));
  return true;
}

void JointGaussian::reserve_joint_update(Eigen::Index k) {
  if (pht_.cols() < k) pht_.resize(pht_.rows(), std::max(k, 2 * pht_.cols()));
  if (batch_s_.rows() < pht_.cols()) {
    batch_s_.resize(pht_.cols(), pht_.cols());
    batch_nu_.resize(std::max(pht_.cols(), pht_.rows()));
  }
}

bool JointGaussian::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  if (batch.size() == 1 && update_iterations_ == 1) return update_landmark(batch[0]);
  const bool updated = with_measurement_dim(
      observation_->dim(), [&]<int D>(std::integral_constant<int, D>) { return update_batch<D>(batch); });
  if (updated && inverse_distance_held_ > 0) convert_where_linear(batch);
  return updated;
}

template <int D>
bool JointGaussian::update_batch(std::span<const LandmarkObservation> batch) {
  apply_pending_motion();
  if (linearisation_ == Linearisation::kFirstEstimates)
    for (const LandmarkObservation& o : batch) anchor_where_plausible(o.index);
  const auto n = static_cast<Eigen::Index>(dim_);
  const auto k = static_cast<Eigen::Index>(D * batch.size());
  reserve_joint_update(k);
  BatchJacobians<D>& jacobians = batch_jacobians_.get<D>();
  jacobians.hx.resize(batch.size());
  jacobians.hm.resize(batch.size());
  jacobians.horigin.resize(batch.size());
  if (update_iterations_ == 1) {
    linearise_batch<D>(batch, x_, linearisation_);
    return apply_joint_update(k);
  }
  // Iterated: relinearise at the update's result until it stops moving. The rows the batch reads
  // (the vehicle and the observed landmarks) are all an iterate needs.
  if (iterate_.size() < x_.size()) {
    iterate_.resize(x_.size());
    iterate_step_.resize(x_.size());
    iterate_correction_.resize(x_.size());
  }
  iterate_.head(n) = x_.head(n);
  if (iterate_s_.rows() < k) iterate_s_.resize(batch_s_.rows(), batch_s_.cols());
  // The iterates are Gauss-Newton's, with the Jacobians at each; the first-estimates variant then
  // makes its update with its own Jacobians about the last iterate (its fixed Jacobians drove the
  // iterates astray where a landmark's first estimate is poor: Victoria Park ATE 1.70 -> 4.12 m).
  // The invariant variant iterates on the group (see linearise_batch).
  const bool on_group = linearisation_ == Linearisation::kInvariant;
  const bool calibrated = calibrates_ranges();
  if (on_group) {
    iterate_correction_.head(static_cast<Eigen::Index>(map_offset())).setZero();
    for (const LandmarkObservation& o : batch)
      iterate_correction_.segment<2>(static_cast<Eigen::Index>(landmark_offset(o.index))).setZero();
  }
  for (int iteration = 1;; ++iteration) {
    linearise_batch<D>(batch, iterate_, on_group ? Linearisation::kInvariant : Linearisation::kStandard);
    if (iteration == update_iterations_) break;
    auto s = iterate_s_.topLeftCorner(k, k);
    s = batch_s_.topLeftCorner(k, k);
    s.triangularView<Eigen::StrictlyLower>() = 0.5 * (s + s.transpose());
    const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(s);
    if (llt.info() != Eigen::Success) break;  // apply_joint_update reports it
    auto step = iterate_step_.head(k);
    step = batch_nu_.head(k);
    llt.solveInPlace(step);
    // The next iterate: where the update with this linearisation would put the rows, the correction
    // W S^-1 nu added to the estimate (on the group: through its exponential).
    double change = 0.0;
    const auto moved_by = [&](Eigen::Index row, double next) {
      double moved = next - iterate_[row];
      if (row == 2) {
        next = wrap_angle(next);
        moved = wrap_angle(moved);
      }
      change = std::max(change, std::abs(moved));
      iterate_[row] = next;
    };
    if (on_group) {
      const auto correction = [&](Eigen::Index row) {
        iterate_correction_.segment<2>(row) = pht_.middleRows<2>(row).leftCols(k) * step;
      };
      correction(0);
      iterate_correction_[2] = pht_.row(2).head(k).dot(step);
      const GroupExponential g(iterate_correction_[2]);
      const auto move = [&](Eigen::Index row) {
        const Vector2 next = g.move(x_.segment<2>(row), iterate_correction_.segment<2>(row));
        moved_by(row, next[0]);
        moved_by(row + 1, next[1]);
      };
      move(0);
      moved_by(2, x_[2] + g.phi);
      if (calibrated)
        // Neither a turn nor a shift of the scene changes the calibration: corrected additively.
        for (const Eigen::Index row : {kOffsetRow, kScaleRow}) {
          iterate_correction_[row] = pht_.row(row).head(k).dot(step);
          moved_by(row, x_[row] + iterate_correction_[row]);
        }
      for (const LandmarkObservation& o : batch) {
        const auto l = static_cast<Eigen::Index>(landmark_offset(o.index));
        correction(l);
        move(l);
      }
    } else {
      for (auto row = Eigen::Index{0}; row < static_cast<Eigen::Index>(map_offset()); ++row)
        moved_by(row, x_[row] + pht_.row(row).head(k).dot(step));
      for (const LandmarkObservation& o : batch)
        for (std::size_t row = 0; row < landmark_rows(o.index); ++row) {
          const auto r = static_cast<Eigen::Index>(landmark_offset(o.index) + row);
          moved_by(r, x_[r] + pht_.row(r).head(k).dot(step));
        }
    }
    if (change < kIterateTolerance) break;
  }
  if (linearisation_ == Linearisation::kFirstEstimates) linearise_batch<D>(batch, iterate_, linearisation_);
  return apply_joint_update(k);
}

template <int D>
void JointGaussian::linearise_batch(std::span<const LandmarkObservation> batch, const Eigen::VectorXd& at,
                                    Linearisation how) {
  const auto n = static_cast<Eigen::Index>(dim_);
  const auto k = static_cast<Eigen::Index>(D * batch.size());
  std::vector<PoseRows<D>>& batch_hx = batch_jacobians_.get<D>().hx;
  std::vector<LandmarkRows<D>>& batch_hm = batch_jacobians_.get<D>().hm;
  std::vector<LandmarkRows<D>>& batch_horigin = batch_jacobians_.get<D>().horigin;
  const Pose2 xv = at.head<3>();
  Pose2 vehicle_offset = x_.head<3>() - xv;
  vehicle_offset[2] = wrap_angle(vehicle_offset[2]);
  // The invariant variant's iterates are on the group, away from the estimate (the single update's
  // linearisation is the first iterate's, at a zero correction).
  const bool on_group = how == Linearisation::kInvariant && update_iterations_ > 1;
  const Vector2 vehicle_turn = GroupExponential::perp(xv.head<2>() - x_.head<2>());
  // W = P H^T, D columns per observation, each from the two column blocks its rows of H touch.
  auto pht = pht_.topLeftCorner(n, k);
  auto nu = batch_nu_.head(k);
  const int calibrated = calibrated_row();
  if (calibrated >= 0) batch_distances_.resize(batch.size());
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const auto l = static_cast<Eigen::Index>(landmark_offset(batch[i].index));
    const auto r = D * static_cast<Eigen::Index>(i);
    const Vector2 m = at.segment<2>(l);
    Measurement zhat = predict_linearised<D>(batch[i].index, at, how, batch_hx[i], batch_hm[i], batch_horigin[i]);
    const bool with_origin = inverse_distance_[batch[i].index];
    const double distance = calibrated >= 0 ? calibrate<D>(at, zhat, batch_hx[i], batch_hm[i]) : 0.0;
    if (calibrated >= 0) batch_distances_[i] = distance;
    // Zero at the estimate; at an iterate, h(x) ~ h(at) + H (x - at) carries it back to the estimate.
    MeasurementVector<D> to_estimate;
    if (on_group) {
      // The prior's invariant error expressed at the iterate, xi - xi_i (the invariant filter's
      // reset, exp's Jacobian at xi_i taken as the identity), is the correction's d - d_i carried
      // by M_i = T(at)^-1 T(x) = I + u e_theta^T, u = J (at - x) for each position. H becomes the
      // standard Jacobian at the iterate times M_i; like the invariant Jacobian it leaves the
      // turn of the whole scene about the origin unobserved, at every iterate.
      const Vector2 landmark_correction = iterate_correction_.segment<2>(l);
      batch_hx[i].col(2) += batch_hx[i].template leftCols<2>() * vehicle_turn +
                            batch_hm[i] * GroupExponential::perp(m - x_.segment<2>(l));
      to_estimate = -(batch_hx[i] * iterate_correction_.head<3>() + batch_hm[i] * landmark_correction);
      if (calibrated >= 0)
        to_estimate[calibrated] -= iterate_correction_[kOffsetRow] + distance * iterate_correction_[kScaleRow];
    } else {
      to_estimate = batch_hx[i] * vehicle_offset + batch_hm[i] * (x_.segment<2>(l) - m);
      if (with_origin) to_estimate += batch_horigin[i] * (x_.segment<2>(l + 2) - at.segment<2>(l + 2));
      if (calibrated >= 0)
        to_estimate[calibrated] += x_[kOffsetRow] - at[kOffsetRow] + distance * (x_[kScaleRow] - at[kScaleRow]);
    }
    nu.template segment<D>(r) = MeasurementVector<D>(observation_->residual(batch[i].z, zhat)) - to_estimate;
    covariance_times_jacobian<D>(static_cast<std::size_t>(l), batch_hx[i], batch_hm[i],
                                 with_origin ? &batch_horigin[i] : nullptr, calibrated, distance,
                                 pht.template middleCols<D>(r));
  }
  // S = H P H^T + R, block (i, j) = H_i (P H_j^T).
  auto s = batch_s_.topLeftCorner(k, k);
  const MeasurementSquare<D> noise = observation_->noise();
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const auto l = static_cast<Eigen::Index>(landmark_offset(batch[i].index));
    const auto r = D * static_cast<Eigen::Index>(i);
    s.template middleRows<D>(r).noalias() =
        batch_hx[i] * pht.template topRows<3>() + batch_hm[i] * pht.template middleRows<2>(l);
    if (inverse_distance_[batch[i].index])
      s.template middleRows<D>(r).noalias() += batch_horigin[i] * pht.template middleRows<2>(l + 2);
    if (calibrated >= 0)
      s.row(r + calibrated) += pht.row(kOffsetRow) + batch_distances_[i] * pht.row(kScaleRow);
    s.template block<D, D>(r, r) += batch[i].noise_scale * noise;
  }
}

bool JointGaussian::apply_joint_update(Eigen::Index k) {
  const auto n = static_cast<Eigen::Index>(dim_);
  auto pht = pht_.topLeftCorner(n, k);
  auto nu = batch_nu_.head(k);
  auto s = batch_s_.topLeftCorner(k, k);
  // The factorisation reads the lower triangle only, so symmetrising it is enough; in place, as an
  // LLT of a Ref, so that it needs no storage of its own.
  s.triangularView<Eigen::StrictlyLower>() = 0.5 * (s + s.transpose());
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(s);
  if (llt.info() != Eigen::Success) return false;
  llt.solveInPlace(nu);
  // The correction W S^-1 nu: applied at once by the additive variants; the invariant one needs the
  // downdated covariance first, so it keeps the correction in the scratch column beside W.
  if (linearisation_ == Linearisation::kInvariant) {
    if (transport_b_.size() < n) transport_b_.resize(x_.size());
    transport_b_.head(n).noalias() = pht * nu;
  } else {
    x_.head(n).noalias() += pht * nu;
    x_[2] = wrap_angle(x_[2]);
  }
  // P -= W S^-1 W^T = C C^T with C = W L^-T: one pass over the lower triangle for the scan.
  // Row by row independent (C L^T = W), so solved in row tiles for the same reason as the downdate.
  for (Eigen::Index r = 0, tile = tile_rows(k); r < n; r += tile)
    llt.matrixU().solveInPlace<Eigen::OnTheRight>(pht.middleRows(r, std::min(tile, n - r)));
  downdate(pht);
  if (linearisation_ == Linearisation::kInvariant) {
    batch_nu_.resize(std::max<Eigen::Index>(batch_nu_.size(), n));
    batch_nu_.head(n) = transport_b_.head(n);
    correct(batch_nu_.head(n));
  }
  return true;
}

template <int D>
void JointGaussian::observation_jacobians(std::size_t index, const Eigen::VectorXd& at, Linearisation how,
                                          PoseRows<D>& hx, LandmarkRows<D>& hm) const {
  PoseJacobian pose_rows;
  LandmarkJacobian landmark_rows;
  if (how == Linearisation::kFirstEstimates)
    observation_->jacobians(predicted_pose_, first_estimates_[index], pose_rows, landmark_rows);
  else
    observation_->jacobians(at.head<3>(), at.segment<2>(static_cast<Eigen::Index>(landmark_offset(index))), pose_rows,
                            landmark_rows);
  hx = pose_rows;
  hm = landmark_rows;
}

void JointGaussian::correct(const Eigen::Ref<const Eigen::VectorXd>& delta) {
  const auto n = static_cast<Eigen::Index>(dim_);
  // The correction in the invariant error's coordinates, applied as X+ = exp(xi) X- (see
  // GroupExponential). To first order that is the additive correction.
  const GroupExponential g(delta[2]);
  if (transport_u_.size() < n) {
    transport_u_.resize(x_.size());
    transport_b_.resize(x_.size());
  }
  auto u = transport_u_.head(n);
  u[2] = 0.0;
  if (calibrates_ranges())
    // Unchanged by a turn or shift of the scene: corrected additively, not transported.
    for (const Eigen::Index row : {kOffsetRow, kScaleRow}) {
      x_[row] += delta[row];
      u[row] = 0.0;
    }
  const auto map = static_cast<Eigen::Index>(map_offset());
  for (Eigen::Index o = 0; o < n; o += (o == 0 ? map : 2)) {
    const Vector2 before = x_.segment<2>(o);
    const Vector2 after = g.move(before, delta.segment<2>(o));
    x_.segment<2>(o) = after;
    // The covariance moves to the new estimate's coordinates: d -> M d with M = I + u e_theta^T,
    // u = J (after - before) for each position (0 for the heading).
    u.segment<2>(o) = GroupExponential::perp(after - before);
  }
  x_[2] = wrap_angle(x_[2] + g.phi);
  // M P M^T = P + u a^T + a u^T + a_theta u u^T with a = P e_theta: one symmetric rank-2 update.
  auto bvec = transport_b_.head(n);
  bvec.head<3>() = diagonal_block<3>(0).col(2);
  bvec.tail(n - 3) = p_.block(3, 2, n - 3, 1);
  bvec += (0.5 * bvec[2]) * u;
  p_.topLeftCorner(n, n).selfadjointView<Eigen::Lower>().rankUpdate(u, bvec);
}

template <int D>
Measurement JointGaussian::predict_linearised(std::size_t index, const Eigen::VectorXd& at, Linearisation how,
                                              PoseRows<D>& hx, LandmarkRows<D>& hm, LandmarkRows<D>& horigin) const {
  const Pose2 xv = at.head<3>();
  const Vector2 m = at.segment<2>(static_cast<Eigen::Index>(landmark_offset(index)));
  if (inverse_distance_[index]) {
    PoseJacobian pose_rows;
    LandmarkJacobian parameter_rows, origin_rows;
    const Measurement zhat =
        inverse_distance_point(index, at).predict(*observation_, xv, m, &pose_rows, &parameter_rows, &origin_rows);
    if (how == Linearisation::kFirstEstimates)
      // At the predicted pose and the origin's first estimate: the unobservable turn of the scene
      // then has the same components at every step (theta's and rho's do not depend on where they
      // are taken), so the bearings add no information about it. (theta and rho at their current
      // estimates: rho's first is the prior's guess.)
      InverseDistancePoint{first_estimates_[index]}.predict(*observation_, predicted_pose_, m, &pose_rows,
                                                            &parameter_rows, &origin_rows);
    hx = pose_rows;
    hm = parameter_rows;
    horigin = origin_rows;
    return zhat;
  }
  observation_jacobians<D>(index, at, how, hx, hm);
  return observation_->predict(xv, m);
}

void JointGaussian::innovation(std::size_t index, Measurement& zhat, MeasurementCovariance& s) const {
  if (!inverse_distance_[index]) {
    EkfEstimator::innovation(index, zhat, s);
    return;
  }
  PoseRows<1> hx;
  LandmarkRows<1> hp, horigin;
  zhat = predict_linearised<1>(index, x_, linearisation_, hx, hp, horigin);
  Eigen::Matrix<double, 1, 7> h;
  h << hx, hp, horigin;
  // P over (vehicle, parameters, origin), the pending motion applied to the cross-covariances.
  const std::size_t l = landmark_offset(index);
  Eigen::Matrix<double, 7, 7> p;
  p.topLeftCorner<3, 3>() = diagonal_block<3>(0);
  p.bottomRightCorner<4, 4>() = diagonal_block<4>(l);
  p.bottomLeftCorner<4, 3>() = p_.block<4, 3>(static_cast<Eigen::Index>(l), 0) * pending_motion_.transpose();
  p.topRightCorner<3, 4>() = p.bottomLeftCorner<4, 3>().transpose();
  s = MeasurementSquare<1>(h * p * h.transpose() + observation_->noise());
}

void JointGaussian::anchor_where_plausible(std::size_t index) {
  if (inverse_distance_[index]) return;  // anchored at the point it converts to
  Vector2& anchor = first_estimates_[index];
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  const Vector2 m = x_.segment<2>(l);
  const Vector2 moved = m - anchor;
  // Cov(m - p) = P_mm - P_mp - P_pm + P_pp over the vehicle's position.
  const Matrix2 cross = p_.block<2, 2>(l, 0);
  const Matrix2 relative =
      diagonal_block<2>(landmark_offset(index)) - cross - cross.transpose() + diagonal_block<2>(0);
  static const double gate = eval::chi_square_quantile(kPlausibleAnchorProbability, 2.0);
  const Eigen::LLT<Matrix2> llt(relative);
  if (llt.info() != Eigen::Success || moved.dot(llt.solve(moved)) <= gate) return;
  // P -> M P M^T with M = I + u e_theta^T, u = J (m - anchor) in the landmark's rows only: those rows
  // gain u times the heading's row a = P(2, :), and their diagonal block also a_theta u u^T.
  const Vector2 u = GroupExponential::perp(moved);
  const auto n = static_cast<Eigen::Index>(dim_);
  const double a_theta = p_(2, 2);
  const Vector2 a_landmark = p_.block<2, 1>(l, 2);
  for (Eigen::Index c = 0; c < l; ++c) p_.block<2, 1>(l, c) += u * (c >= 2 ? p_(c, 2) : p_(2, c));
  for (Eigen::Index r = l + 2; r < n; ++r) p_.block<1, 2>(r, l) += p_(r, 2) * u.transpose();
  const Matrix2 block = u * a_landmark.transpose() + a_landmark * u.transpose() + a_theta * u * u.transpose();
  p_.block<2, 2>(l, l).triangularView<Eigen::Lower>() += block;
  anchor = m;
  ++anchors_moved_;
}

void JointGaussian::add_statistics(std::map<std::string, double>& statistics) const {
  if (linearisation_ == Linearisation::kFirstEstimates)
    statistics["first_estimates_moved"] = static_cast<double>(anchors_moved_);
  if (inverse_distance_held_ + inverse_distance_converted_ > 0) {
    statistics["landmarks_inverse_distance"] = static_cast<double>(inverse_distance_held_);
    statistics["inverse_distance_converted"] = static_cast<double>(inverse_distance_converted_);
  }
}

std::size_t JointGaussian::add_landmark(const InitialLandmark& landmark) {
  reserve(dim_ + 2);
  apply_pending_motion();
  const Matrix23& gx = landmark.gx;
  const std::size_t l = dim_;
  append_landmark(landmark.mean, gx, gx * diagonal_block<3>(0) * gx.transpose() + landmark.covariance);
  if (calibrates_ranges()) {
    // Placed from distances read through the calibration, d = (r - b) / (1 + s), the landmark moves
    // with it: dm/d(b, s) = gp = -(range_gain, range_scale_gain) / (1 + s). So P(m, :) gains
    // gp P(calibration, :), and its covariance gp's share of the calibration's covariance and of
    // the calibration's covariance with the vehicle.
    Eigen::Matrix2d gp;
    gp << landmark.range_gain, landmark.range_scale_gain;
    gp /= -(1.0 + x_[kScaleRow]);
    const auto li = static_cast<Eigen::Index>(l);
    const Matrix23 calibration_vehicle = p_.block<2, 3>(kOffsetRow, 0);
    const Matrix2 calibration = diagonal_block<2>(kOffsetRow);
    p_.block<2, 3>(li, 0) += gp * calibration_vehicle;
    p_.block<2, 2>(li, kOffsetRow) += gp * calibration;
    const Eigen::Index after = li - kScaleRow - 1;
    p_.block(li, kScaleRow + 1, 2, after) += gp * p_.block(kScaleRow + 1, kOffsetRow, after, 2).transpose();
    const Matrix2 through_vehicle = gx * calibration_vehicle.transpose() * gp.transpose();
    p_.block<2, 2>(li, li) += through_vehicle + through_vehicle.transpose() + gp * calibration * gp.transpose();
  }
  return num_landmarks() - 1;
}

void JointGaussian::append_landmark(const Vector2& mean, const Matrix23& gx, const Matrix2& covariance) {
  write_rows(dim_, mean, gx, covariance);
  append_landmark_rows(2);
  first_estimates_.push_back(mean);
  inverse_distance_.push_back(false);
}

void JointGaussian::write_rows(std::size_t at, const Vector2& mean, const Matrix23& gx, const Matrix2& covariance) {
  const auto l = static_cast<Eigen::Index>(at);
  x_.segment<2>(l) = mean;
  // The new rows inherit the vehicle's uncertainty, so they are correlated with everything the
  // vehicle is correlated with: P(m_new, :) = Gx P(v, :).
  p_.block<2, 3>(l, 0).noalias() = gx * diagonal_block<3>(0);
  if (l > 3) p_.block(l, 3, 2, l - 3).noalias() = gx * p_.block(3, 0, l - 3, 3).transpose();
  p_.block<2, 2>(l, l) = covariance;
}

bool JointGaussian::fuse_landmarks(std::span<const LandmarkPair> pairs) {
  if (pairs.empty()) return true;
  for (const LandmarkPair& pair : pairs)
    if (inverse_distance_[pair.original] || inverse_distance_[pair.duplicate])
      throw std::logic_error("a landmark at inverse distance is not fused: it is not yet a point");
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  const auto k = static_cast<Eigen::Index>(2 * pairs.size());
  // Two more columns of scratch beside W for the original's column block.
  reserve_joint_update(k + 2);
  auto pht = pht_.topLeftCorner(n, k);
  auto original_columns = pht_.middleCols<2>(k).topRows(n);
  const Matrix23 no_vehicle = Matrix23::Zero();
  // The measurement m_duplicate - m_original = 0: H has I at the duplicate and -I at the original,
  // so W = P H^T is the difference of their column blocks, and the innovation m_original - m_duplicate.
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto r = 2 * static_cast<Eigen::Index>(i);
    const std::size_t dup = landmark_offset(pairs[i].duplicate), orig = landmark_offset(pairs[i].original);
    covariance_times_jacobian<2>(dup, no_vehicle, Matrix2::Identity(), nullptr, -1, 0.0, pht.middleCols<2>(r));
    covariance_times_jacobian<2>(orig, no_vehicle, Matrix2::Identity(), nullptr, -1, 0.0, original_columns);
    pht.middleCols<2>(r) -= original_columns;
    batch_nu_.segment<2>(r) = x_.segment<2>(static_cast<Eigen::Index>(orig)) - x_.segment<2>(static_cast<Eigen::Index>(dup));
  }
  auto s = batch_s_.topLeftCorner(k, k);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto r = 2 * static_cast<Eigen::Index>(i);
    s.middleRows<2>(r) = pht.middleRows<2>(static_cast<Eigen::Index>(landmark_offset(pairs[i].duplicate))) -
                         pht.middleRows<2>(static_cast<Eigen::Index>(landmark_offset(pairs[i].original)));
  }
  return apply_joint_update(k);
}

void JointGaussian::remove_landmark(std::size_t index) {
  apply_pending_motion();
  remove_stored_landmark(index);
  first_estimates_.erase(first_estimates_.begin() + static_cast<std::ptrdiff_t>(index));
  if (inverse_distance_[index]) --inverse_distance_held_;
  inverse_distance_.erase(inverse_distance_.begin() + static_cast<std::ptrdiff_t>(index));
}

}  // namespace slamkit
