#include "slamkit/filters/ekf_slam.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>

#include "slamkit/core/angles.hpp"

namespace slamkit {

namespace {
constexpr std::size_t kInitialLandmarkCapacity = 64;

// Eigen's matrix-product kernels pack their operands into buffers that live on the stack up to
// EIGEN_STACK_ALLOCATION_LIMIT (128 KB) and come from the heap above it. A product over the whole
// covariance (a tall n x k operand) passes that limit once the map has a few hundred landmarks, so
// the two products that span it are cut into row tiles whose packed operands stay below it.
constexpr Eigen::Index kPackedBytes = 96 * 1024;
Eigen::Index tile_rows(Eigen::Index depth) {
  return std::clamp<Eigen::Index>(kPackedBytes / (static_cast<Eigen::Index>(sizeof(double)) * std::max<Eigen::Index>(depth, 1)),
                                  16, 512);
}

// The lower triangle of P -= C C^T, tile by tile: still one pass over P, each tile read and written
// once, with C's few columns re-read from cache.
void downdate_lower(Eigen::Ref<Eigen::MatrixXd> p, const Eigen::Ref<const Eigen::MatrixXd>& c) {
  const Eigen::Index n = p.rows();
  const Eigen::Index tile = tile_rows(c.cols());
  for (Eigen::Index j = 0; j < n; j += tile) {
    const Eigen::Index w = std::min(tile, n - j);
    p.block(j, j, w, w).selfadjointView<Eigen::Lower>().rankUpdate(c.middleRows(j, w), -1.0);
    for (Eigen::Index i = j + w; i < n; i += tile) {
      const Eigen::Index h = std::min(tile, n - i);
      p.block(i, j, h, w).noalias() -= c.middleRows(i, h) * c.middleRows(j, w).transpose();
    }
  }
}
}  // namespace

EkfSlam::EkfSlam(std::shared_ptr<const MotionModel> motion,
                 std::shared_ptr<const ObservationModel> observation, const EkfSlamOptions& options)
    : motion_(std::move(motion)),
      observation_(std::move(observation)),
      association_((validate(options.association), options.association)),
      gates_(Gates::from(options.association)),
      gate_known_(options.association.gate_known.value_or(true)),
      sensor_((validate(options.sensor), options.sensor)),
      association_view_(association_view(options.sensor, options.association)),
      existence_rule_(options.association, options.sensor),
      // Cells of a third of the sensor range: a query touches a few dozen cells at most.
      grid_(std::max(5.0, options.sensor.max_range / 3.0)),
      variant_(options.variant),
      joint_scan_update_(options.joint_scan_update),
      area_half_side_(0.5 * (options.local_area_side > 0.0 ? options.local_area_side
                                                           : 2.0 * options.sensor.max_range)) {
  if (!motion_ || !observation_) throw std::invalid_argument("EkfSlam needs a motion and an observation model");
  reserve(3 + 2 * kInitialLandmarkCapacity);
  x_.head<3>() = options.initial_pose;
  x_[2] = wrap_angle(x_[2]);
  p_.topLeftCorner<3, 3>() = options.initial_covariance;
}

void EkfSlam::reserve(std::size_t dim) {
  const auto capacity = static_cast<std::size_t>(x_.size());
  if (dim <= capacity) return;
  // Growing by a quarter, not by doubling: the square buffer is what EKF-SLAM's memory is, and
  // doubling left it up to 4x the covariance (2.25 GB at 5,000 landmarks); a quarter bounds it at
  // 1.56x while the copies, O(capacity^2) each, still amortise to O(1) per landmark added.
  const auto grown = static_cast<Eigen::Index>(std::max(dim, capacity + capacity / 4));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(grown);
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(grown, grown);
  const auto n = static_cast<Eigen::Index>(dim_);
  if (capacity > 0) {
    x.head(n) = x_.head(n);
    p.topLeftCorner(n, n).triangularView<Eigen::Lower>() = p_.topLeftCorner(n, n);
  }
  x_.swap(x);
  p_.swap(p);
  scratch3_.resize(grown, 3);
  pht_.resize(grown, std::max<Eigen::Index>(2, pht_.cols()));
}

template <int N>
Eigen::Matrix<double, N, N> EkfSlam::diagonal_block(std::size_t offset) const {
  const auto o = static_cast<Eigen::Index>(offset);
  return p_.block<N, N>(o, o).template selfadjointView<Eigen::Lower>();
}

// In an open local area (compressed variant) the accessors answer from the local state for active
// landmarks and apply the accumulated update on the fly for the others: O(dim(A0)^2) at most.

template <typename Derived>
Eigen::Matrix<double, Derived::RowsAtCompileTime, 2> EkfSlam::times_start_cross_t(const Eigen::MatrixBase<Derived>& m,
                                                                                  std::size_t index) const {
  using Result = Eigen::Matrix<double, Derived::RowsAtCompileTime, 2>;
  Result out = Result::Zero();
  for (Eigen::Index c = 0; c < a0_; ++c) out.noalias() += m.col(c) * start_cross(index, c).transpose();
  return out;
}

Matrix2 EkfSlam::start_cross_quadratic(std::size_t i, std::size_t j) const {
  Matrix2 out = Matrix2::Zero();
  for (Eigen::Index c = 0; c < a0_; ++c) out.noalias() += start_cross(i, c) * times_start_cross_t(psi().row(c), j);
  return out;
}

Matrix3 EkfSlam::pose_covariance() const {
  return in_area() ? Matrix3(pa_.topLeftCorner<3, 3>()) : diagonal_block<3>(0);
}

Vector2 EkfSlam::landmark_position(std::size_t index) const {
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  if (!in_area() || local_offset(index) >= 0) return x_.segment<2>(l);
  return x_.segment<2>(l) + times_start_cross_t(theta().transpose(), index).transpose();
}

Matrix2 EkfSlam::landmark_covariance(std::size_t index) const {
  if (!in_area()) return diagonal_block<2>(landmark_offset(index));
  if (const long a = local_offset(index); a >= 0) return pa_.block<2, 2>(a, a);
  return diagonal_block<2>(landmark_offset(index)) - start_cross_quadratic(index, index);
}

Matrix2 EkfSlam::landmark_cross_covariance(std::size_t i, std::size_t j) const {
  if (i == j) return landmark_covariance(i);
  const auto a = static_cast<Eigen::Index>(landmark_offset(i));
  const auto b = static_cast<Eigen::Index>(landmark_offset(j));
  // Only the lower triangle is stored: the block with the larger row offset holds the pair.
  const Matrix2 stored = a > b ? Matrix2(p_.block<2, 2>(a, b)) : Matrix2(p_.block<2, 2>(b, a).transpose());
  if (!in_area()) return stored;
  const long li = local_offset(i), lj = local_offset(j);
  if (li >= 0 && lj >= 0) return pa_.block<2, 2>(li, lj);
  if (li >= 0) return times_start_cross_t(phi().middleRows<2>(li), j);  // P(A,B) = phi P_AB(0)
  if (lj >= 0) return times_start_cross_t(phi().middleRows<2>(lj), i).transpose();
  return stored - start_cross_quadratic(i, j);
}

Eigen::VectorXd EkfSlam::state() const {
  Eigen::VectorXd x = x_.head(static_cast<Eigen::Index>(dim_));
  if (in_area())
    for (std::size_t i = 0; i < ids_.size(); ++i)
      if (local_offset(i) < 0) x.segment<2>(static_cast<Eigen::Index>(landmark_offset(i))) = landmark_position(i);
  return x;
}

Eigen::MatrixXd EkfSlam::covariance() const {
  const auto n = static_cast<Eigen::Index>(dim_);
  Eigen::MatrixXd lower = p_.topLeftCorner(n, n);
  if (in_area()) {
    Eigen::VectorXd x = x_.head(n);
    MergeWorkspace ws;
    merge_area(x, lower, ws);
  }
  Eigen::MatrixXd full = lower.selfadjointView<Eigen::Lower>();
  full.block(3, 0, n - 3, 3) = full.block(3, 0, n - 3, 3) * pending_motion_.transpose();
  full.block(0, 3, 3, n - 3) = full.block(3, 0, n - 3, 3).transpose();
  return full;
}

Matrix23 EkfSlam::landmark_pose_covariance(std::size_t index) const {
  if (!in_area())
    return p_.block<2, 3>(static_cast<Eigen::Index>(landmark_offset(index)), 0) * pending_motion_.transpose();
  if (const long a = local_offset(index); a >= 0) return pa_.block<2, 3>(a, 0);
  return times_start_cross_t(phi().topRows<3>(), index).transpose();
}

void EkfSlam::apply_pending_motion() {
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

std::vector<Landmark> EkfSlam::landmarks() const {
  std::vector<Landmark> out;
  out.reserve(ids_.size());
  for (std::size_t i = 0; i < ids_.size(); ++i)
    if (existence_rule_.confirmed(existence_[i])) out.push_back(Landmark{ids_[i], landmark_position(i), landmark_covariance(i)});
  return out;
}

std::map<std::string, double> EkfSlam::statistics() const {
  std::map<std::string, double> s = {{"discarded_observations", static_cast<double>(discarded_)},
                                     {"landmarks_removed", static_cast<double>(removed_)},
                                     {"landmarks_in_state", static_cast<double>(ids_.size())}};
  if (compressed()) s["local_area_flushes"] = static_cast<double>(flushes_);
  if (association_.method == AssociationMethod::kKnown && gate_known_)
    s["outliers_rejected"] = static_cast<double>(outliers_);
  if (association_.method != AssociationMethod::kKnown)
    s["association_pairs_evaluated"] = static_cast<double>(association_stats_.candidate_pairs);
  if (association_.method == AssociationMethod::kJcbb) {
    s["jcbb_nodes"] = static_cast<double>(association_stats_.jcbb_nodes);
    s["jcbb_budget_exhausted"] = association_stats_.jcbb_budget_exhausted ? 1.0 : 0.0;
  }
  return s;
}

long EkfSlam::find_landmark(int id) const {
  const auto it = index_of_id_.find(id);
  return it == index_of_id_.end() ? -1 : static_cast<long>(it->second);
}

void EkfSlam::predict(const ControlEvent& control) { predict(control.u, control.dt); }

void EkfSlam::predict(const Control& u, double dt) {
  const Pose2 xv = x_.head<3>();
  const Matrix3 f = motion_->jacobian_state(xv, u, dt);
  const Matrix3 q = motion_->process_noise(xv, u, dt);
  x_.head<3>() = motion_->predict(xv, u, dt);
  if (compressed()) {
    if (!in_area()) begin_area();
    predict_local(f, q);
    return;
  }
  p_.topLeftCorner<3, 3>() = f * diagonal_block<3>(0) * f.transpose() + q;
  // Landmarks are static: only the map-vehicle cross-covariance P_mv changes, to P_mv F^T. The Fs of
  // the controls between two scans are multiplied together and applied to P_mv once, when it is
  // next needed: the same product, O(1) per control instead of O(n).
  pending_motion_ = f * pending_motion_;
}

void EkfSlam::covariance_times_jacobian(std::size_t lm_offset, const Matrix23& hx, const Matrix2& hm,
                                        Eigen::Ref<Eigen::MatrixX2d> out) const {
  const auto n = static_cast<Eigen::Index>(dim_);
  const auto l = static_cast<Eigen::Index>(lm_offset);
  // H = [hx 0 .. 0 hm 0 .. 0], so P H^T = P(:, vehicle) hx^T + P(:, landmark) hm^T, each column block
  // read from the lower triangle: rows above a block come from the transposed row block.
  out.topRows<3>().noalias() = diagonal_block<3>(0) * hx.transpose();
  out.bottomRows(n - 3).noalias() = p_.block(3, 0, n - 3, 3) * hx.transpose();
  out.topRows(l).noalias() += p_.block(l, 0, 2, l).transpose() * hm.transpose();
  out.middleRows<2>(l).noalias() += diagonal_block<2>(lm_offset) * hm.transpose();
  out.bottomRows(n - l - 2).noalias() += p_.block(l + 2, l, n - l - 2, 2) * hm.transpose();
}

void EkfSlam::innovation(std::size_t index, Vector2& zhat, Matrix2& s) const {
  const std::size_t l = landmark_offset(index);
  const Pose2 xv = x_.head<3>();
  const Vector2 m = x_.segment<2>(static_cast<Eigen::Index>(l));
  Matrix23 hx;
  Matrix2 hm;
  observation_->jacobians(xv, m, hx, hm);
  zhat = observation_->predict(xv, m);
  // S = hx Pvv hx^T + hx Pvm hm^T + hm Pmv hx^T + hm Pmm hm^T + R: only the 5x5 block is needed.
  const Matrix23 pvm_t = landmark_pose_covariance(index);  // P(m, v)
  const Matrix2 cross = hm * pvm_t * hx.transpose();
  s = hx * pose_covariance() * hx.transpose() + cross + cross.transpose() +
      hm * landmark_covariance(index) * hm.transpose() + observation_->noise();
}

bool EkfSlam::update_landmark(std::size_t index, const Vector2& z) {
  if (compressed()) {
    activate(index);
    return update_local(index, z);
  }
  apply_pending_motion();
  const std::size_t l = landmark_offset(index);
  const auto li = static_cast<Eigen::Index>(l);
  const auto n = static_cast<Eigen::Index>(dim_);
  const Pose2 xv = x_.head<3>();
  const Vector2 m = x_.segment<2>(li);
  Matrix23 hx;
  Matrix2 hm;
  observation_->jacobians(xv, m, hx, hm);
  const Vector2 nu = observation_->residual(z, observation_->predict(xv, m));

  auto pht = pht_.leftCols<2>().topRows(n);  // two columns known at compile time: 2x2 products stay fixed-size
  covariance_times_jacobian(l, hx, hm, pht);
  Matrix2 s = hx * pht.topRows<3>() + hm * pht.middleRows<2>(li) + observation_->noise();
  s(0, 1) = s(1, 0) = 0.5 * (s(0, 1) + s(1, 0));
  const Eigen::LLT<Matrix2> llt(s);
  if (llt.info() != Eigen::Success) return false;

  // Eq. (10): x += W nu with W = P H^T S^-1.
  x_.head(n).noalias() += pht * llt.solve(nu);
  x_[2] = wrap_angle(x_[2]);

  // Eq. (11): P -= W S W^T = C C^T with C = P H^T L^-T (S = L L^T). L^-T is upper triangular, so C
  // is formed in place, column 1 first because it still needs the old column 0.
  const Matrix2 lower = llt.matrixL();
  const double a00 = 1.0 / lower(0, 0), a11 = 1.0 / lower(1, 1);
  const double a01 = -lower(1, 0) * a00 * a11;
  auto c0 = pht.col(0);
  auto c1 = pht.col(1);
  c1 = a01 * c0 + a11 * c1;
  c0 *= a00;
  downdate_lower(p_.topLeftCorner(n, n), pht);
  return true;
}

bool EkfSlam::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.size() == 1) return update_landmark(batch[0].index, batch[0].z);
  if (compressed()) {
    bool all = true;
    for (const LandmarkObservation& o : batch) all = update_landmark(o.index, o.z) && all;
    return all;
  }
  if (batch.empty()) return true;
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  const auto k = static_cast<Eigen::Index>(2 * batch.size());
  const Pose2 xv = x_.head<3>();
  if (pht_.cols() < k) pht_.resize(pht_.rows(), std::max(k, 2 * pht_.cols()));
  if (batch_s_.rows() < k) {
    batch_s_.resize(pht_.cols(), pht_.cols());
    batch_nu_.resize(pht_.cols());
  }
  batch_hx_.resize(batch.size());
  batch_hm_.resize(batch.size());
  // W = P H^T, two columns per observation, each pair from the two column blocks its row of H touches.
  auto pht = pht_.topLeftCorner(n, k);
  auto nu = batch_nu_.head(k);
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const auto l = landmark_offset(batch[i].index);
    const auto r = 2 * static_cast<Eigen::Index>(i);
    const Vector2 m = x_.segment<2>(static_cast<Eigen::Index>(l));
    observation_->jacobians(xv, m, batch_hx_[i], batch_hm_[i]);
    nu.segment<2>(r) = observation_->residual(batch[i].z, observation_->predict(xv, m));
    covariance_times_jacobian(l, batch_hx_[i], batch_hm_[i], pht.middleCols<2>(r));
  }
  // S = H P H^T + R, block (i, j) = H_i (P H_j^T).
  auto s = batch_s_.topLeftCorner(k, k);
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const auto l = static_cast<Eigen::Index>(landmark_offset(batch[i].index));
    const auto r = 2 * static_cast<Eigen::Index>(i);
    s.middleRows<2>(r).noalias() = batch_hx_[i] * pht.topRows<3>() + batch_hm_[i] * pht.middleRows<2>(l);
    s.block<2, 2>(r, r) += observation_->noise();
  }
  // The factorisation reads the lower triangle only, so symmetrising it is enough; in place, as an
  // LLT of a Ref, so that it needs no storage of its own.
  s.triangularView<Eigen::StrictlyLower>() = 0.5 * (s + s.transpose());
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(s);
  if (llt.info() != Eigen::Success) return false;
  llt.solveInPlace(nu);
  x_.head(n).noalias() += pht * nu;
  x_[2] = wrap_angle(x_[2]);
  // P -= W S^-1 W^T = C C^T with C = W L^-T: one pass over the lower triangle for the scan.
  // Row by row independent (C L^T = W), so solved in row tiles for the same reason as the downdate.
  for (Eigen::Index r = 0, tile = tile_rows(k); r < n; r += tile)
    llt.matrixU().solveInPlace<Eigen::OnTheRight>(pht.middleRows(r, std::min(tile, n - r)));
  downdate_lower(p_.topLeftCorner(n, n), pht);
  return true;
}

