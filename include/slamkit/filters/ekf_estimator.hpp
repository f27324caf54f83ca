#pragma once
// The joint Gaussian over the vehicle pose and every landmark that EKF-SLAM keeps (eqs. 6-11 of the
// tutorial), as an interface whose implementations give the same estimate in different forms:
// moment form over a dense covariance (DenseCovarianceEstimator: JointGaussian updates the whole
// covariance at every step, CompressedJointGaussian confines the updates to a local area) or
// information form (ExtendedInformationFilter). EkfSlam runs its association and map management over
// any of them; tests and benchmarks drive them directly.
//
// What every form shares, kept here: the mean, the state's layout and the models. The state is
// [x y theta | b s | m1x m1y | m2x m2y | ...], the range sensor's offset b and scale error s present
// only where they are estimated (estimate_range_calibration), each landmark's rows in map order (two
// for a point; JointGaussian's inverse-distance landmarks hold four until they become points).
#include <Eigen/Core>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "slamkit/core/information_matrix.hpp"
#include "slamkit/assoc/association.hpp"
#include "slamkit/assoc/map_matching.hpp"
#include "slamkit/filters/worker_pool.hpp"
#include "slamkit/models/inverse_distance.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

/// Where a Gaussian estimator evaluates its models' Jacobians.
enum class Linearisation {
  kStandard,        ///< Jacobians at the current estimates
  kFirstEstimates,  ///< first-estimates Jacobians (FEJ-EKF)
  kInvariant,       ///< right-invariant error (invariant EKF)
};

/// First estimates: one beyond this probability's region of the belief about the landmark's
/// position relative to the vehicle (chi-square, 2 dof) is moved. AssociationConfig's default
/// known-identity gate, so the belief rules it out as the landmark's position as firmly as the gate
/// rules out an observation of it.
inline constexpr double kPlausibleAnchorProbability = 0.9999;

/// One observation of the landmark at a map index.
struct LandmarkObservation {
  std::size_t index = 0;
  Measurement z;
  /// The update uses this times the model's R: above 1 for an observation a heavy-tailed likelihood
  /// trusts less than the sensor (MeasurementLikelihood::noise_inflation).
  double noise_scale = 1.0;
};

class EkfEstimator : public GaussianMapView {
 public:
  Pose2 pose() const final { return x_.head<3>(); }  // the vehicle's estimate is always current
  std::size_t state_dim() const { return dim_; }
  std::size_t num_landmarks() const { return landmark_offsets_.size(); }
  virtual Matrix2 landmark_covariance(std::size_t index) const = 0;
  /// landmark_position and landmark_covariance of every landmark, in map order, into `means` and
  /// `covariances` (resized): the whole map at once, as the runner reads it every second.
  virtual void landmark_marginals(std::vector<Vector2>& means, std::vector<Matrix2>& covariances) const;
  /// The whole state vector (a copy).
  virtual Eigen::VectorXd state() const = 0;
  /// The full symmetric covariance (a copy: O(n^2); for tests and exports, not for the hot path).
  virtual Eigen::MatrixXd covariance() const = 0;
  /// Predicted measurement and innovation covariance S of landmark `index` (for gating): the
  /// update's, so that the gate judges what the update will do.
  virtual void innovation(std::size_t index, Measurement& zhat, MeasurementCovariance& s) const;
  /// The observation model's prediction, its range read through the estimated calibration.
  Measurement predicted_measurement(const Pose2& x, const Vector2& m) const;

  /// Estimates the range sensor's offset b and scale error s (it reads (1 + s) d + b for a distance
  /// d, RangeCorrection) as state variables, from independent Gaussian priors: radio beacons read
  /// long by metres. Only before the first landmark. Throws std::invalid_argument for a model
  /// without a range, a prior that is not finite with positive deviations, or an estimator that does
  /// not keep them (supports_range_calibration).
  void estimate_range_calibration(const RangeCalibrationPrior& prior);
  bool calibrates_ranges() const { return parameters_ > 0; }
  /// The calibration's estimate (zeros where it is not estimated), and its 2x2 covariance over
  /// (offset, scale error).
  RangeCorrection range_correction() const;
  Matrix2 range_correction_covariance() const;

