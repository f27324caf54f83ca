#include "slamkit/filters/compressed_joint_gaussian.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <type_traits>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/huge_pages.hpp"

namespace slamkit {

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

CompressedJointGaussian::CompressedJointGaussian(std::shared_ptr<const MotionModel> motion,
                                                 std::shared_ptr<const ObservationModel> observation,
                                                 double sensor_range, double area_side, const Pose2& initial_pose,
                                                 const Matrix3& initial_covariance)
    : DenseCovarianceEstimator(std::move(motion), std::move(observation), initial_pose, initial_covariance),
      sensor_range_(sensor_range),
      area_half_side_(0.5 * (area_side > 0.0 ? area_side : 2.0 * sensor_range)) {}

// In an open local area the accessors answer from the local state for active landmarks and apply
// the accumulated update on the fly for the others: O(dim(A0)^2) at most.

template <typename Derived>
Eigen::Matrix<double, Derived::RowsAtCompileTime, 2> CompressedJointGaussian::times_start_cross_t(
    const Eigen::MatrixBase<Derived>& m, std::size_t index) const {
  using Result = Eigen::Matrix<double, Derived::RowsAtCompileTime, 2>;
  Result out = Result::Zero();
  for (Eigen::Index c = 0; c < a0_; ++c) out.noalias() += m.col(c) * start_cross(index, c).transpose();
  return out;
}

Matrix2 CompressedJointGaussian::start_cross_quadratic(std::size_t i, std::size_t j) const {
  Matrix2 out = Matrix2::Zero();
  for (Eigen::Index c = 0; c < a0_; ++c) out.noalias() += start_cross(i, c) * times_start_cross_t(psi().row(c), j);
  return out;
}

Matrix3 CompressedJointGaussian::pose_covariance() const {
  return in_area() ? Matrix3(pa_.topLeftCorner<3, 3>()) : diagonal_block<3>(0);
}

Vector2 CompressedJointGaussian::landmark_position(std::size_t index) const {
  const auto l = static_cast<Eigen::Index>(landmark_offset(index));
  if (!in_area() || local_offset(index) >= 0) return x_.segment<2>(l);
  return x_.segment<2>(l) + times_start_cross_t(theta().transpose(), index).transpose();
}

Matrix2 CompressedJointGaussian::landmark_covariance(std::size_t index) const {
  if (!in_area()) return diagonal_block<2>(landmark_offset(index));
  if (const long a = local_offset(index); a >= 0) return pa_.block<2, 2>(a, a);
  return diagonal_block<2>(landmark_offset(index)) - start_cross_quadratic(index, index);
}

void CompressedJointGaussian::landmark_marginals(std::vector<Vector2>& means,
                                                 std::vector<Matrix2>& covariances) const {
  means.resize(num_landmarks());
  covariances.resize(num_landmarks());
  for (std::size_t i = 0; i < num_landmarks(); ++i)
    if (local_offset(i) >= 0 || !in_area()) {
      means[i] = landmark_position(i);
      covariances[i] = landmark_covariance(i);
    }
  if (!in_area() || outside_.empty()) return;
  // B's means x_B(0) + U theta, and its 2x2 diagonal blocks of P_BB(0) - U psi U^T. psi is symmetric:
  // with psi = L + D + L^T (L strictly lower) and V = U L, which costs half of U psi,
  // U_r psi U_s^T = V_r . U_s + V_s . U_r + sum_c U_rc psi_cc U_sc.
  const auto u = start_cross_block();
  const Eigen::Index n_b = u.rows();
  const Eigen::VectorXd shift = u * theta();
  const Eigen::MatrixXd v = u * psi().triangularView<Eigen::StrictlyLower>();
  auto blocks = [&](auto rows, Eigen::Index begin) {
    // The rows' dot products, a block of rows at a time with every sum in registers (U and V are
    // column-major). Row r's partner in its landmark is r ^ 1 (B's rows come in pairs from an even
    // row): `cross` sums (V_r + psi_cc U_r / 2) U_{r^1}, and a landmark's two add up to its
    // off-diagonal entry.
    constexpr int kRows = decltype(rows)::value;
    double square[kRows] = {}, cross[kRows] = {};
    for (Eigen::Index c = 0; c < a0_; ++c) {
      const double psi_cc = psi()(c, c);
      const double* uc = &u.coeffRef(begin, c);
      const double* vc = &v.coeffRef(begin, c);
      for (int i = 0; i < kRows; ++i) {
        square[i] += (2.0 * vc[i] + psi_cc * uc[i]) * uc[i];
        cross[i] += (vc[i] + 0.5 * psi_cc * uc[i]) * uc[i ^ 1];
      }
    }
    for (int i = 0; i < kRows; i += 2) {
      const auto r = begin + i;
      const std::size_t l = outside_[static_cast<std::size_t>(r)], index = (l - 3) / 2;
      means[index] = x_.segment<2>(static_cast<Eigen::Index>(l)) + shift.segment<2>(r);
      Matrix2 quadratic;
      quadratic << square[i], cross[i] + cross[i + 1], cross[i] + cross[i + 1], square[i + 1];
      covariances[index] = diagonal_block<2>(l) - quadratic;
    }
  };
  constexpr int kBlock = 16;
  Eigen::Index r = 0;
  for (; r + kBlock <= n_b; r += kBlock) blocks(std::integral_constant<int, kBlock>{}, r);
  for (; r < n_b; r += 2) blocks(std::integral_constant<int, 2>{}, r);
}

Matrix2 CompressedJointGaussian::landmark_cross_covariance(std::size_t i, std::size_t j) const {
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

Matrix23 CompressedJointGaussian::landmark_pose_covariance(std::size_t index) const {
  if (!in_area()) return p_.block<2, 3>(static_cast<Eigen::Index>(landmark_offset(index)), 0);
  if (const long a = local_offset(index); a >= 0) return pa_.block<2, 3>(a, 0);
  return times_start_cross_t(phi().topRows<3>(), index).transpose();
}

Eigen::VectorXd CompressedJointGaussian::state() const {
  Eigen::VectorXd x = x_.head(static_cast<Eigen::Index>(dim_));
  if (in_area())
    for (std::size_t i = 0; i < num_landmarks(); ++i)
      if (local_offset(i) < 0) x.segment<2>(static_cast<Eigen::Index>(landmark_offset(i))) = landmark_position(i);
  return x;
}

Eigen::MatrixXd CompressedJointGaussian::covariance() const {
  const auto n = static_cast<Eigen::Index>(dim_);
  Eigen::MatrixXd lower = p_.topLeftCorner(n, n);
  if (in_area()) {
    Eigen::VectorXd x = x_.head(n);
    MergeWorkspace ws;
    merge_area(x, lower, ws);
  }
  return lower.selfadjointView<Eigen::Lower>();
}

void CompressedJointGaussian::predict(const Control& u, double dt) {
  const Pose2 xv = x_.head<3>();
  const Matrix3 f = motion_->jacobian_state(xv, u, dt);
  const Matrix3 q = motion_->process_noise(xv, u, dt);
  x_.head<3>() = motion_->predict(xv, u, dt);
  if (!in_area()) begin_area();
  predict_local(f, q);
}

void CompressedJointGaussian::inflate_pose(const Matrix3& q) {
  if (!in_area()) begin_area();
  predict_local(Matrix3::Identity(), q);
}

bool CompressedJointGaussian::update_landmark(const LandmarkObservation& observation) {
  return update_landmarks(std::span<const LandmarkObservation>(&observation, 1));
}

bool CompressedJointGaussian::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  // Inside the square every landmark in view is active; an observation of one that is not (the
  // area's square is checked before each scan, not after each control) starts a new area early.
  const bool all_active = std::all_of(batch.begin(), batch.end(),
                                      [&](const LandmarkObservation& o) { return local_offset(o.index) >= 0; });
  if (!all_active) {
    flush_local_area();
    begin_area(batch);
  }
  return with_measurement_dim(observation_->dim(),
                              [&]<int D>(std::integral_constant<int, D>) { return update_local<D>(batch); });
}

std::size_t CompressedJointGaussian::add_landmark(const InitialLandmark& landmark) {
  reserve(dim_ + 2);
  if (!in_area()) begin_area();
  x_.segment<2>(static_cast<Eigen::Index>(dim_)) = landmark.mean;
  add_local(landmark.gx, landmark.covariance);
  append_landmark_rows(2);
  return num_landmarks() - 1;
}

void CompressedJointGaussian::remove_landmark(std::size_t index) {
  flush_local_area();
  remove_stored_landmark(index);
}

void CompressedJointGaussian::begin_scan() {
  // Leaving the square ends the area even if every landmark seen is still active: the landmarks
  // added on the way are active too, and an area that never ends would grow into the whole map.
  if (in_area() && (x_.head<2>() - area_centre_).lpNorm<Eigen::Infinity>() > area_half_side_) flush_local_area();
}

void CompressedJointGaussian::add_statistics(std::map<std::string, double>& statistics) const {
  statistics["local_area_flushes"] = static_cast<double>(flushes_);
}

long CompressedJointGaussian::local_offset(std::size_t index) const { return in_area() ? local_of_[index] : -1; }

void CompressedJointGaussian::reserve_area(Eigen::Index d) {
  if (d <= pa_.rows()) return;
  // Doubling: an area larger than every one before is rare once the map is built, and an area is
  // small next to the stored state (which grows by a quarter). The open area's part is kept.
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
  h_phi_.resize(h_phi_.rows(), capacity);
}

void CompressedJointGaussian::begin_area(std::span<const LandmarkObservation> must_include) {
  // The square lies ahead of the vehicle, which starts on its edge (or inside it): driving on, it
  // crosses the whole square before leaving, twice as far as from a square centred on it, for the
  // same active set (what can be seen from inside the square). Half the flushes.
  area_centre_ = x_.head<2>() + area_half_side_ * Vector2(std::cos(x_[2]), std::sin(x_[2]));
  // Every landmark the vehicle can see from inside the square is active, so observations made
  // before it leaves the square involve A only.
  const double reach = area_half_side_ + sensor_range_;
  area_offsets_ = {0, 1, 2};
  constexpr long kMustInclude = 0;  // a marker: no landmark has local offset 0 (the vehicle's)
  local_of_.assign(num_landmarks(), -1);
  for (const LandmarkObservation& o : must_include) local_of_[o.index] = kMustInclude;
  for (std::size_t i = 0; i < num_landmarks(); ++i) {
    const std::size_t l = landmark_offset(i);
    const Vector2 offset = x_.segment<2>(static_cast<Eigen::Index>(l)) - area_centre_;
    const bool near = offset.lpNorm<Eigen::Infinity>() <= reach;
    if (!near && local_of_[i] != kMustInclude) continue;
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
  gather_start_cross();
}

void CompressedJointGaussian::gather_start_cross() {
  // area_offsets_ is ascending (begin_area takes the landmarks in map order): B is its complement.
  outside_.clear();
  auto next_active = area_offsets_.begin();
  for (std::size_t i = 0; i < dim_; ++i) {
    if (next_active != area_offsets_.end() && *next_active == i)
      ++next_active;
    else
      outside_.push_back(i);
  }
  const auto n_b = static_cast<Eigen::Index>(outside_.size());
  // Rows for the stored state's capacity, columns grown geometrically: reallocating while the map
  // grows would cost the fresh pages' faults at every area.
  if (u_b_.rows() < n_b || u_b_.cols() < a0_) {
    u_b_.resize(std::max({n_b, u_b_.rows(), p_.rows()}), std::max(a0_, u_b_.cols() + u_b_.cols() / 2));
    advise_huge_pages(u_b_.data(), sizeof(double) * static_cast<std::size_t>(u_b_.size()));
  }
  auto u = u_b_.topLeftCorner(n_b, a0_);
  for (Eigen::Index c = 0; c < a0_; ++c) {
    const std::size_t a = area_offsets_[static_cast<std::size_t>(c)];
    for (Eigen::Index r = 0; r < n_b; ++r) u(r, c) = stored_entry(outside_[static_cast<std::size_t>(r)], a);
  }
}

void CompressedJointGaussian::flush_local_area() {
  if (!in_area()) return;
  const auto n = static_cast<Eigen::Index>(dim_);
  merge_area(x_.head(n), p_.topLeftCorner(n, n), merge_);
  area_offsets_.clear();
  local_of_.clear();
  ++flushes_;
}

void CompressedJointGaussian::predict_local(const Matrix3& f, const Matrix3& q) {
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

template <int D>
bool CompressedJointGaussian::update_local(std::span<const LandmarkObservation> batch) {
  const Eigen::Index d = d_, k = D * static_cast<Eigen::Index>(batch.size());
  reserve_update(k);
  std::vector<PoseRows<D>>& hx = jacobians_.get<D>().hx;
  std::vector<LandmarkRows<D>>& hm = jacobians_.get<D>().hm;
  if (hx.size() < batch.size()) {
    hx.resize(batch.size());
    hm.resize(batch.size());
  }
  PoseJacobian pose_rows;
  LandmarkJacobian landmark_rows;
  auto pa = this->pa();
  auto phi = this->phi();
  const Pose2 xv = x_.head<3>();
  // P_AA H_A^T, D columns per observation from the vehicle's and the landmark's columns, and the
  // stacked innovation; then S = H_A P_AA H_A^T + R block by block, and H_A phi.
  auto pht = pht_.topLeftCorner(d, k);
  auto nu = nu_.head(k);
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const auto l = static_cast<Eigen::Index>(local_of_[batch[i].index]);
    const auto r = D * static_cast<Eigen::Index>(i);
    const Vector2 m = x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(batch[i].index)));
    observation_->jacobians(xv, m, pose_rows, landmark_rows);
    hx[i] = pose_rows;
    hm[i] = landmark_rows;
    nu.template segment<D>(r) = observation_->residual(batch[i].z, observation_->predict(xv, m));
    pht.template middleCols<D>(r).noalias() = pa.template leftCols<3>() * hx[i].transpose();
    pht.template middleCols<D>(r).noalias() += pa.template middleCols<2>(l) * hm[i].transpose();
  }
  auto s = s_.topLeftCorner(k, k);
  auto g = h_phi_.topLeftCorner(k, a0_);
  const MeasurementSquare<D> noise = observation_->noise();
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const auto l = static_cast<Eigen::Index>(local_of_[batch[i].index]);
    const auto r = D * static_cast<Eigen::Index>(i);
    s.template middleRows<D>(r).noalias() = hx[i] * pht.template topRows<3>() + hm[i] * pht.template middleRows<2>(l);
    s.template block<D, D>(r, r) += batch[i].noise_scale * noise;
    g.template middleRows<D>(r).noalias() = hx[i] * phi.template topRows<3>();
    g.template middleRows<D>(r).noalias() += hm[i] * phi.template middleRows<2>(l);
  }
  return apply_local_update(k);
}