std::size_t EkfSlam::add_landmark(const Vector2& z, int id) {
  reserve(dim_ + 2);
  if (compressed() && !in_area()) begin_area();
  apply_pending_motion();
  const auto l = static_cast<Eigen::Index>(dim_);
  const Pose2 xv = x_.head<3>();
  Matrix23 gx;
  Matrix2 gz;
  observation_->inverse_jacobians(xv, z, gx, gz);
  x_.segment<2>(l) = observation_->inverse(xv, z);
  const Matrix2 added = gz * observation_->noise() * gz.transpose();
  if (compressed()) {
    add_local(gx, added);
  } else {
    // The new landmark inherits the vehicle's uncertainty, so it is correlated with everything the
    // vehicle is correlated with: P(m_new, :) = Gx P(v, :).
    const Matrix3 pvv = diagonal_block<3>(0);
    p_.block<2, 3>(l, 0).noalias() = gx * pvv;
    if (l > 3) p_.block(l, 3, 2, l - 3).noalias() = gx * p_.block(3, 0, l - 3, 3).transpose();
    p_.block<2, 2>(l, l).noalias() = gx * pvv * gx.transpose() + added;
  }
  dim_ += 2;
  return register_landmark(id);
}

std::size_t EkfSlam::register_landmark(int id) {
  const std::size_t index = ids_.size();
  ids_.push_back(id);
  if (id != kUnknownId) index_of_id_[id] = index;
  existence_.push_back(association_.method == AssociationMethod::kKnown ? existence_rule_.given()
                                                                      : existence_rule_.first_observed());
  binned_.push_back(grid_.cell_of(landmark_position(index)));
  grid_.insert(binned_.back(), static_cast<std::uint32_t>(index));
  return index;
}