  /// Eqs. (8)-(9): the time update with control u over dt.
  virtual void predict(const Control& u, double dt) = 0;
  /// Adds q to the vehicle's covariance: process noise the motion model did not allow for.
  virtual void inflate_pose(const Matrix3& q) = 0;
  /// Eqs. (10)-(11) for one observation of a landmark. Returns false (and changes nothing) if the
  /// innovation covariance is not positive definite.
  virtual bool update_landmark(const LandmarkObservation& observation) = 0;
  /// The same for observation z of the landmark at map index `index`, with the model's R.
  bool update_landmark(std::size_t index, const Measurement& z) { return update_landmark({index, z}); }
  /// Eqs. (10)-(11) for observations of distinct landmarks, stacked into one innovation. Returns
  /// false (and changes nothing) if the innovation covariance is not positive definite.
  virtual bool update_landmarks(std::span<const LandmarkObservation> batch) = 0;
  /// Appends `landmark` (its correlations all through the vehicle's); returns its map index.
  virtual std::size_t add_landmark(const InitialLandmark& landmark) = 0;
  /// Appends the landmark seen as z from the current pose, with its full cross-covariances; returns
  /// its map index. Throws std::logic_error if the observation model cannot invert z.
  virtual std::size_t add_landmark(const Measurement& z);
  /// Whether this estimator keeps inverse-distance landmarks (add_inverse_distance_landmark).
  virtual bool keeps_inverse_distance() const { return false; }
  /// Appends the landmark first seen as bearing z from the current pose as an inverse-distance
  /// point (models/inverse_distance.hpp), which the estimator converts to a point once its distance
  /// is known well enough; returns its map index. Throws std::logic_error where the estimator does
  /// not keep them.
  virtual std::size_t add_inverse_distance_landmark(const Measurement& z, const InverseDistanceOptions& options);
  /// Whether landmark `index` is still held as an inverse-distance point. Its landmark_position and
  /// covariances answer for the point it stands for; state() and covariance() hold its four rows
  /// (theta, rho, origin).
  virtual bool at_inverse_distance(std::size_t /*index*/) const { return false; }
  /// Whether landmark `index`, at inverse distance, is seen from so far off its origin, its distance
  /// still so uncertain, that a bearing is no longer near linear in rho
  /// (kInverseDistanceMaxBearingSpread): an update would then place it by a linearisation that
  /// stands for none of the distances it allows.
  virtual bool beyond_linear_reach(std::size_t /*index*/) const { return false; }
  /// Takes landmark `index` out of the state: its rows and columns leave the covariance, and the
  /// landmarks after it move down one index. O(n^2).
  virtual void remove_landmark(std::size_t index) = 0;
  /// Conditions the state on each pair being one landmark (m_duplicate = m_original, a linear
  /// measurement without noise, all pairs jointly), so that the duplicate can then be removed. Returns
  /// false (and changes nothing) if the discrepancies' joint covariance is not positive definite.
  virtual bool fuse_landmarks(std::span<const LandmarkPair> pairs) = 0;
  /// Called before each scan's updates (CompressedJointGaussian: a new local area when the vehicle
  /// has left the last one).
  virtual void begin_scan() {}
  /// Called with the landmarks association is about to ask about (their covariances, with the
  /// vehicle's and with each other), so that an estimator that recovers covariances can recover them
  /// together (InformationFormEstimator's local recovery: one Markov blanket for all of them).
  virtual void prepare_covariances(std::span<const std::size_t> /*landmarks*/) const {}
  /// The information matrix, for an estimator that keeps one (InformationFormEstimator), as its
  /// picture shows it.
  virtual std::vector<InformationMatrixPanel> information_panels() const { return {}; }
  /// Adds the implementation's own figures to a filter's statistics.
  virtual void add_statistics(std::map<std::string, double>& /*statistics*/) const {}

  /// Shares the covariance's O(n^2) passes out over `threads` threads, the calling one included (1:
  /// none, 0: every core). Each covariance entry is computed the same way on any thread, so the
  /// estimate is the same bit for bit whatever the number.
  void use_threads(unsigned threads);
  unsigned threads() const { return pool_.pool ? pool_.pool->size() : 1; }

  const MotionModel& motion_model() const { return *motion_; }
  const ObservationModel& observation_model() const { return *observation_; }
  const std::shared_ptr<const ObservationModel>& shared_observation_model() const { return observation_; }

 protected:
  /// Throws std::invalid_argument for a missing model.
  EkfEstimator(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
               const Pose2& initial_pose);