bool CompressedJointGaussian::fuse_landmarks(std::span<const LandmarkPair> pairs) {
  if (pairs.empty()) return true;
  const bool all_active = std::all_of(pairs.begin(), pairs.end(), [&](const LandmarkPair& p) {
    return local_offset(p.duplicate) >= 0 && local_offset(p.original) >= 0;
  });
  if (!all_active) {
    flush_local_area();
    fused_.clear();
    for (const LandmarkPair& p : pairs) {
      fused_.push_back({p.duplicate, Vector2::Zero()});
      fused_.push_back({p.original, Vector2::Zero()});
    }
    begin_area(fused_);
  }
  const Eigen::Index d = d_, k = 2 * static_cast<Eigen::Index>(pairs.size());
  reserve_update(k);
  auto pa = this->pa();
  auto phi = this->phi();
  // The measurement m_duplicate - m_original = 0, as JointGaussian::fuse_landmarks: H_A has I at the
  // duplicate and -I at the original, no noise.
  auto pht = pht_.topLeftCorner(d, k);
  auto nu = nu_.head(k);
  auto s = s_.topLeftCorner(k, k);
  auto g = h_phi_.topLeftCorner(k, a0_);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto dup = static_cast<Eigen::Index>(local_of_[pairs[i].duplicate]);
    const auto orig = static_cast<Eigen::Index>(local_of_[pairs[i].original]);
    const auto r = 2 * static_cast<Eigen::Index>(i);
    nu.segment<2>(r) = x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(pairs[i].original))) -
                       x_.segment<2>(static_cast<Eigen::Index>(landmark_offset(pairs[i].duplicate)));
    pht.middleCols<2>(r) = pa.middleCols<2>(dup) - pa.middleCols<2>(orig);
    g.middleRows<2>(r) = phi.middleRows<2>(dup) - phi.middleRows<2>(orig);
  }
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto r = 2 * static_cast<Eigen::Index>(i);
    s.middleRows<2>(r) = pht.middleRows<2>(static_cast<Eigen::Index>(local_of_[pairs[i].duplicate])) -
                         pht.middleRows<2>(static_cast<Eigen::Index>(local_of_[pairs[i].original]));
  }
  return apply_local_update(k);
}

