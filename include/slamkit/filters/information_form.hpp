#pragma once
// What the information-form estimators share (ExtendedInformationFilter, exact;
// SparseExtendedInformationFilter, sparse by approximation): the information matrix Omega = P^-1
// over the state's rows, stored by blocks (InformationGraph), the vehicle's motion since Omega was
// last brought up to date, and the covariances the gates and the runner read.
//
// Time update: the controls between two scans are composed into one motion of the vehicle,
// x_v -> F x_v + c with noise Q (F = F_k ... F_1, c the linearisation's offset), as the dense EKF
// defers P_mv F^T. It is folded into Omega only when an update needs it: with Psi = A^-T Omega A^-1,
// A = diag(F, I), the Woodbury identity gives Omega' = Psi - Psi(:, v) (I + Q Psi_vv)^-1 Q Psi(v, :),
// which Q may be singular in (a two-input vehicle's Q has rank 2). Psi(:, v) is non-zero on the
// vehicle and the landmarks linked to it only, so the fold touches those blocks only. Until then the
// covariances read are the last ones recovered, carried through the pending motion as the EKF
// carries them.
//
// Covariances, recovered one of two ways (CovarianceRecovery) and kept until Omega changes:
//  * exact: columns of Omega^-1 solved for on request (InformationFactor: Eigen's SimplicialLLT in
//    an AMD order of the graph's blocks, reused while Omega's pattern is unchanged); a solve costs
//    what the whole map's factor costs;
//  * local: Omega restricted to the variables asked about and their neighbours in the graph (their
//    Markov blanket), inverted as a dense block: the rest of the map conditioned at its mean, as
//    Thrun et al. recover SEIF's covariances. It costs the same however large the map, and is
//    overconfident by what the conditioning leaves out.
//
// Linearisation (InformationLinearisation): at the estimate, as the EKF, or by first estimates, as
// the FEJ-EKF (filters/joint_gaussian.hpp): the motion Jacobian between the poses predicted for two
// steps, an observation's at the predicted pose and the landmark's first estimate, so that the
// linearised system leaves the global translation and turn unobserved as the true one does. The
// canonical form takes them as the EKF does: Omega += H^T R^-1 H and the information vector moves by
// H^T R^-1 (nu + H mu). A first estimate the belief rules out is moved as the FEJ-EKF moves it, and
// Omega carried to the moved linearisation's coordinates: with M = I + u e_theta^T (u = J (m - m_fe)
// in the landmark's rows), P -> M P M^T is Omega -> M^-T Omega M^-1, M^-1 = I - u e_theta^T, which
// changes the vehicle's heading row by Omega(:, landmark) u: the vehicle becomes linked to the
// landmark's neighbours. The mean does not move, so the information vector becomes Omega' mu.
// With update_iterations > 1 the scan's measurement is relinearised at the iterated EKF's iterates
// first (Gauss-Newton with the prior's marginal covariance over the vehicle and the observed
// landmarks, the only rows an iterate reads, recovered as the gates' are), and the update is then
// made about the last iterate: the mean's nu becomes z - h(x_i) + H (x_i - mu). First estimates keep
// their own Jacobians for that update, as the iterated FEJ-EKF does.
//
// The information form cannot hold a pose that is known exactly, as the map frame's start pose is by
// default: a singular initial covariance gets kInitialPoseFloor added on its diagonal (1 mm, 1 mrad),
// so give the EKF the same prior to compare with it.
#include <Eigen/SparseCore>
#include <optional>
#include <unordered_map>
#include <vector>

#include "slamkit/filters/ekf_estimator.hpp"
#include "slamkit/filters/information_factor.hpp"
#include "slamkit/filters/information_graph.hpp"

namespace slamkit {

enum class CovarianceRecovery { kExact, kLocal };

/// How an information-form estimator linearises (the file's comment).
struct InformationLinearisation {
  /// kStandard or kFirstEstimates; the invariant error has no information form here.
  Linearisation linearisation = Linearisation::kStandard;
  /// Linearisations per scan, the next at the last's result until it stops moving (the iterated
  /// EKF); 1 is the EKF's single one.
  int update_iterations = 1;
};

class InformationFormEstimator : public EkfEstimator {
 public:
  /// The variance added to each diagonal entry of an initial pose's or a new landmark's covariance
  /// that is not positive definite (m^2, m^2, rad^2).
  static constexpr double kInitialPoseFloor = 1e-6;

  Matrix3 pose_covariance() const override;
  Vector2 landmark_position(std::size_t index) const override;
  Matrix2 landmark_covariance(std::size_t index) const override;
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override;
  Matrix23 landmark_pose_covariance(std::size_t index) const override;
  /// Local: the covariances of the vehicle and `landmarks` from one Markov blanket, kept for the
  /// reads that follow until Omega changes.
  void prepare_covariances(std::span<const std::size_t> landmarks) const override;
  /// Exact: one factorisation, and a solve for each landmark's two columns.
  void landmark_marginals(std::vector<Vector2>& means, std::vector<Matrix2>& covariances) const override;
  Eigen::VectorXd state() const override;
  /// Omega^-1 with the pending motion applied (a dense inverse, exact whatever the recovery: for tests
  /// and exports).
  Eigen::MatrixXd covariance() const override;
  /// The information matrix over state(), the pending motion applied (both triangles stored).
  Eigen::SparseMatrix<double> information() const { return folded_information().to_sparse(); }
  /// information(), the one panel of an exact filter.
  std::vector<InformationMatrixPanel> information_panels() const override;

