#pragma once
// UKF-SLAM: the joint Gaussian of EKF-SLAM (same storage, same joint scan update) with every
// linearisation replaced by the unscented transform, so no model Jacobian is used.
//
// Cost stays quadratic in the map (Huang, Mourikis and Roumeliotis, T-RO 2013): sigma points are
// drawn only over the part of the state a step's functions read, the rest of the map following
// through its cross-covariances. With s that part and y = f(s), the transform gives y's mean and
// covariance and the statistical linearisation A = P_ys P_ss^+; then P(rest, y) = P(rest, s) A^T,
// exact for the Gaussian regression of y on s. In detail:
//  * time update: sigma points over the vehicle and the control noise; A takes the place of the
//    motion Jacobian in the map-vehicle cross-covariance (applied lazily, as in JointGaussian);
//  * observation update: sigma points over the vehicle and the landmarks the scan observes;
//    P H^T becomes P(:, s) A^T, S the transformed covariance plus R, and the scan is one joint
//    update (one rank-2k downdate), as in JointGaussian;
//  * new landmarks: sigma points over the vehicle and the measurement noise, through the inverse
//    observation model.
// The sigma points are the symmetric set of 2r points at +-sqrt(min(r, 3)) times the columns of a
// square root of the covariance: its Cholesky factor, or for a singular covariance (the start pose
// is known exactly) its r eigen-directions of non-zero variance.
#include "slamkit/filters/joint_gaussian.hpp"

namespace slamkit {

class UnscentedJointGaussian final : public JointGaussian {
 public:
  UnscentedJointGaussian(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
                         const Pose2& initial_pose = Pose2::Zero(), const Matrix3& initial_covariance = Matrix3::Zero());

  void predict(const Control& u, double dt) override;
  bool update_landmark(std::size_t index, const Vector2& z) override;
  /// One joint innovation for the batch (observations of distinct landmarks), sigma points over the
  /// vehicle and those landmarks.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  std::size_t add_landmark(const Vector2& z) override;

 private:
  // The observation update's sub-state, reused per scan.
  Eigen::VectorXd sub_mean_;
  Eigen::MatrixXd sub_covariance_, gain_basis_;
  std::vector<std::size_t> sub_offsets_;  // state offset of each block of the sub-state
};

}  // namespace slamkit
