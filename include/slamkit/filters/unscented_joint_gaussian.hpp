#pragma once
// UKF-SLAM: the joint Gaussian of EKF-SLAM (same storage, same joint scan update) with every
// linearisation replaced by the unscented transform, so no model Jacobian is used.
//
// Cost stays quadratic in the map (Huang, Mourikis and Roumeliotis, T-RO 2013): sigma points are
// drawn only over the part of the state a step's functions read, the rest of the map following
// through its cross-covariances. With s that part and y = f(s), the transform gives y's mean and
// covariance and the statistical linearisation A = P_ys P_ss^+; then P(rest, y) = P(rest, s) A^T,
// exact for the Gaussian regression of y on s. In detail:
//  * time update: sigma points over the vehicle and the control noise (UkfNoise::kAugmented), or
//    over the vehicle with the control noise's spread added after (kAdditive, below); A takes the
//    place of the motion Jacobian in the map-vehicle cross-covariance (applied lazily, as in
//    JointGaussian);
//  * observation update: sigma points over the vehicle and the landmarks the scan observes;
//    P H^T becomes P(:, s) A^T, S the transformed covariance plus R, and the scan is one joint
//    update (one rank-2k downdate), as in JointGaussian;
//  * new landmarks: sigma points over the vehicle and the measurement noise, through the inverse
//    observation model.
// The sigma points are the symmetric set of 2r points at +-sqrt(min(r, 3)) times the columns of a
// square root of the covariance: its Cholesky factor, or for a singular covariance (the start pose
// is known exactly) its r eigen-directions of non-zero variance.
#include <vector>

#include "slamkit/filters/joint_gaussian.hpp"

namespace slamkit {

/// How the UKF's time update treats the control noise.
enum class UkfNoise {
  /// Sigma points over the vehicle and the control noise together, so the noise moves the mean by
  /// the motion's curvature as well as spreading it (e.g. a steering noise turns the car more on
  /// average, E[tan(gamma)] > tan(E[gamma])): the textbook UKF, right when the noise is the
  /// controls' real error.
  kAugmented,
  /// Sigma points over the vehicle only; the control noise's spread at the mean pose, taken by its
  /// own unscented transform as the second moment about f(x, u), is added as zero-mean process
  /// noise. For a noise that is an allowance for model error (inflated to keep a filter
  /// consistent, as on Victoria Park), whose curvature term would be a bias, not a correction.
  kAdditive,
};

class UnscentedJointGaussian final : public JointGaussian {
 public:
  UnscentedJointGaussian(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
                         const Pose2& initial_pose = Pose2::Zero(), const Matrix3& initial_covariance = Matrix3::Zero(),
                         UkfNoise noise = UkfNoise::kAugmented);

  void predict(const Control& u, double dt) override;
  using EkfEstimator::update_landmark;
  bool update_landmark(const LandmarkObservation& observation) override;
  /// One joint innovation for the batch (observations of distinct landmarks), sigma points over the
  /// vehicle and those landmarks.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  using JointGaussian::add_landmark;
  /// Sigma points over the vehicle and the measurement noise, through the model's inverse.
  std::size_t add_landmark(const Measurement& z) override;
  /// Its sigma points pass through the model at point landmarks.
  bool keeps_inverse_distance() const override { return false; }

 private:
  // Its sigma points carry the vehicle and the landmarks only.
  bool supports_range_calibration() const override { return false; }

  /// Buffers of one kind of unscented transform (time update, its control noise apart when additive,
  /// scan update, new landmark), kept per kind so that a step reallocates nothing unless its sizes
  /// change (a scan of another size).
  struct Transform {
    Eigen::MatrixXd factor;           // the covariance, then its Cholesky factor (lower triangle)
    Eigen::MatrixXd offsets;          // the sigma points less the mean, as columns (d x r)
    Eigen::MatrixXd inverse_offsets;  // their pseudo-inverse (r x d), where they are not triangular
    double weight = 0.0;              // of each of the 2r points
    bool triangular = false;          // offsets from the Cholesky factor: column j is zero above row j
    Eigen::VectorXd point, centre, shift;
    Eigen::MatrixXd images;  // the points' images less the centre's, + then - (m x 2r)
    // The result: y's mean (angular entries not wrapped) and covariance, and the statistical
    // linearisation P_ys P_ss^+ (the Jacobian, for a linear f).
    Eigen::VectorXd mean;
    Eigen::MatrixXd covariance, linearisation;
  };

  /// The sigma points of N(., cov) into t.offsets, t.weight, t.triangular and, for offsets that are
  /// not triangular, t.inverse_offsets.
  static void sigma_points(Transform& t, const Eigen::MatrixXd& cov);
  /// The unscented transform of y = f(s), s ~ N(mean, cov), into t.mean, t.covariance and
  /// t.linearisation. image(s, first_moved, column, y) writes f(s) into y, the images' column `column`
  /// (-1: the mean's), which holds f(mean) on entry; the rows of s before first_moved equal the
  /// mean's, so entries of f that read only those may be left. subtract(y, c, first_moved) makes y the difference y - c, angular entries wrapped, so that
  /// sigma points straddling +-pi average correctly (entries image left at c are exactly zero).
  template <class Image, class Subtract>
  static void unscented(Transform& t, const Eigen::VectorXd& mean, const Eigen::MatrixXd& cov, Eigen::Index m,
                        Image image, Subtract subtract);

  UkfNoise noise_;
  Transform motion_transform_, noise_transform_, scan_transform_, landmark_transform_;
  // The time update's sigma points' Gaussians: [vehicle, control noise] or the vehicle, and the
  // control (kAdditive).
  Eigen::VectorXd motion_mean_, control_mean_;
  Eigen::MatrixXd motion_covariance_, control_covariance_;
  // The observation update's sub-state, reused per scan.
  Eigen::VectorXd sub_mean_;
  Eigen::MatrixXd sub_covariance_, sub_columns_;  // P(s, s) and P(:, s)
  std::vector<std::size_t> sub_offsets_;  // state offset of each block of the sub-state
  std::vector<Eigen::Index> sub_at_;      // where each observation's landmark sits in the sub-state
  // The observed landmarks of a sigma point that moves the vehicle, and their predictions; for all
  // the points that leave the vehicle at the mean, the landmarks they move, their predictions and
  // where each image column's start.
  std::vector<Vector2> moved_landmarks_, mean_pose_landmarks_;
  std::vector<Measurement> moved_predictions_, mean_pose_predictions_;
  std::vector<std::size_t> mean_pose_first_;
};

}  // namespace slamkit