  void predict(const Control& u, double dt) override;
  void inflate_pose(const Matrix3& q) override;
  using EkfEstimator::update_landmark;
  /// A batch of one: an information-form update costs what its linearisation and solve cost, however
  /// many observations it holds.
  bool update_landmark(const LandmarkObservation& observation) override {
    return update_landmarks(std::span<const LandmarkObservation>(&observation, 1));
  }
  /// information_nonzeros (of Omega, both triangles), information_factorisations and
  /// information_local_recoveries; with first estimates, first_estimates_moved.
  void add_statistics(std::map<std::string, double>& statistics) const override;

 protected:
  using Sparse = Eigen::SparseMatrix<double>;
  using Triplets = std::vector<Eigen::Triplet<double>>;

  /// Throws std::invalid_argument for a missing model, an initial covariance that is not finite, or
  /// a linearisation it does not have.
  InformationFormEstimator(std::shared_ptr<const MotionModel> motion,
                           std::shared_ptr<const ObservationModel> observation, const Pose2& initial_pose,
                           const Matrix3& initial_covariance, CovarianceRecovery recovery,
                           const InformationLinearisation& linearisation);

  /// The vehicle's motion folded into Omega: Psi(:, v) of the file's comment over the variables it
  /// is non-zero on (the vehicle and the landmarks linked to it), the gain K = (I + Q Psi_vv)^-1 Q,
  /// and the motion (F, c) itself.
  struct FoldedMotion {
    InformationGraph::Variables linked;
    Eigen::MatrixXd psi_columns;
    Matrix3 gain;
    Matrix3 f;
    Eigen::Vector3d offset;
  };
  /// Omega's graph with the pending motion folded in.
  InformationGraph folded_information() const;
  /// Whether controls came since Omega was last brought up to date.
  bool motion_pending() const;
  /// Folds the pending motion into Omega (nothing if there is none); calls motion_folded.
  void apply_pending_motion();
  /// What an estimator that keeps more than Omega does when a motion is folded in (Omega already
  /// updated).
  virtual void motion_folded(const FoldedMotion& /*motion*/) {}
  /// Drops what was derived from Omega: call after changing graph_.
  void information_changed();
  /// The Cholesky factor of Omega, computed on first use after a change; false if it failed.
  bool factorise() const;
  /// Whether the exact recovery has factorised Omega as it stands (for the gates, say), so that a
  /// solve costs two triangular passes.
  bool factorised_for_covariances() const { return recovery_ == CovarianceRecovery::kExact && factorised_; }
  /// Makes `omega` the information matrix if it factorises (then factorised); otherwise keeps the
  /// present one and returns false.
  bool replace_information(InformationGraph omega);
  /// Omega^-1 b (the factorisation current).
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const { return factor_.solve(b); }
  /// First estimates: moves the first estimate of each landmark in `batch` that the belief rules out
  /// to its estimate, carrying Omega and, if given, the information vector `vector` (over the
  /// state's rows) along (the file's comment). Returns whether one moved. Call before
  /// linearisation_point.
  bool move_implausible_anchors(std::span<const LandmarkObservation> batch, Eigen::VectorXd* vector);
  /// Where a scan's measurement is linearised: the vehicle and each observed landmark.
  struct LinearisationPoint {
    Pose2 vehicle;
    std::unordered_map<std::size_t, Vector2> landmarks;  // by map index
  };
  /// The observation Jacobians an update uses for landmark `index` linearised at (vehicle,
  /// landmark): there, or at first estimates.
  void update_jacobians(std::size_t index, const Pose2& vehicle, const Vector2& landmark, PoseJacobian& hx,
                        LandmarkJacobian& hm) const;
  /// The estimate, or with update_iterations > 1 the iterated EKF's last iterate for `batch`.
  LinearisationPoint linearisation_point(std::span<const LandmarkObservation> batch) const;
  /// Applies the pending motion, then adds H^T R^-1 H of `batch` (each observation linearised at
  /// `at`, which holds its landmarks) into Omega, and H^T R^-1 nu, or with `about_estimate`
  /// H^T R^-1 (nu + H mu), into `vector` (over the state's rows): the linearised measurement's share
  /// of the information vector, nu = z - h(at) + H (at - mu).
  void add_linearised_information(std::span<const LandmarkObservation> batch, bool about_estimate,
                                  Eigen::VectorXd& vector, const LinearisationPoint& at);
  /// The information vector of a landmark factor, by block.
  struct FactorVector {
    Eigen::Vector3d vehicle;
    Vector2 landmark;
  };
  /// Applies the pending motion, then appends the landmark as the factor m = Gx x_v + c + w: Omega
  /// grows by [-Gx I]^T L [-Gx I] over (vehicle, landmark), L the inverse of its covariance given the
  /// pose, and the mean by its position. Returns the factor's information vector [-Gx I]^T L c.
  FactorVector append_landmark_factor(const InitialLandmark& landmark);
  /// Marginalises `variable` (the vehicle, or one landmark) out of Omega and, if given, out of the
  /// information vector `vector` over the state's rows: the Schur complement over its neighbours.
  /// It is left without edges, its own block and rows of `vector` as they were (a landmark until
  /// remove_stored_landmark takes its rows).
  void marginalise(const InformationGraph::Variables& variable, Eigen::VectorXd* vector = nullptr);
  /// The rows of `vector` (over the state's rows) that `variables` hold, in the block's row order.
  Eigen::VectorXd rows_of(const InformationGraph::Variables& variables, const Eigen::VectorXd& vector) const;
  /// vector (over the state's rows) += change (over `variables`' block rows).
  void add_to_rows(const InformationGraph::Variables& variables, const Eigen::VectorXd& change,
                   Eigen::VectorXd& vector) const;
  /// The change of variables that fuses `pairs`: x = T y, with each duplicate's rows of y holding
  /// e = m_duplicate - m_original; `duplicate_row` marks those rows.
  Sparse fusion_transform(std::span<const LandmarkPair> pairs, std::vector<char>& duplicate_row) const;
  /// `omega` (in the fused variables) conditioned on every e = 0: e's couplings dropped, each e held
  /// as an independent unit block until the duplicate is removed.
  static Sparse conditioned_on_fusion(Sparse omega, const std::vector<char>& duplicate_row);
  void squeeze_stored_rows(std::size_t first, std::size_t count) override;