void EkfSlam::remove_landmark(std::size_t index) {
  // Removal renumbers the state; the area's bookkeeping is by stored offset, so it is closed first.
  flush_local_area();
  apply_pending_motion();
  const std::size_t n = dim_, l = landmark_offset(index);
  std::copy(x_.data() + l + 2, x_.data() + n, x_.data() + l);
  // Close the gap in the lower triangle column by column. Columns left of the landmark shift their
  // rows below it up by two, in place; columns right of it come from two columns further right.
  const auto stride = static_cast<std::size_t>(p_.rows());
  double* base = p_.data();
  for (std::size_t c = 0; c + 2 < n; ++c) {
    double* dst = base + c * stride;
    if (c < l) {
      std::copy(dst + l + 2, dst + n, dst + l);
    } else {
      const double* src = base + (c + 2) * stride;
      std::copy(src + c + 2, src + n, dst + c);
    }
  }
  dim_ -= 2;
  const int id = ids_[index];
  ids_.erase(ids_.begin() + static_cast<std::ptrdiff_t>(index));
  existence_.erase(existence_.begin() + static_cast<std::ptrdiff_t>(index));
  if (id != kUnknownId) index_of_id_.erase(id);
  for (auto& [key, i] : index_of_id_)
    if (i > index) --i;
  rebuild_grid();
}