bool CompressedJointGaussian::apply_local_update(Eigen::Index k) {
  const Eigen::Index d = d_;
  auto pht = pht_.topLeftCorner(d, k);
  auto nu = nu_.head(k);
  auto s = s_.topLeftCorner(k, k);
  auto g = h_phi_.topLeftCorner(k, a0_);
  s.triangularView<Eigen::StrictlyLower>() = 0.5 * (s + s.transpose());
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(s);
  if (llt.info() != Eigen::Success) return false;
  llt.solveInPlace(nu);  // S^-1 nu

  for (Eigen::Index r = 0; r < d; ++r) x_[static_cast<Eigen::Index>(area_offsets_[r])] += pht.row(r).dot(nu);
  x_[2] = wrap_angle(x_[2]);

  // With G = L^-1 H_A phi (S = L L^T) and C = P_AA H_A^T L^-T: theta += (H_A phi)^T S^-1 nu,
  // psi += G^T G, phi -= W_A H_A phi = C G and P_AA -= W_A S W_A^T = C C^T.
  theta().noalias() += g.transpose() * nu;
  llt.matrixL().solveInPlace(g);
  psi().noalias() += g.transpose() * g;
  llt.matrixU().solveInPlace<Eigen::OnTheRight>(pht);
  phi().noalias() -= pht * g;
  pa().noalias() -= pht * pht.transpose();
  return true;
}

