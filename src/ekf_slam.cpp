#include "slamkit/filters/ekf_slam.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>

#include "slamkit/angles.hpp"

namespace slamkit {

namespace {
constexpr std::size_t kInitialLandmarkCapacity = 64;

bool full_circle(const SensorLimits& sensor) { return sensor.fov >= 2.0 * kPi - 1e-9; }
}  // namespace

EkfSlam::EkfSlam(std::shared_ptr<const MotionModel> motion,
                 std::shared_ptr<const ObservationModel> observation, const EkfSlamOptions& options)
    : motion_(std::move(motion)),
      observation_(std::move(observation)),
      association_(options.association),
      gates_(Gates::from(options.association)),
      sensor_(options.sensor),
      // Cells of a third of the sensor range: a query touches a few dozen cells at most.
      grid_(std::max(5.0, options.sensor.max_range / 3.0)) {
  if (!motion_ || !observation_) throw std::invalid_argument("EkfSlam needs a motion and an observation model");
  reserve(3 + 2 * kInitialLandmarkCapacity);
  x_.head<3>() = options.initial_pose;
  x_[2] = wrap_angle(x_[2]);
  p_.topLeftCorner<3, 3>() = options.initial_covariance;
}

void EkfSlam::reserve(std::size_t dim) {
  const auto capacity = static_cast<std::size_t>(x_.size());
  if (dim <= capacity) return;
  const auto grown = static_cast<Eigen::Index>(std::max(dim, 2 * capacity));
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
  pht_.resize(grown, 2);
}

template <int N>
Eigen::Matrix<double, N, N> EkfSlam::diagonal_block(std::size_t offset) const {
  const auto o = static_cast<Eigen::Index>(offset);
  return p_.block<N, N>(o, o).template selfadjointView<Eigen::Lower>();
}

Matrix3 EkfSlam::pose_covariance() const { return diagonal_block<3>(0); }

Matrix2 EkfSlam::landmark_covariance(std::size_t index) const {
  return diagonal_block<2>(landmark_offset(index));
}

Matrix2 EkfSlam::landmark_cross_covariance(std::size_t i, std::size_t j) const {
  if (i == j) return landmark_covariance(i);
  const auto a = static_cast<Eigen::Index>(landmark_offset(i));
  const auto b = static_cast<Eigen::Index>(landmark_offset(j));
  // Only the lower triangle is stored: the block with the larger row offset holds the pair.
  return a > b ? Matrix2(p_.block<2, 2>(a, b)) : Matrix2(p_.block<2, 2>(b, a).transpose());
}

Eigen::MatrixXd EkfSlam::covariance() const {
  const auto n = static_cast<Eigen::Index>(dim_);
  Eigen::MatrixXd full = p_.topLeftCorner(n, n).selfadjointView<Eigen::Lower>();
  full.block(3, 0, n - 3, 3) = full.block(3, 0, n - 3, 3) * pending_motion_.transpose();
  full.block(0, 3, 3, n - 3) = full.block(3, 0, n - 3, 3).transpose();
  return full;
}

Matrix23 EkfSlam::landmark_pose_covariance(std::size_t index) const {
  return p_.block<2, 3>(static_cast<Eigen::Index>(landmark_offset(index)), 0) * pending_motion_.transpose();
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
    if (tracks_[i].confirmed) out.push_back(Landmark{ids_[i], landmark_position(i), landmark_covariance(i)});
  return out;
}

std::map<std::string, double> EkfSlam::statistics() const {
  std::map<std::string, double> s = {{"discarded_observations", static_cast<double>(discarded_)},
                                     {"landmarks_removed", static_cast<double>(removed_)},
                                     {"landmarks_in_state", static_cast<double>(ids_.size())}};
  if (association_.method == AssociationMethod::kKnown && association_.gate_known)
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
  p_.topLeftCorner<3, 3>() = f * diagonal_block<3>(0) * f.transpose() + q;
  // Landmarks are static: only the map-vehicle cross-covariance P_mv changes, to P_mv F^T. The Fs of
  // the controls between two scans are multiplied together and applied to P_mv once, when it is
  // next needed: the same product, O(1) per control instead of O(n).
  pending_motion_ = f * pending_motion_;
}

void EkfSlam::covariance_times_jacobian(std::size_t lm_offset, const Matrix23& hx, const Matrix2& hm) {
  const auto n = static_cast<Eigen::Index>(dim_);
  const auto l = static_cast<Eigen::Index>(lm_offset);
  auto out = pht_.topRows(n);
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
  s = hx * diagonal_block<3>(0) * hx.transpose() + cross + cross.transpose() +
      hm * diagonal_block<2>(l) * hm.transpose() + observation_->noise();
}

bool EkfSlam::update_landmark(std::size_t index, const Vector2& z) {
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

  covariance_times_jacobian(l, hx, hm);
  Matrix2 s = hx * pht_.topRows<3>() + hm * pht_.middleRows<2>(li) + observation_->noise();
  s(0, 1) = s(1, 0) = 0.5 * (s(0, 1) + s(1, 0));
  const Eigen::LLT<Matrix2> llt(s);
  if (llt.info() != Eigen::Success) return false;

  // Eq. (10): x += W nu with W = P H^T S^-1.
  x_.head(n).noalias() += pht_.topRows(n) * llt.solve(nu);
  x_[2] = wrap_angle(x_[2]);

  // Eq. (11): P -= W S W^T = C C^T with C = P H^T L^-T (S = L L^T). L^-T is upper triangular, so C
  // is formed in place, column 1 first because it still needs the old column 0.
  const Matrix2 lower = llt.matrixL();
  const double a00 = 1.0 / lower(0, 0), a11 = 1.0 / lower(1, 1);
  const double a01 = -lower(1, 0) * a00 * a11;
  auto c0 = pht_.col(0).head(n);
  auto c1 = pht_.col(1).head(n);
  c1 = a01 * c0 + a11 * c1;
  c0 *= a00;
  p_.topLeftCorner(n, n).selfadjointView<Eigen::Lower>().rankUpdate(pht_.topRows(n), -1.0);
  return true;
}

std::size_t EkfSlam::add_landmark(const Vector2& z, int id) {
  reserve(dim_ + 2);
  apply_pending_motion();
  const auto l = static_cast<Eigen::Index>(dim_);
  const Pose2 xv = x_.head<3>();
  Matrix23 gx;
  Matrix2 gz;
  observation_->inverse_jacobians(xv, z, gx, gz);
  x_.segment<2>(l) = observation_->inverse(xv, z);
  // The new landmark inherits the vehicle's uncertainty, so it is correlated with everything the
  // vehicle is correlated with: P(m_new, :) = Gx P(v, :).
  const Matrix3 pvv = diagonal_block<3>(0);
  p_.block<2, 3>(l, 0).noalias() = gx * pvv;
  if (l > 3) p_.block(l, 3, 2, l - 3).noalias() = gx * p_.block(3, 0, l - 3, 3).transpose();
  p_.block<2, 2>(l, l).noalias() = gx * pvv * gx.transpose() + gz * observation_->noise() * gz.transpose();
  dim_ += 2;
  const std::size_t index = ids_.size();
  ids_.push_back(id);
  if (id != kUnknownId) index_of_id_[id] = index;
  Track track;
  track.confirmed = association_.method == AssociationMethod::kKnown || association_.confirm_after <= 1;
  tracks_.push_back(track);
  grid_.add(index, landmark_position(index));
  return index;
}

void EkfSlam::remove_landmark(std::size_t index) {
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
  tracks_.erase(tracks_.begin() + static_cast<std::ptrdiff_t>(index));
  if (id != kUnknownId) index_of_id_.erase(id);
  for (auto& [key, i] : index_of_id_)
    if (i > index) --i;
  std::vector<Vector2> positions(ids_.size());
  for (std::size_t i = 0; i < ids_.size(); ++i) positions[i] = landmark_position(i);
  grid_.rebuild(positions);
}

void EkfSlam::update(const ScanEvent& scan) {
  last_associations_.assign(scan.observations.size(), AssociationRecord{});
  if (association_.method == AssociationMethod::kKnown)
    update_known(scan);
  else
    update_unknown(scan);
}

void EkfSlam::update_known(const ScanEvent& scan) {
  new_observations_.clear();
  auto apply = [&](std::size_t k, std::size_t index) {
    if (association_.gate_known) {
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
    if (update_landmark(index, scan.observations[k].z)) {
      last_associations_[k] = {AssociationDecision::kUpdate, ids_[index]};
      ++tracks_[index].observations;
    } else {
      ++discarded_;
    }
  };
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
}

void EkfSlam::find_candidates(double range_margin, double angle_margin, std::vector<std::size_t>& out) const {
  out.clear();
  if (ids_.empty()) return;
  // The grid bins landmarks where they were last re-binned; one extra cell covers the drift since.
  const double reach = sensor_.max_range + range_margin;
  std::vector<std::size_t> nearby;
  grid_.query(x_.head<2>(), reach + grid_.cell_size(), nearby);
  const Pose2 xv = pose();
  for (const std::size_t j : nearby) {
    const Vector2 z = observation_->predict(xv, landmark_position(j));
    if (z[0] > reach) continue;
    if (!full_circle(sensor_) && std::abs(z[1]) > 0.5 * sensor_.fov + angle_margin) continue;
    out.push_back(j);
  }
  std::sort(out.begin(), out.end());
}

std::vector<Pairing> EkfSlam::associate_scan(const ScanEvent& scan) {
  // Candidates reach a little beyond the sensor: a landmark just outside the predicted view may be
  // the one seen at the edge.
  find_candidates(association_.view_margin_m, association_.view_margin_rad, candidates_);
  return associate(scan.observations, candidates_, *this, *observation_, association_, &association_stats_);
}

void EkfSlam::update_unknown(const ScanEvent& scan) {
  const std::vector<Pairing> pairings = associate_scan(scan);

  const Vector2 position_before = x_.head<2>();
  std::vector<bool> seen(ids_.size(), false);
  for (std::size_t k = 0; k < pairings.size(); ++k) {
    if (pairings[k].decision != AssociationDecision::kUpdate) continue;
    const std::size_t index = pairings[k].landmark;
    if (!update_landmark(index, scan.observations[k].z)) continue;
    last_associations_[k] = {AssociationDecision::kUpdate, ids_[index]};
    seen[index] = true;
    Track& track = tracks_[index];
    ++track.observations;
    track.misses = 0;
    if (track.observations >= association_.confirm_after) track.confirmed = true;
  }
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
  for (const std::size_t j : candidates_) grid_.move(j, landmark_position(j));
  drift_since_rebuild_ += (x_.head<2>() - position_before).norm();
  if (drift_since_rebuild_ > 0.5 * grid_.cell_size()) {
    std::vector<Vector2> positions(ids_.size());
    for (std::size_t i = 0; i < ids_.size(); ++i) positions[i] = landmark_position(i);
    grid_.rebuild(positions);
    drift_since_rebuild_ = 0.0;
  }
  manage_map(seen);
}

void EkfSlam::manage_map(const std::vector<bool>& seen) {
  // Only landmarks predicted well inside the view count as missed: near the edge the sensor's own
  // noise decides whether they are seen.
  find_candidates(-association_.view_margin_m, -association_.view_margin_rad, candidates_);
  std::vector<std::size_t> doomed;
  for (const std::size_t j : candidates_) {
    if (j >= seen.size() || seen[j]) continue;  // added this scan, or seen
    Track& track = tracks_[j];
    ++track.misses;
    const bool expired = track.confirmed
                             ? association_.confirmed_max_misses > 0 && track.misses >= association_.confirmed_max_misses
                             : track.misses >= association_.provisional_max_misses;
    if (expired) doomed.push_back(j);
  }
  // Highest index first, so the indices still to remove stay valid.
  for (auto it = doomed.rbegin(); it != doomed.rend(); ++it) {
    remove_landmark(*it);
    ++removed_;
  }
}

}  // namespace slamkit