void EkfSlam::rebuild_grid() {
  grid_.clear();
  binned_.resize(ids_.size());
  for (std::size_t i = 0; i < ids_.size(); ++i) {
    binned_[i] = grid_.cell_of(landmark_position(i));
    grid_.insert(binned_[i], static_cast<std::uint32_t>(i));
  }
}

void EkfSlam::rebin(std::size_t index) {
  const LandmarkGrid::Cell cell = grid_.cell_of(landmark_position(index));
  if (cell == binned_[index]) return;
  grid_.erase(binned_[index], static_cast<std::uint32_t>(index));
  grid_.insert(cell, static_cast<std::uint32_t>(index));
  binned_[index] = cell;
}

void EkfSlam::update(const ScanEvent& scan) {
  last_associations_.assign(scan.observations.size(), AssociationRecord{});
  if (in_area() && (x_.head<2>() - area_centre_).lpNorm<Eigen::Infinity>() > area_half_side_) flush_local_area();
  if (association_.method == AssociationMethod::kKnown)
    update_known(scan);
  else
    update_unknown(scan);
}

void EkfSlam::update_known(const ScanEvent& scan) {
  new_observations_.clear();
  auto apply = [&](std::size_t k, std::size_t index) {
    if (gate_known_) {
      Vector2 zhat;
      Matrix2 s;
      innovation(index, zhat, s);
      const Vector2 nu = observation_->residual(scan.observations[k].z, zhat);
      if (nu.dot(s.ldlt().solve(nu)) > gates_.new_landmark) {
        ++outliers_;
        ++discarded_;
        return;
      }
    }
    if (joint_scan_update_) {
      batch_.push_back({index, scan.observations[k].z});
      last_associations_[k] = {AssociationDecision::kUpdate, ids_[index]};
      existence_rule_.observed(existence_[index]);
    } else if (update_landmark(index, scan.observations[k].z)) {
      last_associations_[k] = {AssociationDecision::kUpdate, ids_[index]};
      existence_rule_.observed(existence_[index]);
    } else {
      ++discarded_;
    }
  };
  batch_.clear();
  for (std::size_t k = 0; k < scan.observations.size(); ++k) {
    const Observation& obs = scan.observations[k];
    if (obs.id == kUnknownId) {
      ++discarded_;  // a detection without identity (e.g. clutter) cannot be placed by its id
      continue;
    }
    const long index = find_landmark(obs.id);
    if (index >= 0)
      apply(k, static_cast<std::size_t>(index));
    else
      new_observations_.push_back(k);
  }
  apply_joint_batch();
  // New landmarks are added after the scan's updates, so they start from the best pose estimate.
  for (const std::size_t k : new_observations_) {
    const Observation& obs = scan.observations[k];
    const long index = find_landmark(obs.id);
    if (index >= 0) {
      apply(k, static_cast<std::size_t>(index));  // seen twice in one scan
    } else {
      add_landmark(obs.z, obs.id);
      last_associations_[k] = {AssociationDecision::kNew, obs.id};
    }
  }
  apply_joint_batch();
}

