#pragma once
// The EKF-SLAM estimator that updates the whole joint covariance at every step.
//
// Cost: a time update is O(1) per control: the vehicle block is updated at once, while the
// map-vehicle cross-covariance P_mv F^T takes the product of the controls' Jacobians since the last
// update once, O(n), before the next operation that needs it (accessors apply it on the fly). An
// observation update is O(n^2) with the constant of one symmetric rank-2 downdate, because the
// observation Jacobian has non-zeros only in the vehicle's 3 and the landmark's 2 columns; a joint
// update of k observations is one symmetric rank-2k downdate, a single pass over the lower triangle.
#include <vector>

#include "slamkit/filters/ekf_estimator.hpp"

namespace slamkit {

class JointGaussian final : public EkfEstimator {
 public:
  /// The vehicle at `initial_pose` with `initial_covariance` (the map frame is defined by the start
  /// pose, so by default it is known exactly), and no landmarks.
  JointGaussian(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
                const Pose2& initial_pose = Pose2::Zero(), const Matrix3& initial_covariance = Matrix3::Zero());

  Matrix3 pose_covariance() const override { return diagonal_block<3>(0); }
  Vector2 landmark_position(std::size_t index) const override;
  Matrix2 landmark_covariance(std::size_t index) const override;
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override;
  Matrix23 landmark_pose_covariance(std::size_t index) const override;
  Eigen::VectorXd state() const override;
  Eigen::MatrixXd covariance() const override;

  void predict(const Control& u, double dt) override;
  bool update_landmark(std::size_t index, const Vector2& z) override;
  /// One joint innovation for the batch; equal to the sequential updates for linear models, and for
  /// nonlinear ones every observation is linearised at the prior, as in eqs. (10)-(11) with z_k the
  /// whole batch.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  std::size_t add_landmark(const Vector2& z) override;
  void remove_landmark(std::size_t index) override;

 private:
  /// Brings the stored map-vehicle cross-covariance up to date with the controls since (see predict).
  void apply_pending_motion();
  /// Fills `out` (dim_ x 2) with P H^T for an observation Jacobian with blocks hx (vehicle) and hm
  /// (landmark).
  void covariance_times_jacobian(std::size_t lm_offset, const Matrix23& hx, const Matrix2& hm,
                                 Eigen::Ref<Eigen::MatrixX2d> out) const;

  /// Product of the motion Jacobians not yet applied to the stored P_mv: P_mv = stored * pending^T.
  Matrix3 pending_motion_ = Matrix3::Identity();
  // The joint update's other terms, sized for the largest batch so far.
  std::vector<Matrix23> batch_hx_;
  std::vector<Matrix2> batch_hm_;
  Eigen::VectorXd batch_nu_;
  Eigen::MatrixXd batch_s_;
};

}  // namespace slamkit
