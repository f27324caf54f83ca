#pragma once
// The EKF-SLAM estimator that updates the whole joint covariance at every step.
//
// Cost: a time update is O(1) per control: the vehicle block is updated at once, while the
// map-vehicle cross-covariance P_mv F^T takes the product of the controls' Jacobians since the last
// update once, O(n), before the next operation that needs it (accessors apply it on the fly). An
// observation update is O(n^2) with the constant of one symmetric rank-2 downdate, because the
// observation Jacobian has non-zeros only in the vehicle's 3 and the landmark's 2 columns; a joint
// update of k observations is one symmetric downdate of rank k times the measurement's dimension, a
// single pass over the lower triangle.
//
// Linearisation: besides the standard EKF, two variants that keep EKF-SLAM consistent by giving the
// linearised system the unobservable directions of the true one (global translation and rotation),
// which the standard EKF loses because its Jacobians are evaluated at estimates that change:
//  * first-estimates Jacobians (Huang, Mourikis and Roumeliotis, ICRA 2008 / IJRR 2010): the motion
//    Jacobian links the pose predicted for a step with the pose predicted for the step before, and an
//    observation Jacobian is evaluated at the predicted pose and the landmark's first estimate, so
//    the Jacobians' products along the trajectory telescope as the true system's do. A first
//    estimate the current belief rules out is moved (below, "Moving a first estimate");
//  * the right-invariant EKF (Barrau and Bonnabel 2015): the error is that of the group SE_{1+n}(2),
//    xi = (dtheta, dp - dtheta J p, dm_i - dtheta J m_i), in which the motion Jacobian is the identity
//    and the observation Jacobian does not depend on the heading estimate. Kept in the standard
//    coordinates: the gain and the downdate are the standard ones (S is the same in both), the
//    correction is applied through the group's exponential, and the covariance is carried to the
//    corrected estimate's coordinates by a symmetric rank-2 update, one more pass per scan.
//
// Iterated update (update_iterations > 1): the scan's measurement is relinearised at the update's
// result until that stops moving, Gauss-Newton on the measurement (the iterated EKF). It matters at a
// loop closure after a long drift, where the prediction at the drifted pose is metres and degrees
// from the one at the truth: one linearisation there over- or under-corrects and leaves the filter
// overconfident. With first-estimates Jacobians the iterates use the Jacobians at each (fixed ones
// led them astray where a first estimate is poor), and the update itself the first estimates',
// about the last iterate. An iteration costs O(n k) (W = P H^T), against the one O(n^2 k) downdate at
// the end.
//
// The invariant variant iterates on the group. Its prior is X = exp(xi) X^, xi = T d with d ~ N(0, P)
// the standard error (T(x): xi_theta = d_theta, xi_p = d_p - d_theta J p), so an iterate is
// X_i = exp(T d_i) X^, in standard coordinates x_i = move(x^, d_i): heading + phi, each position
// p -> R(phi) p + V(phi) (d_p - phi J p), which is p + V(phi) d_p. At X_i the prior's invariant
// error is expressed as eps = xi - xi_i (the invariant filter's reset, exp's Jacobian at xi_i taken
// as the identity), so in standard coordinates at x_i the error is M_i (d - d_i) with
// M_i = T(x_i)^-1 T(x^) = I + u_i e_theta^T, u_i = J (p_i - p) for each position. The measurement
// linearised there, h ~ h(x_i) + H(x_i) M_i (d - d_i), gives the Gauss-Newton step
//   d_{i+1} = P H_i^T S_i^-1 (z - h(x_i) + H_i d_i),  H_i = H(x_i) M_i,  S_i = H_i P H_i^T + R,
// and at convergence the gradient of the posterior about the estimate, in the invariant error there,
// is zero. H(x_i) M_i leaves the turn of the whole scene about the origin unobserved at every
// iterate, as the invariant Jacobian does (M_i carries that direction at x^ to the one at x_i);
// with the exact chain rule instead (dmove/dd in place of M_i), the iterates gained information on
// the global heading and drifted (sparse world: ATE +18%). H_i keeps the sparsity of H (M_i only
// adds to the heading column), so an iteration costs what the standard one does, and the first
// (d_0 = 0, M_0 = I) is the single update. The last iterate's H gives the covariance of d,
// P - W S^-1 W^T; the correction d* goes through the exponential, and the covariance is carried to
// the new estimate's coordinates as in the single update.
//
// Moving a first estimate. FEJ's premise is a first estimate near the truth. A landmark first seen
// far away while the heading was poorly known can be metres off (MRCLAM Dataset1 robot 5: 4-6 m at
// ranges of 3-6 m, first seen after 50 s of dead reckoning); linearised there, later observations
// from close by correct the wrong directions, the filter turns overconfident and the known-identity
// gate ends up rejecting most observations, so the robot runs on odometry. So before a landmark's
// observation is linearised, its first estimate is tested against the current belief: when the
// anchor's position relative to the vehicle, m_fe - p, lies beyond the 99.99% region (chi-square,
// 2 dof, the known-identity gate's probability) of the belief about m - p, the landmark is anchored
// at its current estimate instead. The unobservable turn of the whole scene about the origin is, at
// the anchors, n = (J p, 1, J m_fe,1, ...); moving landmark i's anchor by d turns it into M n with
// M = I + u e_theta^T, u = J d in the landmark's rows. Carrying the covariance along, P -> M P M^T
// (an O(n) update of the landmark's rows), keeps the information about that turn what it was, so
// the moved filter is as unobservable in it as before: the same transport the invariant EKF applies
// at every correction, and the one FEJ's motion Jacobian already applies to the pose at every step
// (its predicted poses move with each update). FEJ that moved every anchor at every update would be
// the invariant EKF's linearisation with an additive correction; moved only when the first estimate
// is implausible, it keeps FEJ's Jacobians wherever their premise holds.
//
// Inverse-distance landmarks (bearing only, standard and first-estimates linearisations): a landmark
// may be held as (theta, rho) about its origin (models/inverse_distance.hpp) in four rows, (theta,
// rho, origin x, origin y), predicted through its direction from the sensor, so that its rows of H
// touch three column blocks (vehicle, parameters, origin); it is converted to its point once its
// linearity index is below the threshold, which squeezes the origin's rows out (O(n^2), once per
// landmark). The accessors answer for the point; state() and covariance() hold the stored rows.
#include <vector>