void EkfSlam::apply_joint_batch() {
  if (batch_.empty()) return;
  // A joint innovation covariance that is not positive definite: fall back to one at a time.
  if (!update_landmarks(batch_))
    for (const LandmarkObservation& o : batch_) update_landmark(o.index, o.z);
  batch_.clear();
}

void EkfSlam::find_candidates(const SensorView& view) {
  candidates_.clear();
  if (ids_.empty()) return;
  // The grid bins landmarks where they were last re-binned; one extra cell covers the drift since.
  grid_.query(x_.head<2>(), view.reach() + grid_.cell_size(), nearby_);
  const Pose2 xv = pose();
  for (const std::uint32_t j : nearby_)
    if (view.contains(observation_->predict(xv, landmark_position(j)))) candidates_.push_back(j);
}

const std::vector<Pairing>& EkfSlam::associate_scan(const ScanEvent& scan) {
  find_candidates(association_view_);
  associate(scan.observations, candidates_, *this, *observation_, association_, association_workspace_, pairings_,
            &association_stats_);
  return pairings_;
}

void EkfSlam::update_unknown(const ScanEvent& scan) {
  const std::vector<Pairing>& pairings = associate_scan(scan);

  const Vector2 position_before = x_.head<2>();
  seen_.assign(ids_.size(), false);
  batch_.clear();
  for (std::size_t k = 0; k < pairings.size(); ++k) {
    if (pairings[k].decision != AssociationDecision::kUpdate) continue;
    const std::size_t index = pairings[k].landmark;
    if (joint_scan_update_)
      batch_.push_back({index, scan.observations[k].z});
    else if (!update_landmark(index, scan.observations[k].z))
      continue;
    last_associations_[k] = {AssociationDecision::kUpdate, ids_[index]};
    seen_[index] = true;
    existence_rule_.observed(existence_[index]);
  }
  apply_joint_batch();
  for (std::size_t k = 0; k < pairings.size(); ++k) {
    if (pairings[k].decision == AssociationDecision::kNew) {
      const int id = next_id_++;
      add_landmark(scan.observations[k].z, id);
      last_associations_[k] = {AssociationDecision::kNew, id};
    } else if (last_associations_[k].decision == AssociationDecision::kDiscard) {
      ++discarded_;
    }
  }

  // Keep the grid honest: the landmarks just updated moved the most; a large vehicle correction
  // (a loop closure) moved the whole map, so then the grid is rebuilt.
  for (const std::size_t j : candidates_) rebin(j);
  drift_since_rebuild_ += (x_.head<2>() - position_before).norm();
  if (drift_since_rebuild_ > 0.5 * grid_.cell_size()) {
    rebuild_grid();
    drift_since_rebuild_ = 0.0;
  }
  manage_map();
}