void CompressedJointGaussian::reserve_update(Eigen::Index k) {
  if (pht_.cols() < k) pht_.resize(pht_.rows(), std::max(k, 2 * pht_.cols()));
  if (s_.rows() < k) {
    s_.resize(pht_.cols(), pht_.cols());
    nu_.resize(pht_.cols());
  }
  if (h_phi_.rows() < k || h_phi_.cols() < pa_.cols()) h_phi_.resize(std::max(k, h_phi_.rows()), pa_.cols());
}

void CompressedJointGaussian::add_local(const Matrix23& gx, const Matrix2& pnew) {
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

void CompressedJointGaussian::merge_area(Eigen::Ref<Eigen::VectorXd> x, Eigen::Ref<Eigen::MatrixXd> p, MergeWorkspace& ws) const {
  const Eigen::Index n = x.size(), d = d_;
  const auto u_b = start_cross_block();
  const Eigen::Index n_b = u_b.rows();
  // The workspace takes the stored state's capacity in rows and grows its columns geometrically: a
  // flush while the map grows would otherwise reallocate it every time, and the fresh pages' faults
  // cost more than the flush's arithmetic.
  const Eigen::Index capacity = p_.rows();
  auto fit = [capacity](Eigen::MatrixXd& m, Eigen::Index rows, Eigen::Index cols) {
    if (m.rows() < rows || m.cols() < cols) {
      m.resize(std::max({rows, m.rows(), capacity}), std::max({cols, m.cols() + m.cols() / 2}));
      advise_huge_pages(m.data(), sizeof(double) * static_cast<std::size_t>(m.size()));
    }
    return m.topLeftCorner(rows, cols);
  };
  // P_BA(0) spread over all n rows, zero in A's: the P_BB downdate is then one triangular product
  // on the stored layout, leaving A's rows untouched.
  auto u = fit(ws.u, n, a0_);
  u.setZero();
  for (Eigen::Index r = 0; r < n_b; ++r)
    u.row(static_cast<Eigen::Index>(outside_[static_cast<std::size_t>(r)])) = u_b.row(r);

  x.noalias() += u * theta();
  auto u_psi = fit(ws.u_psi, n, a0_);
  u_psi.noalias() = u * psi();
  ws.downdate.apply(p, u, u_psi, pool_.pool.get());
  auto p_ba = fit(ws.p_ba, n_b, d);
  p_ba.noalias() = u_b * phi().transpose();
  auto pa = this->pa();
  for (Eigen::Index c = 0; c < d; ++c) {
    const auto a = static_cast<Eigen::Index>(area_offsets_[c]);
    for (Eigen::Index r = 0; r < n_b; ++r) {
      const auto b = static_cast<Eigen::Index>(outside_[static_cast<std::size_t>(r)]);
      (b > a ? p(b, a) : p(a, b)) = p_ba(r, c);
    }
    for (Eigen::Index r = 0; r < d; ++r) {
      const auto b = static_cast<Eigen::Index>(area_offsets_[r]);
      if (b >= a) p(b, a) = pa(r, c);
    }
  }
}

}  // namespace slamkit
