#include "slamkit/filters/unscented_joint_gaussian.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <stdexcept>

#include "slamkit/core/angles.hpp"

namespace slamkit {

// The symmetric sigma-point set of a Gaussian with covariance `cov`: points mean +- o_j, o_j = c a_j
// for the r columns a_j of a square root A (A A^T = cov), each point of weight 1/(2 c^2), the mean
// itself taking the rest. The spread c^2 = min(r, 3): 3 matches the Gaussian's fourth moment along
// each direction (Julier and Uhlmann's kappa = 3 - r); below r = 3 that would give the mean a
// negative weight, so c^2 = r there (the mean's weight is 0). A is the Cholesky factor when the
// covariance is well conditioned (cheap); otherwise the eigen-directions of non-zero variance, so
// that a singular covariance (the start pose is known exactly) gives points only where there is
// uncertainty.
void UnscentedJointGaussian::sigma_points(Transform& t, const Eigen::MatrixXd& cov) {
  const Eigen::Index d = cov.rows();
  t.factor = cov;
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(t.factor);
  if (llt.info() == Eigen::Success &&
      t.factor.diagonal().array().square().minCoeff() > 1e-12 * cov.diagonal().maxCoeff()) {
    const double spread = std::min(static_cast<double>(d), 3.0);
    const double c = std::sqrt(spread);
    t.offsets = t.factor.triangularView<Eigen::Lower>();
    t.offsets *= c;
    t.weight = 0.5 / spread;
    t.triangular = true;
    return;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(cov);
  const Eigen::VectorXd& lambda = eigen.eigenvalues();
  const double floor = 1e-12 * std::max(lambda.maxCoeff(), 0.0);
  std::vector<Eigen::Index> kept;
  for (Eigen::Index j = 0; j < lambda.size(); ++j)
    if (lambda[j] > floor && lambda[j] > 0.0) kept.push_back(j);
  const auto r = static_cast<Eigen::Index>(kept.size());
  const double spread = std::min(static_cast<double>(r), 3.0);
  t.offsets.resize(d, r);
  t.inverse_offsets.resize(r, d);
  t.weight = 0.5 / std::max(spread, 1.0);
  t.triangular = false;
  for (Eigen::Index j = 0; j < r; ++j) {
    const double length = std::sqrt(spread * lambda[kept[static_cast<std::size_t>(j)]]);
    const auto v = eigen.eigenvectors().col(kept[static_cast<std::size_t>(j)]);
    t.offsets.col(j) = length * v;
    t.inverse_offsets.row(j) = v.transpose() / length;  // orthogonal columns
  }
}

template <class Image, class Subtract>
void UnscentedJointGaussian::unscented(Transform& t, const Eigen::VectorXd& mean, const Eigen::MatrixXd& cov,
                                       Eigen::Index m, Image image, Subtract subtract) {
  sigma_points(t, cov);
  const Eigen::Index r = t.offsets.cols();
  t.centre.resize(m);
  image(mean, Eigen::Index{0}, Eigen::Index{-1}, t.centre);
  t.mean = t.centre;
  t.covariance.setZero(m, m);
  t.linearisation.setZero(m, mean.size());
  t.shift.setZero(m);
  if (r == 0) return;
  t.images.resize(m, 2 * r);
  for (Eigen::Index j = 0; j < r; ++j) {
    // A column of the Cholesky factor moves the rows from its own down, and only those.
    const Eigen::Index first_moved = t.triangular ? j : 0;
    for (const double sign : {1.0, -1.0}) {
      const Eigen::Index column = sign > 0.0 ? j : r + j;
      t.point = mean + sign * t.offsets.col(j);
      Eigen::Ref<Eigen::VectorXd> y = t.images.col(column);
      y = t.centre;
      image(t.point, first_moved, column, y);
      subtract(y, t.centre, first_moved);
    }
  }
  t.shift.noalias() = t.weight * t.images.rowwise().sum();
  t.mean += t.shift;
  // Central differences along the offsets, (y+ - y-) / 2 = J o_j for a linear f, so J = that times
  // the offsets' pseudo-inverse: the regression coefficient of y on s. For the Cholesky factor's
  // offsets (lower triangular) that is a triangular solve on the right.
  t.linearisation = 0.5 * (t.images.leftCols(r) - t.images.rightCols(r));
  if (t.triangular)
    t.offsets.triangularView<Eigen::Lower>().solveInPlace<Eigen::OnTheRight>(t.linearisation);
  else
    t.linearisation *= t.inverse_offsets;
  // The weighted scatter about the new mean, the centre point's term included, is this sum less
  // shift shift^T (the weights add up to one).
  t.covariance.noalias() = t.weight * t.images * t.images.transpose();
  t.covariance.noalias() -= t.shift * t.shift.transpose();
}

UnscentedJointGaussian::UnscentedJointGaussian(std::shared_ptr<const MotionModel> motion,
                                               std::shared_ptr<const ObservationModel> observation,
                                               const Pose2& initial_pose, const Matrix3& initial_covariance,
                                               UkfNoise noise)
    : JointGaussian(std::move(motion), std::move(observation), initial_pose, initial_covariance), noise_(noise) {}

void UnscentedJointGaussian::predict(const Control& u, double dt) {
  const ControlCovariance noise = motion_->control_noise(u, dt);
  const Eigen::Index c = noise.rows();
  const auto subtract = [](Eigen::Ref<Eigen::VectorXd> y, const Eigen::VectorXd& centre, Eigen::Index) {
    y -= centre;
    y[2] = wrap_angle(y[2]);
  };
  // The augmented transform draws sigma points over [vehicle, control noise]; the additive one over
  // the vehicle alone, and over the control noise at the mean pose apart.
  const Eigen::Index noise_in_sigma_points = noise_ == UkfNoise::kAugmented ? c : 0;
  Transform& t = motion_transform_;
  motion_mean_.setZero(3 + noise_in_sigma_points);
  motion_mean_.head<3>() = x_.head<3>();
  motion_covariance_.setZero(3 + noise_in_sigma_points, 3 + noise_in_sigma_points);
  motion_covariance_.topLeftCorner<3, 3>() = diagonal_block<3>(0);
  motion_covariance_.bottomRightCorner(noise_in_sigma_points, noise_in_sigma_points) =
      noise.topLeftCorner(noise_in_sigma_points, noise_in_sigma_points);
  unscented(
      t, motion_mean_, motion_covariance_, 3,
      [&](const Eigen::VectorXd& a, Eigen::Index, Eigen::Index, Eigen::Ref<Eigen::VectorXd> y) {
        Control noisy = u;
        noisy.head(noise_in_sigma_points) += a.tail(noise_in_sigma_points);
        y.head<3>() = motion_->predict(a.head<3>(), noisy, dt);
      },
      subtract);
  p_.topLeftCorner<3, 3>() = t.covariance;
  if (noise_ == UkfNoise::kAdditive) {
    Transform& n = noise_transform_;
    const Pose2 mean_pose = x_.head<3>();
    control_mean_ = u;
    control_covariance_ = noise;
    unscented(
        n, control_mean_, control_covariance_, 3,
        [&](const Eigen::VectorXd& a, Eigen::Index, Eigen::Index, Eigen::Ref<Eigen::VectorXd> y) {
          y.head<3>() = motion_->predict(mean_pose, Control(a), dt);
        },
        subtract);
    // The second moment about f(x, u): the spread the curvature would have shifted the mean by
    // stays spread.
    p_.topLeftCorner<3, 3>() += n.covariance + n.shift * n.shift.transpose();
  }
  x_.head<3>() = t.mean;
  x_[2] = wrap_angle(x_[2]);
  // P_mv <- P_mv A^T with A the vehicle part of the regression, applied lazily like F.
  pending_motion_ = t.linearisation.leftCols<3>() * pending_motion_;
}

bool UnscentedJointGaussian::update_landmark(const LandmarkObservation& observation) {
  return update_landmarks(std::span<const LandmarkObservation>(&observation, 1));
}

bool UnscentedJointGaussian::update_landmarks(std::span<const LandmarkObservation> batch) {
  if (batch.empty()) return true;
  apply_pending_motion();
  const auto n = static_cast<Eigen::Index>(dim_);
  const Eigen::Index dz = observation_->dim();
  const auto k = dz * static_cast<Eigen::Index>(batch.size());
  // The sub-state s: the vehicle, then each observed landmark once; sub_at_[i] is observation i's
  // landmark's position in s.
  sub_offsets_.assign(1, 0);
  sub_at_.resize(batch.size());
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const std::size_t offset = landmark_offset(batch[i].index);
    const auto found = std::find(sub_offsets_.begin(), sub_offsets_.end(), offset);
    sub_at_[i] = 3 + 2 * static_cast<Eigen::Index>(found - sub_offsets_.begin() - 1);
    if (found == sub_offsets_.end()) sub_offsets_.push_back(offset);
  }
  const auto d = static_cast<Eigen::Index>(1 + 2 * sub_offsets_.size());
  auto width = [](std::size_t block) -> Eigen::Index { return block == 0 ? 3 : 2; };
  // P(:, s), the covariance's columns of the sub-state gathered from the lower triangle (rows above
  // a block from its transposed row block), of which s's own rows are P(s, s).
  sub_columns_.resize(n, d);
  for (std::size_t a = 0, ra = 0; a < sub_offsets_.size(); ra += static_cast<std::size_t>(width(a)), ++a) {
    const auto o = static_cast<Eigen::Index>(sub_offsets_[a]);
    const Eigen::Index wa = width(a);
    auto columns = sub_columns_.middleCols(static_cast<Eigen::Index>(ra), wa);
    if (o > 0) columns.topRows(o) = p_.block(o, 0, wa, o).transpose();
    columns.middleRows(o, wa) = p_.block(o, o, wa, wa).selfadjointView<Eigen::Lower>();
    if (o + wa < n) columns.bottomRows(n - o - wa) = p_.block(o + wa, o, n - o - wa, wa);
  }
  sub_mean_.resize(d);
  sub_covariance_.resize(d, d);
  for (std::size_t a = 0, ra = 0; a < sub_offsets_.size(); ra += static_cast<std::size_t>(width(a)), ++a) {
    const auto o = static_cast<Eigen::Index>(sub_offsets_[a]);
    sub_mean_.segment(static_cast<Eigen::Index>(ra), width(a)) = x_.segment(o, width(a));
    sub_covariance_.middleRows(static_cast<Eigen::Index>(ra), width(a)) = sub_columns_.middleRows(o, width(a));
  }

  // Whether a sigma point that leaves the sub-state's rows before first_moved at the mean moves
  // observation i (the vehicle's rows or its landmark's).
  const auto moves = [&](std::size_t i, Eigen::Index first_moved) { return first_moved < 3 || sub_at_[i] + 2 > first_moved; };
  Transform& t = scan_transform_;
  // The points along the Cholesky factor's landmark columns leave the vehicle at the mean, so the
  // landmarks they move are all predicted from the mean pose at once (one sensor pose for all of
  // them), when the first of those points is imaged; mean_pose_first_[c] is where image column c's
  // predictions start.
  bool mean_pose_predicted = false;
  const auto predict_from_mean_pose = [&] {
    const Eigen::Index r = t.offsets.cols();
    mean_pose_landmarks_.clear();
    mean_pose_first_.assign(static_cast<std::size_t>(2 * r), 0);
    for (Eigen::Index column = 0; column < 2 * r; ++column) {
      const Eigen::Index j = column % r;
      if (j < 3) continue;
      const double sign = column < r ? 1.0 : -1.0;
      mean_pose_first_[static_cast<std::size_t>(column)] = mean_pose_landmarks_.size();
      for (std::size_t i = 0; i < batch.size(); ++i)
        if (moves(i, j))
          mean_pose_landmarks_.push_back(sub_mean_.segment<2>(sub_at_[i]) + sign * t.offsets.block<2, 1>(sub_at_[i], j));
    }
    mean_pose_predictions_.resize(mean_pose_landmarks_.size());
    observation_->predict_many(sub_mean_.head<3>(), mean_pose_landmarks_, mean_pose_predictions_);
    mean_pose_predicted = true;
  };
  unscented(
      t, sub_mean_, sub_covariance_, k,
      [&](const Eigen::VectorXd& s, Eigen::Index first_moved, Eigen::Index column, Eigen::Ref<Eigen::VectorXd> z) {
        // An observation reads the vehicle and its landmark; the points that move neither leave it
        // at the centre's prediction (half of the evaluations, the Cholesky factor being triangular).
        // The others are predicted together, from the point's pose.
        if (first_moved >= 3) {
          if (!mean_pose_predicted) predict_from_mean_pose();
          auto next = mean_pose_predictions_.cbegin() + static_cast<std::ptrdiff_t>(mean_pose_first_[static_cast<std::size_t>(column)]);
          for (std::size_t i = 0; i < batch.size(); ++i)
            if (moves(i, first_moved)) z.segment(dz * static_cast<Eigen::Index>(i), dz) = *next++;
          return;
        }
        // A point that moves the vehicle moves every observation.
        moved_landmarks_.clear();
        for (std::size_t i = 0; i < batch.size(); ++i) moved_landmarks_.push_back(s.segment<2>(sub_at_[i]));
        moved_predictions_.resize(moved_landmarks_.size());
        observation_->predict_many(s.head<3>(), moved_landmarks_, moved_predictions_);
        for (std::size_t i = 0; i < batch.size(); ++i) z.segment(dz * static_cast<Eigen::Index>(i), dz) = moved_predictions_[i];
      },
      [&](Eigen::Ref<Eigen::VectorXd> a, const Eigen::VectorXd& b, Eigen::Index first_moved) {
        // The residual of a prediction left at the centre's is exactly zero.
        for (std::size_t i = 0; i < batch.size(); ++i) {
          auto ai = a.segment(dz * static_cast<Eigen::Index>(i), dz);
          if (moves(i, first_moved))
            ai = observation_->residual(ai, b.segment(dz * static_cast<Eigen::Index>(i), dz));
          else
            ai.setZero();
        }
      });

  reserve_joint_update(k);
  auto s = batch_s_.topLeftCorner(k, k);
  s = t.covariance;
  const MeasurementCovariance noise = observation_->noise();
  for (Eigen::Index i = 0; i < k; i += dz) {
    s.block(i, i, dz, dz) += batch[static_cast<std::size_t>(i / dz)].noise_scale * noise;
    batch_nu_.segment(i, dz) = observation_->residual(batch[static_cast<std::size_t>(i / dz)].z, t.mean.segment(i, dz));
  }
  // W = P(:, s) A^T.
  pht_.topLeftCorner(n, k).noalias() = sub_columns_ * t.linearisation.transpose();
  return apply_joint_update(k);
}

std::size_t UnscentedJointGaussian::add_landmark(const Measurement& z) {
  if (!observation_->invertible())
    throw std::logic_error("a " + observation_->name() +
                           " measurement does not determine a landmark; start it through a landmark initialiser");
  reserve(dim_ + 2);
  apply_pending_motion();
  // Sigma points over [vehicle, measurement noise], through the inverse observation model.
  Transform& t = landmark_transform_;
  const Eigen::Index dz = observation_->dim();
  sub_mean_.resize(3 + dz);
  sub_mean_ << x_.head<3>(), z;
  sub_covariance_.setZero(3 + dz, 3 + dz);
  sub_covariance_.topLeftCorner<3, 3>() = diagonal_block<3>(0);
  sub_covariance_.bottomRightCorner(dz, dz) = observation_->noise();
  // The images are written through fixed-size heads: on a dynamic destination GCC 12 reports Eigen's
  // (unreachable) 8-wide AVX-512 loop as reading past a 2- or 3-vector.
  unscented(
      t, sub_mean_, sub_covariance_, 2,
      [&](const Eigen::VectorXd& a, Eigen::Index, Eigen::Index, Eigen::Ref<Eigen::VectorXd> y) {
        y.head<2>() = observation_->invert(a.head<3>(), a.tail(dz))->position;
      },
      [](Eigen::Ref<Eigen::VectorXd> y, const Eigen::VectorXd& centre, Eigen::Index) { y -= centre; });
  append_landmark(t.mean, t.linearisation.leftCols<3>(), t.covariance);
  return num_landmarks() - 1;
}

}  // namespace slamkit
