#pragma once
// What the information-form estimators share (ExtendedInformationFilter, exact;
// SparseExtendedInformationFilter, sparse by approximation): the information matrix Omega = P^-1
// over the state's rows in Eigen's sparse storage (both triangles), the vehicle's motion since Omega
// was last brought up to date, and the covariances the gates and the runner read, recovered from a
// sparse Cholesky factorisation of Omega.
//
// Time update: the controls between two scans are composed into one motion of the vehicle,
// x_v -> F x_v + c with noise Q (F = F_k ... F_1, c the linearisation's offset), as the dense EKF
// defers P_mv F^T. It is folded into Omega only when an update needs it: with Psi = A^-T Omega A^-1,
// A = diag(F, I), the Woodbury identity gives Omega' = Psi - Psi(:, v) (I + Q Psi_vv)^-1 Q Psi(v, :),
// which Q may be singular in (a two-input vehicle's Q has rank 2). Until then the covariances read
// are the last factorisation's carried through the pending motion, as the EKF carries them.
//
// Covariances: columns of Omega^-1, solved for on request (Eigen's SimplicialLLT, AMD ordering, the
// ordering reused while Omega's pattern is unchanged) and kept until Omega changes.
//
// The information form cannot hold a pose that is known exactly, as the map frame's start pose is by
// default: a singular initial covariance gets kInitialPoseFloor added on its diagonal (1 mm, 1 mrad),
// so give the EKF the same prior to compare with it.
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <unordered_map>
#include <vector>

#include "slamkit/filters/ekf_estimator.hpp"

namespace slamkit {

class InformationFormEstimator : public EkfEstimator {
 public:
  /// The variance added to each of the pose's diagonal entries when the initial covariance is not
  /// positive definite (m^2, m^2, rad^2).
  static constexpr double kInitialPoseFloor = 1e-6;

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
  /// A batch of one: an information-form update costs what its linearisation and solve cost, however
  /// many observations it holds.
  bool update_landmark(const LandmarkObservation& observation) override {
    return update_landmarks(std::span<const LandmarkObservation>(&observation, 1));
  }
  /// information_nonzeros (of Omega, both triangles) and information_factorisations.
  void add_statistics(std::map<std::string, double>& statistics) const override;

 protected:
  using Sparse = Eigen::SparseMatrix<double>;
  using Triplets = std::vector<Eigen::Triplet<double>>;

  /// Throws std::invalid_argument for a missing model or an initial covariance that is not finite.
  InformationFormEstimator(std::shared_ptr<const MotionModel> motion,
                           std::shared_ptr<const ObservationModel> observation, const Pose2& initial_pose,
                           const Matrix3& initial_covariance);

  /// The vehicle's motion folded into Omega: Psi(:, v) of the file's comment (n x 3), the gain
  /// K = (I + Q Psi_vv)^-1 Q, and the motion (F, c) itself.
  struct FoldedMotion {
    Sparse psi_columns;
    Matrix3 gain;
    Matrix3 f;
    Eigen::Vector3d offset;
  };
  /// Folds the pending motion into omega_ (nothing if there is none); calls motion_folded.
  void apply_pending_motion();
  /// What an estimator that keeps more than Omega does when a motion is folded in (Omega already
  /// updated).
  virtual void motion_folded(const FoldedMotion& /*motion*/) {}
  /// Replaces Omega, dropping what was derived from the old one.
  void set_information(Sparse omega);
  /// Replaces Omega with one whose pattern may differ from the old one's by more than growth.
  void set_information_pattern(Sparse omega) {
    set_information(std::move(omega));
    pattern_changed_ = true;
  }
  /// The Cholesky factor of omega_, computed on first use after a change; false if it failed.
  bool factorise() const;
  /// Omega^-1 b (the factorisation current).
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const { return llt_.solve(b); }
  /// Applies the pending motion, then adds H^T R^-1 H of `batch` (each observation linearised at the
  /// estimate) into `triplets`, and returns H^T R^-1 nu, or with `about_estimate` H^T R^-1 (nu + H mu):
  /// the linearised measurement's share of the information vector.
  Eigen::VectorXd linearised_information(std::span<const LandmarkObservation> batch, bool about_estimate,
                                         Triplets& triplets);
  /// The information vector of a landmark factor, by block.
  struct FactorVector {
    Eigen::Vector3d vehicle;
    Vector2 landmark;
  };
  /// Applies the pending motion, then appends the landmark as the factor m = Gx x_v + c + w: Omega
  /// grows by [-Gx I]^T L [-Gx I] over (vehicle, landmark), L the inverse of its covariance given the
  /// pose, and the mean by its position. Returns the factor's information vector [-Gx I]^T L c.
  FactorVector append_landmark_factor(const InitialLandmark& landmark);
  /// Omega with landmark `index`'s rows marginalised out (their rows still there, to be squeezed).
  Sparse marginalised(std::size_t index) const;
  /// The change of variables that fuses `pairs`: x = T y, with each duplicate's rows of y holding
  /// e = m_duplicate - m_original; `duplicate_row` marks those rows.
  Sparse fusion_transform(std::span<const LandmarkPair> pairs, std::vector<char>& duplicate_row) const;
  /// `omega` (in the fused variables) conditioned on every e = 0: e's couplings dropped, each e held
  /// as an independent unit block until the duplicate is removed.
  static Sparse conditioned_on_fusion(Sparse omega, const std::vector<char>& duplicate_row);
  void squeeze_stored_rows(std::size_t first, std::size_t count) override;

  static void add_block(Triplets& triplets, Eigen::Index row, Eigen::Index col,
                        const Eigen::Ref<const Eigen::MatrixXd>& block);
  static Sparse from_triplets(Eigen::Index rows, Eigen::Index cols, const Triplets& triplets);
  /// The inverse of a symmetric positive definite block; throws std::logic_error naming `what` if it
  /// is not.
  static Eigen::MatrixXd spd_inverse(const Eigen::MatrixXd& m, const char* what);

  Sparse omega_;
  // The controls since omega_ was last brought up to date: the vehicle moved to F x_v + c, with
  // noise Q.
  Matrix3 pending_f_ = Matrix3::Identity();
  Matrix3 pending_q_ = Matrix3::Zero();
  Eigen::Vector3d pending_offset_ = Eigen::Vector3d::Zero();

 private:
  /// Omega with a motion (F, Q) of the vehicle folded in (the Woodbury form in the file's comment).
  static FoldedMotion fold(const Sparse& omega, const Matrix3& f, const Matrix3& q, Sparse& folded);
  /// Columns of omega_^-1 from `first`, `count` of them (the factorisation current).
  Eigen::MatrixXd covariance_columns(std::size_t first, std::size_t count) const;
  /// omega_^-1 (:, vehicle), before the pending motion; cached until omega_ changes.
  const Eigen::MatrixXd& vehicle_columns() const;
  /// omega_^-1 (:, landmark `index`); cached until omega_ changes.
  const Eigen::MatrixXd& landmark_columns(std::size_t index) const;

  mutable Eigen::SimplicialLLT<Sparse, Eigen::Lower, Eigen::AMDOrdering<int>> llt_;
  mutable bool factorised_ = false;
  mutable std::size_t factorisations_ = 0;
  // The pattern llt_'s ordering was analysed for.
  mutable bool pattern_changed_ = true;
  mutable Eigen::Index analysed_rows_ = 0, analysed_nonzeros_ = 0;
  mutable Eigen::MatrixXd vehicle_columns_;  // empty when out of date
  mutable std::unordered_map<std::size_t, Eigen::MatrixXd> landmark_columns_;  // by first state row
};

}  // namespace slamkit