#include "slamkit/filters/dense_covariance.hpp"

namespace slamkit {

class JointGaussian : public DenseCovarianceEstimator {
 public:
  static constexpr int kMaxUpdateIterations = 100;
  /// The vehicle at `initial_pose` with `initial_covariance` (the map frame is defined by the start
  /// pose, so by default it is known exactly), and no landmarks.
  JointGaussian(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
                const Pose2& initial_pose = Pose2::Zero(), const Matrix3& initial_covariance = Matrix3::Zero(),
                Linearisation linearisation = Linearisation::kStandard, int update_iterations = 1);

  Matrix3 pose_covariance() const override { return diagonal_block<3>(0); }
  Vector2 landmark_position(std::size_t index) const override;
  Matrix2 landmark_covariance(std::size_t index) const override;
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override;
  Matrix23 landmark_pose_covariance(std::size_t index) const override;
  Eigen::VectorXd state() const override;
  Eigen::MatrixXd covariance() const override;

  void predict(const Control& u, double dt) override;
  void inflate_pose(const Matrix3& q) override;
  using EkfEstimator::update_landmark;
  bool update_landmark(const LandmarkObservation& observation) override;
  /// One joint innovation for the batch; equal to the sequential updates for linear models, and for
  /// nonlinear ones every observation is linearised at the prior, as in eqs. (10)-(11) with z_k the
  /// whole batch.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  using EkfEstimator::add_landmark;
  std::size_t add_landmark(const InitialLandmark& landmark) override;
  /// Standard and first-estimates linearisations (the invariant error is that of points). A landmark
  /// at inverse distance is linearised at its current estimate by both; the first-estimates variant
  /// anchors it at the point it converts to.
  bool keeps_inverse_distance() const override { return linearisation_ != Linearisation::kInvariant; }
  std::size_t add_inverse_distance_landmark(const Measurement& z, const InverseDistanceOptions& options) override;
  bool at_inverse_distance(std::size_t index) const override { return inverse_distance_[index]; }
  bool beyond_linear_reach(std::size_t index) const override;
  /// At inverse distance: predicted through the parameters and the origin as the update predicts,
  /// S over the vehicle's, the parameters' and the origin's rows (the point's marginals misjudge it
  /// where rho is near zero or below, and a gate that passed such a bearing let it wreck the map).
  void innovation(std::size_t index, Measurement& zhat, MeasurementCovariance& s) const override;
  /// Converts landmark `index` from inverse distance to the point it stands for now, its rows of the
  /// covariance by P(m, :) = G P(p, :) + P(origin, :), G = d position / dp: what the filter does
  /// itself once the landmark's linearity index is below the threshold. Nothing for a point.
  void convert_to_point(std::size_t index);
  void remove_landmark(std::size_t index) override;
  /// Throws std::logic_error for a pair with a landmark at inverse distance.
  bool fuse_landmarks(std::span<const LandmarkPair> pairs) override;
  /// First-estimates variant: the anchors moved so far (see "Moving a first estimate").
  void add_statistics(std::map<std::string, double>& statistics) const override;
  /// The position the first-estimates variant linearises landmark `index`'s observations at (at
  /// inverse distance: the origin's).
  Vector2 linearisation_anchor(std::size_t index) const { return first_estimates_.at(index); }