void EkfSlam::manage_map() {
  find_candidates(existence_rule_.detection_view());
  doomed_.clear();
  for (const std::size_t j : candidates_) {
    if (j >= seen_.size() || seen_[j]) continue;  // added this scan, or seen
    if (existence_rule_.missed(existence_[j])) doomed_.push_back(j);
  }
  // Highest index first, so the indices still to remove stay valid.
  for (auto it = doomed_.rbegin(); it != doomed_.rend(); ++it) {
    remove_landmark(*it);
    ++removed_;
  }
}

// ---- Compressed variant (Guivant and Nebot 2001) ----
//
// Partition the state into A (vehicle + active landmarks) and B (the rest). While every operation
// involves A only, B's blocks follow from their values when the area began (index 0):
//
//   time update, F_A = diag(F, I):   P_AA <- F_A P_AA F_A^T + Q_A,  P_BA <- P_BA F_A^T
//   observation, H = [H_A 0]:        S = H_A P_AA H_A^T + R,  W_A = P_AA H_A^T S^-1
//                                    P_BA <- P_BA (I - W_A H_A)^T
//                                    P_BB <- P_BB - P_BA H_A^T S^-1 H_A P_AB
//                                    x_B  <- x_B + P_BA H_A^T S^-1 nu
//   new landmark m = g(x_v, z):      P_{B,m} = P_Bv Gx^T
//
// Every step multiplies P_BA on the right, so P_BA = P_BA(0) phi^T with phi <- F_A phi,
// phi <- (I - W_A H_A) phi, and for a new landmark phi gains the rows Gx phi_v. Substituting into the
// other two: P_BB = P_BB(0) - P_BA(0) psi P_AB(0) with psi += (H_A phi)^T S^-1 (H_A phi), and
// x_B = x_B(0) + P_BA(0) theta with theta += (H_A phi)^T S^-1 nu. phi is dim(A) x dim(A0), psi and
// theta dim(A0): a step costs O(dim(A)^2) whatever the map's size. Applying them to B (a flush) is
// O(n_B^2 dim(A0)), once per area. A and A0 differ only by the landmarks added in the area, which
// come last in the local order.