  /// A covariance symmetrised, with kInitialPoseFloor added on its diagonal if it is not positive
  /// definite by that much (the information form's floor for what a covariance says is exact).
  template <int N>
  static Eigen::Matrix<double, N, N> floored(const Eigen::Matrix<double, N, N>& covariance);
  /// The inverse of a symmetric positive definite block; throws std::logic_error naming `what` if it
  /// is not.
  static Eigen::MatrixXd spd_inverse(const Eigen::MatrixXd& m, const char* what);

  InformationGraph graph_;
  // The controls since Omega was last brought up to date: the vehicle moved to F x_v + c, with
  // noise Q.
  Matrix3 pending_f_ = Matrix3::Identity();
  Matrix3 pending_q_ = Matrix3::Zero();
  Eigen::Vector3d pending_offset_ = Eigen::Vector3d::Zero();

 private:
  using Joint = Eigen::Matrix<double, 5, 5>;  // over (vehicle, one landmark)
  /// `graph` with a motion (F, Q) of the vehicle folded in (the Woodbury form in the file's comment).
  static FoldedMotion fold(InformationGraph& graph, const Matrix3& f, const Matrix3& q);
  /// Columns of Omega^-1 from `first`, `count` of them (the factorisation current).
  Eigen::MatrixXd covariance_columns(std::size_t first, std::size_t count) const;
  /// Omega^-1 (:, vehicle), exact, before the pending motion; cached until Omega changes.
  const Eigen::MatrixXd& vehicle_columns() const;
  /// Omega^-1 (:, landmark `index`), exact; cached until Omega changes.
  const Eigen::MatrixXd& landmark_columns(std::size_t index) const;
  /// The covariance of `variables` from Omega over them and their neighbours (local recovery).
  Eigen::MatrixXd local_covariance(const InformationGraph::Variables& variables) const;
  /// The local covariance of (vehicle, landmark `index`); cached until Omega changes.
  const Joint& local_joint(std::size_t index) const;
  /// The vehicle's covariance before the pending motion, by the estimator's recovery.
  Matrix3 vehicle_marginal() const;

  CovarianceRecovery recovery_;
  InformationLinearisation linearisation_;
  Pose2 predicted_pose_;                 // first estimates: the pose the last control predicted
  std::vector<Vector2> first_estimates_;  // first estimates: by map index
  std::size_t anchors_moved_ = 0;
  mutable InformationFactor factor_;
  mutable bool factorised_ = false;
  mutable std::size_t factorisations_ = 0, local_recoveries_ = 0;
  mutable Eigen::MatrixXd vehicle_columns_;  // empty when out of date
  mutable std::unordered_map<std::size_t, Eigen::MatrixXd> landmark_columns_;  // by map index
  mutable std::optional<Matrix3> local_vehicle_;
  mutable std::unordered_map<std::size_t, Joint> local_joints_;  // by map index
  // prepare_covariances's joint covariance over (vehicle, its landmarks), and where each landmark's
  // rows are in it (by map index).
  mutable Eigen::MatrixXd prepared_;
  mutable std::unordered_map<std::size_t, Eigen::Index> prepared_rows_;
};

}  // namespace slamkit