 protected:
  /// Brings the stored map-vehicle cross-covariance up to date with the controls since (see predict).
  void apply_pending_motion();
  /// Sizes the joint update's workspace for k measurement rows and returns its three parts: W (in
  /// pht_, dim_ x k), the innovation nu and S (k x k, lower triangle read).
  void reserve_joint_update(Eigen::Index k);
  /// Eqs. (10)-(11) for the k measurement rows whose W = P H^T, innovation and S the caller has
  /// written into the workspace: x += W S^-1 nu, P -= W S^-1 W^T as one symmetric rank-k downdate.
  /// Returns false (and changes nothing) if S is not positive definite.
  bool apply_joint_update(Eigen::Index k);
  /// Appends a landmark with mean `mean`, covariance `covariance` and P(m, :) = gx P(v, :), its
  /// correlations all through the vehicle's (pending motion applied, room reserved).
  void append_landmark(const Vector2& mean, const Matrix23& gx, const Matrix2& covariance);
  /// Writes two rows at state row `at` (>= dim_) as append_landmark describes, correlated with the
  /// rows before them (those after dim_ included) through the vehicle only.
  void write_rows(std::size_t at, const Vector2& mean, const Matrix23& gx, const Matrix2& covariance);

  bool supports_range_calibration() const override { return true; }
  Matrix23 calibration_pose_covariance() const override {
    return p_.block<2, 3>(kOffsetRow, 0) * pending_motion_.transpose();
  }

  /// Product of the motion Jacobians not yet applied to the stored P_mv: P_mv = stored * pending^T.

  Matrix3 pending_motion_ = Matrix3::Identity();
  Eigen::VectorXd batch_nu_;
  Eigen::MatrixXd batch_s_;