long EkfSlam::local_offset(std::size_t index) const { return in_area() ? local_of_[index] : -1; }

void EkfSlam::reserve_area(Eigen::Index d) {
  if (d <= pa_.rows()) return;
  // Doubling, like the stored state: an area larger than every one before is rare once the map is
  // built. The open area's part of each buffer is kept.
  const Eigen::Index capacity = std::max(d, 2 * pa_.rows());
  auto grow = [&](Eigen::MatrixXd& m, Eigen::Index rows, Eigen::Index cols) {
    Eigen::MatrixXd grown(capacity, capacity);
    grown.topLeftCorner(rows, cols) = m.topLeftCorner(rows, cols);
    m.swap(grown);
  };
  grow(pa_, d_, d_);
  grow(phi_, d_, a0_);
  grow(psi_, a0_, a0_);
  Eigen::VectorXd theta(capacity);
  theta.head(a0_) = theta_.head(a0_);
  theta_.swap(theta);
  h_phi_.resize(2, capacity);
}

void EkfSlam::begin_area(long must_include) {
  area_centre_ = x_.head<2>();
  // Every landmark the vehicle can see from inside the square is active, so observations made
  // before it leaves the square involve A only.
  const double reach = area_half_side_ + sensor_.max_range;
  area_offsets_ = {0, 1, 2};
  local_of_.assign(ids_.size(), -1);
  for (std::size_t i = 0; i < ids_.size(); ++i) {
    const std::size_t l = landmark_offset(i);
    const Vector2 offset = x_.segment<2>(static_cast<Eigen::Index>(l)) - area_centre_;
    const bool near = offset.lpNorm<Eigen::Infinity>() <= reach;
    if (!near && static_cast<long>(i) != must_include) continue;
    local_of_[i] = static_cast<long>(area_offsets_.size());
    area_offsets_.push_back(l);
    area_offsets_.push_back(l + 1);
  }
  const auto a0 = static_cast<Eigen::Index>(area_offsets_.size());
  reserve_area(a0);
  a0_ = d_ = a0;
  auto pa = this->pa();
  for (std::size_t c = 0; c < area_offsets_.size(); ++c)
    for (std::size_t r = c; r < area_offsets_.size(); ++r) {
      const auto i = static_cast<Eigen::Index>(r), j = static_cast<Eigen::Index>(c);
      pa(i, j) = pa(j, i) = stored_entry(area_offsets_[r], area_offsets_[c]);
    }
  phi().setIdentity();
  psi().setZero();
  theta().setZero();
}

void EkfSlam::activate(std::size_t index) {
  if (local_offset(index) >= 0) return;
  flush_local_area();
  begin_area(static_cast<long>(index));
}

void EkfSlam::flush_local_area() {
  if (!in_area()) return;
  const auto n = static_cast<Eigen::Index>(dim_);
  merge_area(x_.head(n), p_.topLeftCorner(n, n), merge_);
  area_offsets_.clear();
  local_of_.clear();
  ++flushes_;
}

void EkfSlam::predict_local(const Matrix3& f, const Matrix3& q) {
  auto pa = this->pa();
  const Eigen::Index rest = d_ - 3;
  const Matrix3 pvv = f * pa.topLeftCorner<3, 3>() * f.transpose() + q;
  // P_Av <- P_Av F^T and phi_v <- F phi_v through scratch3_ (at least dim_ x 3), as products that
  // overwrite their own operand would go through a temporary.
  auto pav = scratch3_.topRows(rest);
  pav.noalias() = pa.bottomLeftCorner(rest, 3) * f.transpose();
  pa.bottomLeftCorner(rest, 3) = pav;
  pa.topRightCorner(3, rest) = pav.transpose();
  pa.topLeftCorner<3, 3>() = pvv;
  auto phi_v = scratch3_.topRows(a0_);
  phi_v.noalias() = phi().topRows<3>().transpose() * f.transpose();
  phi().topRows<3>() = phi_v.transpose();
}

