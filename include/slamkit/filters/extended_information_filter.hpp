#pragma once
// The extended information filter (EIF): EKF-SLAM's joint Gaussian held in information form, the
// information matrix Omega = P^-1 over the same state and the mean, with the same motion and
// observation models and the same linearisation points, so that on the same log it gives the EKF's
// estimate (tests/extended_information_filter_test.cpp checks it to 1e-8). It is the tutorial's third
// solution form (its ref. [43]) in exact form, and the oracle the sparse information filters are
// tested against.
//
// The steps, each an exact rewrite of the EKF's:
//  * time update: the controls between two scans are composed into one motion of the vehicle,
//    F = F_k ... F_1 and Q their accumulated noise, as the dense EKF defers P_mv F^T. It is folded
//    into Omega only when an update needs it: with Psi = A^-T Omega A^-1, A = diag(F, I), the
//    Woodbury identity gives Omega' = Psi - Psi(:, v) (I + Q Psi_vv)^-1 Q Psi(v, :), which Q may be
//    singular in (a two-input vehicle's Q has rank 2). Until then the covariances the gates read are
//    the last factorisation's, carried through the pending motion as the EKF carries them.
//  * measurement update: Omega += H^T R^-1 H, and the mean moves by Omega^-1 H^T R^-1 nu, a sparse
//    Cholesky solve (Eigen's SimplicialLLT, AMD ordering). H touches only the vehicle's and the
//    observed landmarks' columns, so the information added is local; the solve is not.
//  * new landmark: the factor m = g(x, z) + w, whose Jacobian in the state is [-Gx I] and whose
//    information is the inverse of the landmark's covariance given the pose.
//  * removal: the landmark's rows marginalised out by their Schur complement.
//  * fusion (loop closure): conditioning on m_duplicate = m_original is exact in information form by
//    a change of variables, e = m_duplicate - m_original, after which conditioning on e = 0 drops e's
//    rows; the duplicate is then held as an independent point at the original's position until
//    the filter removes it.
//
// Cost: the EIF is exact, so every landmark the vehicle saw stays linked to it and the motion update
// links them all to each other: Omega fills in, and a solve costs what the EKF's dense update costs
// and more. It is the reference form, not the fast one; the sparse information filters keep Omega
// sparse by approximation.
//
// The information form cannot hold a pose that is known exactly, as the map frame's start pose is by
// default: a singular initial covariance gets kInitialPoseFloor added on its diagonal (1 mm, 1 mrad),
// so give the EKF the same prior to compare the two.
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <unordered_map>

#include "slamkit/filters/ekf_estimator.hpp"

namespace slamkit {

class ExtendedInformationFilter final : public EkfEstimator {
 public:
  /// The variance added to each of the pose's diagonal entries when the initial covariance is not
  /// positive definite (m^2, m^2, rad^2).
  static constexpr double kInitialPoseFloor = 1e-6;

  ExtendedInformationFilter(std::shared_ptr<const MotionModel> motion,
                            std::shared_ptr<const ObservationModel> observation, const Pose2& initial_pose = Pose2::Zero(),
                            const Matrix3& initial_covariance = Matrix3::Zero());

  Matrix3 pose_covariance() const override;
  Vector2 landmark_position(std::size_t index) const override;
  Matrix2 landmark_covariance(std::size_t index) const override;
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override;
  Matrix23 landmark_pose_covariance(std::size_t index) const override;
  /// One factorisation, and a solve for each landmark's two columns.
  void landmark_marginals(std::vector<Vector2>& means, std::vector<Matrix2>& covariances) const override;
  Eigen::VectorXd state() const override;
  /// Omega^-1 with the pending motion applied (a dense inverse: for tests and exports).
  Eigen::MatrixXd covariance() const override;
  /// The information matrix over state(), the pending motion applied (both triangles stored).
  Eigen::SparseMatrix<double> information() const;

  void predict(const Control& u, double dt) override;
  void inflate_pose(const Matrix3& q) override;
  using EkfEstimator::update_landmark;
  bool update_landmark(const LandmarkObservation& observation) override;
  /// Every observation linearised at the prior, as the EKF's joint update. Returns false (and changes
  /// nothing) if the updated information matrix does not factorise.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  using EkfEstimator::add_landmark;
  std::size_t add_landmark(const InitialLandmark& landmark) override;
  void remove_landmark(std::size_t index) override;
  bool fuse_landmarks(std::span<const LandmarkPair> pairs) override;
  /// information_nonzeros (of Omega, both triangles) and information_factorisations.
  void add_statistics(std::map<std::string, double>& statistics) const override;

 protected:
  void squeeze_stored_rows(std::size_t first, std::size_t count) override;

 private:
  using Sparse = Eigen::SparseMatrix<double>;
  /// Omega with a motion (F, Q) of the vehicle folded in (the Woodbury form in the file's comment).
  static Sparse with_motion(const Sparse& omega, const Matrix3& f, const Matrix3& q);
  /// Folds the pending motion into omega_.
  void apply_pending_motion();
  /// Replaces Omega, dropping what was derived from the old one.
  void set_information(Sparse omega);
  /// The Cholesky factor of omega_, computed on first use after a change; false if it failed.
  bool factorise() const;
  /// Columns of omega_^-1 from `first`, `count` of them (the factorisation current).
  Eigen::MatrixXd covariance_columns(std::size_t first, std::size_t count) const;
  /// omega_^-1 (:, vehicle), before the pending motion; cached until omega_ changes.
  const Eigen::MatrixXd& vehicle_columns() const;
  /// omega_^-1 (:, landmark `index`); cached until omega_ changes.
  const Eigen::MatrixXd& landmark_columns(std::size_t index) const;

  Sparse omega_;
  // The controls since omega_ was last brought up to date: the vehicle moved by F with noise Q.
  Matrix3 pending_f_ = Matrix3::Identity();
  Matrix3 pending_q_ = Matrix3::Zero();
  mutable Eigen::SimplicialLLT<Sparse, Eigen::Lower, Eigen::AMDOrdering<int>> llt_;
  mutable bool factorised_ = false;
  // The pattern llt_'s ordering was analysed for.
  mutable bool pattern_changed_ = true;
  mutable Eigen::Index analysed_rows_ = 0, analysed_nonzeros_ = 0;
  mutable std::size_t factorisations_ = 0;
  mutable Eigen::MatrixXd vehicle_columns_;  // empty when out of date
  mutable std::unordered_map<std::size_t, Eigen::MatrixXd> landmark_columns_;  // by first state row
};

}  // namespace slamkit