  /// Where the range calibration is kept, between the vehicle and the map (static, as a landmark is).
  static constexpr Eigen::Index kOffsetRow = 3, kScaleRow = 4;
  /// Whether this estimator's updates carry a range calibration (JointGaussian's do).
  virtual bool supports_range_calibration() const { return false; }
  /// The first landmark's row: after the vehicle and the calibration, if estimated.
  std::size_t map_offset() const { return 3 + parameters_; }
  std::size_t landmark_offset(std::size_t index) const { return landmark_offsets_[index]; }
  /// The number of state rows landmark `index` holds.
  std::size_t landmark_rows(std::size_t index) const {
    return (index + 1 < landmark_offsets_.size() ? landmark_offsets_[index + 1] : dim_) - landmark_offsets_[index];
  }
  /// Registers a landmark whose `rows` rows the caller has written at the end of the state (room
  /// reserved), and grows the state by them.
  void append_landmark_rows(std::size_t rows) {
    landmark_offsets_.push_back(dim_);
    dim_ += rows;
  }
  /// The measurement row the calibration applies to, or -1 where it is not estimated.
  int calibrated_row() const { return calibrates_ranges() ? observation_->rows().range : -1; }
  /// The calibration at the state `at` applied to a prediction and its Jacobians at a distance:
  /// range (1 + s) d + b, its pose and landmark rows times (1 + s). Returns d, the range's
  /// derivative in s (its derivative in b is 1).
  template <int D>
  double calibrate(const Eigen::VectorXd& at, Measurement& zhat, PoseRows<D>& hx, LandmarkRows<D>& hm) const {
    const int row = calibrated_row();
    const double distance = zhat[row], scale = 1.0 + at[kScaleRow];
    zhat[row] = scale * distance + at[kOffsetRow];
    hx.row(row) *= scale;
    hm.row(row) *= scale;
    return distance;
  }
  /// The calibration's covariances, read only where it is estimated (so by the estimators that
  /// support it): P(calibration), P(calibration, vehicle) as current as pose_covariance, and
  /// P(landmark `index`, calibration).
  virtual Matrix2 calibration_covariance() const { return Matrix2::Zero(); }
  virtual Matrix23 calibration_pose_covariance() const { return Matrix23::Zero(); }
  virtual Matrix2 landmark_calibration_covariance(std::size_t /*index*/) const { return Matrix2::Zero(); }
  /// Writes the calibration prior's covariance (uncorrelated with the vehicle) where the estimator
  /// keeps its uncertainty; called with the calibration's rows appended, before dim_ counts them.
  virtual void store_calibration_prior(const Matrix2& /*covariance*/) {}
  /// Makes room for a state of dimension `dim`, growing the buffers by a quarter at least.
  virtual void reserve(std::size_t dim);
  /// Squeezes landmark `index`'s rows out of the stored state, in place.
  void remove_stored_landmark(std::size_t index);
  /// Squeezes `count` rows from `first` (inside the map) out of the stored state, in place; the
  /// landmarks whose rows lie after them move up.
  void remove_stored_rows(std::size_t first, std::size_t count);
  /// The part of remove_stored_rows that the implementation's own storage needs (dim_ still counts
  /// the rows).
  virtual void squeeze_stored_rows(std::size_t /*first*/, std::size_t /*count*/) {}

  std::shared_ptr<const MotionModel> motion_;
  std::shared_ptr<const ObservationModel> observation_;
  std::size_t dim_ = 3;
  std::size_t parameters_ = 0;  // state rows between the vehicle and the map (the range calibration: 0 or 2)
  std::vector<std::size_t> landmark_offsets_;  // by map index: the landmark's first state row
  Eigen::VectorXd x_;
  /// The threads of use_threads (null: one); a copy of the estimator gets a pool of its own.
  struct OwnPool {
    std::unique_ptr<WorkerPool> pool;
    OwnPool() = default;
    OwnPool(const OwnPool& other) : pool(other.pool ? std::make_unique<WorkerPool>(other.pool->size()) : nullptr) {}
    OwnPool& operator=(const OwnPool& other) {
      if (this != &other) pool = other.pool ? std::make_unique<WorkerPool>(other.pool->size()) : nullptr;
      return *this;
    }
    OwnPool(OwnPool&&) = default;
    OwnPool& operator=(OwnPool&&) = default;
  } pool_;
};

}  // namespace slamkit