bool EkfSlam::update_local(std::size_t index, const Vector2& z) {
  const auto l = static_cast<Eigen::Index>(local_of_[index]);
  const Eigen::Index d = d_;
  auto pa = this->pa();
  auto phi = this->phi();
  const Pose2 xv = x_.head<3>();
  const Vector2 m = x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(index)));
  Matrix23 hx;
  Matrix2 hm;
  observation_->jacobians(xv, m, hx, hm);
  const Vector2 nu = observation_->residual(z, observation_->predict(xv, m));

  auto pht = pht_.leftCols<2>().topRows(d);
  pht.noalias() = pa.leftCols<3>() * hx.transpose();
  pht.noalias() += pa.middleCols<2>(l) * hm.transpose();
  Matrix2 s = hx * pht.topRows<3>() + hm * pht.middleRows<2>(l) + observation_->noise();
  s(0, 1) = s(1, 0) = 0.5 * (s(0, 1) + s(1, 0));
  const Eigen::LLT<Matrix2> llt(s);
  if (llt.info() != Eigen::Success) return false;

  const Vector2 s_inv_nu = llt.solve(nu);
  for (Eigen::Index r = 0; r < d; ++r) x_[static_cast<Eigen::Index>(area_offsets_[r])] += pht.row(r).dot(s_inv_nu);
  x_[2] = wrap_angle(x_[2]);

  // With g = L^-1 H_A phi (S = L L^T): theta += (H_A phi)^T S^-1 nu, psi += g^T g and
  // phi -= W_A H_A phi = P H^T L^-T g, all through one 2 x dim(A0) buffer.
  auto h_phi = h_phi_.leftCols(a0_);
  h_phi.noalias() = hx * phi.topRows<3>();
  h_phi.noalias() += hm * phi.middleRows<2>(l);
  theta().noalias() += h_phi.transpose() * s_inv_nu;
  llt.matrixL().solveInPlace(h_phi);
  psi().noalias() += h_phi.transpose() * h_phi;
  llt.matrixU().solveInPlace(h_phi);
  phi.noalias() -= pht * h_phi;

  llt.matrixL().solveInPlace(pht.transpose());  // now C = P H^T L^-T
  pa.noalias() -= pht * pht.transpose();         // W_A S W_A^T = C C^T
  return true;
}

void EkfSlam::add_local(const Matrix23& gx, const Matrix2& pnew) {
  const Eigen::Index d = d_;
  const std::size_t l = dim_;
  reserve_area(d + 2);
  d_ = d + 2;
  auto pa = this->pa();
  pa.bottomLeftCorner(2, d).noalias() = gx * pa.topLeftCorner(3, d);
  pa.topRightCorner(d, 2) = pa.bottomLeftCorner(2, d).transpose();
  pa.bottomRightCorner<2, 2>().noalias() = gx * pa.block<3, 2>(0, d) + pnew;
  phi().bottomRows<2>().noalias() = gx * phi().topRows<3>();
  local_of_.push_back(static_cast<long>(d));
  area_offsets_.push_back(l);
  area_offsets_.push_back(l + 1);
}

void EkfSlam::merge_area(Eigen::Ref<Eigen::VectorXd> x, Eigen::Ref<Eigen::MatrixXd> p, MergeWorkspace& ws) const {
  const Eigen::Index n = x.size(), d = d_;
  ws.active.assign(dim_, 0);
  for (const std::size_t a : area_offsets_) ws.active[a] = 1;
  ws.outside.clear();
  for (std::size_t i = 0; i < dim_; ++i)
    if (!ws.active[i]) ws.outside.push_back(i);
  const auto n_b = static_cast<Eigen::Index>(ws.outside.size());
  auto fit = [](Eigen::MatrixXd& m, Eigen::Index rows, Eigen::Index cols) {
    if (m.rows() < rows || m.cols() < cols) m.resize(std::max(rows, m.rows()), std::max(cols, m.cols()));
    return m.topLeftCorner(rows, cols);
  };
  auto u_b = fit(ws.u_b, n_b, a0_);
  for (Eigen::Index c = 0; c < a0_; ++c) {
    const std::size_t a = area_offsets_[static_cast<std::size_t>(c)];
    for (Eigen::Index r = 0; r < n_b; ++r) u_b(r, c) = stored_entry(ws.outside[static_cast<std::size_t>(r)], a);
  }
  // P_BA(0) spread over all n rows, zero in A's: the P_BB downdate is then one triangular product
  // on the stored layout, leaving A's rows untouched.
  auto u = fit(ws.u, n, a0_);
  u.setZero();
  for (Eigen::Index r = 0; r < n_b; ++r)
    u.row(static_cast<Eigen::Index>(ws.outside[static_cast<std::size_t>(r)])) = u_b.row(r);

  x.noalias() += u * theta();
  auto psi_ut = fit(ws.psi_ut, a0_, n);
  psi_ut.noalias() = psi() * u.transpose();
  p.triangularView<Eigen::Lower>() -= u * psi_ut;
  auto p_ba = fit(ws.p_ba, n_b, d);
  p_ba.noalias() = u_b * phi().transpose();
  auto pa = this->pa();
  for (Eigen::Index c = 0; c < d; ++c) {
    const auto a = static_cast<Eigen::Index>(area_offsets_[c]);
    for (Eigen::Index r = 0; r < n_b; ++r) {
      const auto b = static_cast<Eigen::Index>(ws.outside[static_cast<std::size_t>(r)]);
      (b > a ? p(b, a) : p(a, b)) = p_ba(r, c);
    }
    for (Eigen::Index r = 0; r < d; ++r) {
      const auto b = static_cast<Eigen::Index>(area_offsets_[r]);
      if (b >= a) p(b, a) = pa(r, c);
    }
  }
}

}  // namespace slamkit