 private:
  /// update_landmark for a measurement of dimension D.
  template <int D>
  bool update_one(const LandmarkObservation& observation);
  /// update_landmarks for measurements of dimension D.
  template <int D>
  bool update_batch(std::span<const LandmarkObservation> batch);
  /// Fills `out` (dim_ x D) with P H^T for an observation Jacobian with blocks hx (vehicle), hm
  /// (landmark at lm_offset) and, for a landmark at inverse distance, horigin (its origin, the two
  /// rows after), and in row `calibrated` (none if negative) (1, distance) for the range calibration.
  template <int D>
  void covariance_times_jacobian(std::size_t lm_offset, const PoseRows<D>& hx, const LandmarkRows<D>& hm,
                                 const LandmarkRows<D>* horigin, int calibrated, double distance,
                                 Eigen::Ref<Eigen::Matrix<double, Eigen::Dynamic, D>> out) const;
  /// out += P(:, two columns from `offset`) h^T, read from the lower triangle.
  template <int D>
  void add_column_block(std::size_t offset, const LandmarkRows<D>& h,
                        Eigen::Ref<Eigen::Matrix<double, Eigen::Dynamic, D>> out) const;
  /// The observation Jacobians of landmark `index` where linearisation `how` evaluates them, the
  /// state-dependent ones at the point `at` (the estimate, or an iterate of the iterated update).
  template <int D>
  void observation_jacobians(std::size_t index, const Eigen::VectorXd& at, Linearisation how, PoseRows<D>& hx,
                             LandmarkRows<D>& hm) const;
  /// h of landmark `index` at the point `at` and its Jacobians as observation_jacobians gives them;
  /// a landmark at inverse distance is predicted through its parameters, and `horigin` set to its
  /// origin's rows (untouched for a point).
  template <int D>
  Measurement predict_linearised(std::size_t index, const Eigen::VectorXd& at, Linearisation how, PoseRows<D>& hx,
                                 LandmarkRows<D>& hm, LandmarkRows<D>& horigin) const;
  /// Landmark `index` at inverse distance as the state `at` holds it.
  InverseDistancePoint inverse_distance_point(std::size_t index, const Eigen::VectorXd& at) const {
    return {at.segment<2>(static_cast<Eigen::Index>(landmark_offset(index)) + 2)};
  }
  /// d position / d (stored rows) of landmark `index`: [I 0] for a point, [G I] at inverse distance
  /// (G = d position / d (theta, rho)).
  Eigen::Matrix<double, 2, 4> point_jacobian(std::size_t index) const;
  /// Converts each landmark of the batch that is at inverse distance to its point where its linearity
  /// index has fallen below kInverseDistanceLinearityThreshold.
  void convert_where_linear(std::span<const LandmarkObservation> batch);
  /// Fills W = P H^T, the innovation and S for the batch linearised about `at` (Jacobians as `how`
  /// evaluates them); the innovation is taken at the estimate: z - h(at) - H (x - at).
  template <int D>
  void linearise_batch(std::span<const LandmarkObservation> batch, const Eigen::VectorXd& at, Linearisation how);
  /// Adds the correction `delta` (standard coordinates) to the estimate; the invariant variant
  /// applies it through the group's exponential and carries the covariance along.
  void correct(const Eigen::Ref<const Eigen::VectorXd>& delta);
  /// First-estimates variant, before an observation of landmark `index` is linearised: anchors it at
  /// its current estimate, carrying the covariance along, when the belief rules its first estimate
  /// out. Needs the pending motion applied.
  void anchor_where_plausible(std::size_t index);

  Linearisation linearisation_;
  // Iterated update (Gauss-Newton on the scan's measurement, Bell and Cathey 1993): at most this many
  // linearisations per update; 1 is the EKF's single one. iterate_ is the current linearisation
  // point (the whole state, of which the vehicle and the observed landmarks are read).
  int update_iterations_;
  Eigen::VectorXd iterate_, iterate_step_;
  // The invariant variant's iterate as the correction d (the estimate's standard coordinates) whose
  // group exponential it is (see the file's comment); rows as iterate_.
  Eigen::VectorXd iterate_correction_;
  Eigen::MatrixXd iterate_s_;
  // First-estimates Jacobians: the pose predicted for the current step (before its update), and
  // each landmark's first estimate, by map index (at inverse distance: its origin's).
  Pose2 predicted_pose_;
  std::vector<Vector2> first_estimates_;
  std::size_t anchors_moved_ = 0;
  // By map index: whether the landmark is held at inverse distance (its origin in the two rows after
  // its parameters).
  std::vector<bool> inverse_distance_;
  std::size_t inverse_distance_held_ = 0;  // how many are
  std::size_t inverse_distance_converted_ = 0;
  // The joint update's other terms, sized for the largest batch so far.
  template <int D>
  struct BatchJacobians {
    std::vector<PoseRows<D>> hx;
    std::vector<LandmarkRows<D>> hm;
    std::vector<LandmarkRows<D>> horigin;
  };
  PerMeasurementDim<BatchJacobians> batch_jacobians_;
  std::vector<double> batch_distances_;  // each observation's distance, where ranges are calibrated
  Eigen::VectorXd transport_u_, transport_b_;  // the invariant variant's rank-2 update
};

}  // namespace slamkit
