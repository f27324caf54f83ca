#include "slamkit/filters/ekf_estimator.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>
#include <thread>

#include "slamkit/core/angles.hpp"

namespace slamkit {

namespace {
constexpr std::size_t kInitialLandmarkCapacity = 64;
}  // namespace

EkfEstimator::EkfEstimator(std::shared_ptr<const MotionModel> motion,
                           std::shared_ptr<const ObservationModel> observation, const Pose2& initial_pose)
    : motion_(std::move(motion)), observation_(std::move(observation)) {
  if (!motion_ || !observation_) throw std::invalid_argument("EKF-SLAM needs a motion and an observation model");
  // The gates measure innovations against R: without measurement noise a new landmark's innovation
  // covariance is singular and unknown association starts a landmark for every observation.
  if (observation_->noise().llt().info() != Eigen::Success)
    throw std::invalid_argument("EKF-SLAM needs a positive definite measurement noise R");
  EkfEstimator::reserve(3 + 2 * kInitialLandmarkCapacity);
  x_.head<3>() = initial_pose;
  x_[2] = wrap_angle(x_[2]);
}

void EkfEstimator::reserve(std::size_t dim) {
  const auto capacity = static_cast<std::size_t>(x_.size());
  if (dim <= capacity) return;
  // Growing by a quarter, not by doubling: the square buffer is what EKF-SLAM's memory is, and
  // doubling left it up to 4x the covariance (2.25 GB at 5,000 landmarks); a quarter bounds it at
  // 1.56x while the copies, O(capacity^2) each, still amortise to O(1) per landmark added.
  const auto grown = static_cast<Eigen::Index>(std::max(dim, capacity + capacity / 4));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(grown);
  if (capacity > 0) x.head(static_cast<Eigen::Index>(dim_)) = x_.head(static_cast<Eigen::Index>(dim_));
  x_.swap(x);
}

void EkfEstimator::landmark_marginals(std::vector<Vector2>& means, std::vector<Matrix2>& covariances) const {
  means.resize(num_landmarks());
  covariances.resize(num_landmarks());
  for (std::size_t i = 0; i < num_landmarks(); ++i) {
    means[i] = landmark_position(i);
    covariances[i] = landmark_covariance(i);
  }
}

std::size_t EkfEstimator::add_inverse_distance_landmark(const Measurement& /*z*/,
                                                       const InverseDistanceOptions& /*options*/) {
  throw std::logic_error("inverse-distance landmarks are kept by the EKF variants full and fej");
}

Measurement EkfEstimator::predicted_measurement(const Pose2& x, const Vector2& m) const {
  Measurement z = observation_->predict(x, m);
  if (calibrates_ranges()) z[calibrated_row()] = range_correction().range(z[calibrated_row()]);
  return z;
}

void EkfEstimator::estimate_range_calibration(const RangeCalibrationPrior& prior) {
  validate(prior, *observation_);
  if (!supports_range_calibration())
    throw std::invalid_argument("this estimator does not keep a range calibration (the full-covariance EKF, its "
                                "FEJ, invariant and iterated variants do)");
  if (num_landmarks() > 0 || calibrates_ranges())
    throw std::logic_error("the range calibration joins the state before the first landmark, once");
  reserve(dim_ + 2);
  // Static, as a landmark is: its covariance with the vehicle changes with the motion as theirs do.
  x_[kOffsetRow] = prior.offset_m;
  x_[kScaleRow] = prior.scale_error;
  store_calibration_prior(
      Eigen::Vector2d(prior.offset_std_m * prior.offset_std_m, prior.scale_error_std * prior.scale_error_std)
          .asDiagonal());
  dim_ += 2;
  parameters_ = 2;
}

RangeCorrection EkfEstimator::range_correction() const {
  return calibrates_ranges() ? RangeCorrection{x_[kOffsetRow], x_[kScaleRow]} : RangeCorrection{};
}

Matrix2 EkfEstimator::range_correction_covariance() const {
  return calibrates_ranges() ? calibration_covariance() : Matrix2::Zero();
}

void EkfEstimator::innovation(std::size_t index, Measurement& zhat, MeasurementCovariance& s) const {
  const Pose2 xv = pose();
  const Vector2 m = landmark_position(index);
  zhat = observation_->predict(xv, m);
  with_measurement_dim(observation_->dim(), [&]<int D>(std::integral_constant<int, D>) {
    PoseJacobian pose_rows;
    LandmarkJacobian landmark_rows;
    observation_->jacobians(xv, m, pose_rows, landmark_rows);
    PoseRows<D> hx = pose_rows;
    LandmarkRows<D> hm = landmark_rows;
    const double distance = calibrates_ranges() ? calibrate<D>(x_, zhat, hx, hm) : 0.0;
    // S = hx Pvv hx^T + hx Pvm hm^T + hm Pmv hx^T + hm Pmm hm^T + R: only the 5x5 block is needed.
    const Matrix23 pvm_t = landmark_pose_covariance(index);  // P(m, v)
    const MeasurementSquare<D> cross = hm * pvm_t * hx.transpose();
    MeasurementSquare<D> sd = hx * pose_covariance() * hx.transpose() + cross + cross.transpose() +
                              hm * landmark_covariance(index) * hm.transpose() +
                              MeasurementSquare<D>(observation_->noise());
    if (calibrates_ranges()) {
      // H gains the calibration's columns, (1, d) in the range row: S their share in that row and
      // column, with their covariances with the vehicle and the landmark.
      const int row = calibrated_row();
      const Vector2 hp(1.0, distance);
      const MeasurementVector<D> with_calibration =
          hx * calibration_pose_covariance().transpose() * hp + hm * landmark_calibration_covariance(index) * hp;
      sd.col(row) += with_calibration;
      sd.row(row) += with_calibration.transpose();
      sd(row, row) += hp.dot(calibration_covariance() * hp);
    }
    s = sd;
  });
}

std::size_t EkfEstimator::add_landmark(const Measurement& z) {
  Measurement distance = z;
  if (calibrates_ranges()) distance[calibrated_row()] = range_correction().distance(z[calibrated_row()]);
  const std::optional<InitialLandmark> landmark = inverted_landmark(*observation_, pose(), distance);
  if (!landmark)
    throw std::logic_error("a " + observation_->name() +
                           " measurement does not determine a landmark; start it through a landmark initialiser");
  return add_landmark(*landmark);
}

void EkfEstimator::use_threads(unsigned threads) {
  if (threads == 0) threads = std::max(1U, std::thread::hardware_concurrency());
  if (threads == this->threads()) return;
  pool_.pool = threads > 1 ? std::make_unique<WorkerPool>(threads) : nullptr;
}

void EkfEstimator::remove_stored_landmark(std::size_t index) {
  const std::size_t rows = landmark_rows(index);
  remove_stored_rows(landmark_offset(index), rows);
  landmark_offsets_.erase(landmark_offsets_.begin() + static_cast<std::ptrdiff_t>(index));
}

void EkfEstimator::remove_stored_rows(std::size_t first, std::size_t count) {
  squeeze_stored_rows(first, count);
  const std::size_t end = first + count;
  std::copy(x_.data() + end, x_.data() + dim_, x_.data() + first);
  dim_ -= count;
  for (std::size_t& offset : landmark_offsets_)
    if (offset >= end) offset -= count;
}

}  // namespace slamkit
