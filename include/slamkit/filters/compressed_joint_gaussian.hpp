#pragma once
// The compressed EKF (Guivant and Nebot 2001): the same estimate as JointGaussian, with the cost of a
// step independent of the map's size while the vehicle stays inside a local area. Only the active
// part A (the vehicle and the landmarks near the area) is updated, through a dense local
// covariance; the effect on the rest B is accumulated in matrices of A's size (phi, psi, theta) and
// applied to the whole map once, when the vehicle leaves the area: an exact reorganisation of the
// same products (see src/filters/compressed_joint_gaussian.cpp for the derivation). Accessors answer
// for B on the fly, so reading never flushes. A scan's observations are applied jointly (one
// innovation, as JointGaussian's), and a flush is one pass of the covariance downdate kernel
// (lower_downdate.hpp) per area left.
#include <vector>

#include "slamkit/filters/dense_covariance.hpp"

namespace slamkit {

class CompressedJointGaussian final : public DenseCovarianceEstimator {
 public:
  /// The local area is a square of side `area_side` [m] (0: 2 x sensor_range) that opens ahead of
  /// the vehicle (centred half a side ahead along its heading, so that driving on, it crosses the
  /// whole square before leaving it); its active landmarks are those within `sensor_range` of the square, i.e. every
  /// landmark the vehicle can see from inside it. Leaving the square is checked at begin_scan().
  CompressedJointGaussian(std::shared_ptr<const MotionModel> motion,
                          std::shared_ptr<const ObservationModel> observation, double sensor_range,
                          double area_side = 0.0, const Pose2& initial_pose = Pose2::Zero(),
                          const Matrix3& initial_covariance = Matrix3::Zero());

  Matrix3 pose_covariance() const override;
  Vector2 landmark_position(std::size_t index) const override;
  Matrix2 landmark_covariance(std::size_t index) const override;
  /// For the landmarks outside the area, two products over all of them (U_B theta, U_B psi) instead
  /// of O(dim(A0)^2) scalar work per landmark.
  void landmark_marginals(std::vector<Vector2>& means, std::vector<Matrix2>& covariances) const override;
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override;
  Matrix23 landmark_pose_covariance(std::size_t index) const override;
  Eigen::VectorXd state() const override;
  Eigen::MatrixXd covariance() const override;

  void predict(const Control& u, double dt) override;
  void inflate_pose(const Matrix3& q) override;
  using EkfEstimator::update_landmark;
  bool update_landmark(const LandmarkObservation& observation) override;
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  using EkfEstimator::add_landmark;
  std::size_t add_landmark(const InitialLandmark& landmark) override;
  /// Flushes first: removal renumbers the state, and the area's bookkeeping is by stored offset.
  void remove_landmark(std::size_t index) override;
  bool fuse_landmarks(std::span<const LandmarkPair> pairs) override;
  /// Flushes when the vehicle has left the local area.
  void begin_scan() override;
  /// "local_area_flushes".
  void add_statistics(std::map<std::string, double>& statistics) const override;

  /// Applies the update accumulated in the current local area to the whole map, O(n_B^2 n_A); the
  /// next operation starts a new area around the vehicle. Every accessor already answers as if this
  /// had been done, so this only decides when the cost is paid.
  void flush_local_area();

 private:
  bool in_area() const { return !area_offsets_.empty(); }
  /// Offset of landmark `index` in the local state; -1 when it is in B or no area is open.
  long local_offset(std::size_t index) const;
  /// Starts an area ahead of the vehicle with the landmarks of `must_include` active.
  void begin_area(std::span<const LandmarkObservation> must_include = {});
  void predict_local(const Matrix3& f, const Matrix3& q);
  /// One joint update of active landmarks, measurements of dimension D.
  template <int D>
  bool update_local(std::span<const LandmarkObservation> batch);
  /// The tail of a local update whose P_AA H_A^T, innovation, S and H_A phi (k rows) the caller has
  /// written into the workspace. Returns false (and changes nothing) if S is not positive definite.
  bool apply_local_update(Eigen::Index k);
  /// Sizes the update's workspace for k measurement rows.
  void reserve_update(Eigen::Index k);
  void add_local(const Matrix23& gx, const Matrix2& pnew);
  /// Makes room for a local state of dimension d, keeping the open area's matrices.
  void reserve_area(Eigen::Index d);
  // The open area's matrices: views of buffers with room to grow.
  auto pa() { return pa_.topLeftCorner(d_, d_); }
  auto pa() const { return pa_.topLeftCorner(d_, d_); }
  auto phi() { return phi_.topLeftCorner(d_, a0_); }
  auto phi() const { return phi_.topLeftCorner(d_, a0_); }
  auto psi() { return psi_.topLeftCorner(a0_, a0_); }
  auto psi() const { return psi_.topLeftCorner(a0_, a0_); }
  auto theta() { return theta_.head(a0_); }
  auto theta() const { return theta_.head(a0_); }
  /// Column c of U = P_BA(0) for landmark `index` in B: its cross-covariance with A0's c-th variable
  /// when the area began (B's rows and A0's columns are not written while the area is open).
  Vector2 start_cross(std::size_t index, Eigen::Index c) const {
    const std::size_t l = landmark_offset(index), a = area_offsets_[static_cast<std::size_t>(c)];
    return {stored_entry(l, a), stored_entry(l + 1, a)};
  }
  /// m U^T for landmark `index` in B and m with a0_ columns, summed column by column: the accessors'
  /// products with U, without gathering U.
  template <typename Derived>
  Eigen::Matrix<double, Derived::RowsAtCompileTime, 2> times_start_cross_t(const Eigen::MatrixBase<Derived>& m,
                                                                           std::size_t index) const;
  /// U_i psi U_j^T for landmarks i and j in B.
  Matrix2 start_cross_quadratic(std::size_t i, std::size_t j) const;
  /// Fills outside_ and u_b_ for the area just begun.
  void gather_start_cross();
  /// P_BA(0), B's rows and A0's columns (a view of u_b_).
  auto start_cross_block() const { return u_b_.topLeftCorner(static_cast<Eigen::Index>(outside_.size()), a0_); }
  /// Reused by merge_area; a flush makes room in it once and then reuses it.
  struct MergeWorkspace {
    Eigen::MatrixXd u;                 // P_BA(0) spread over all rows (zero in A's): n x a0
    Eigen::MatrixXd u_psi;             // u psi
    LowerDowndate downdate;
    Eigen::MatrixXd p_ba;              // u_b phi^T: the new P_BA
  };
  /// Writes the accumulated update into x and the lower triangle of p (the stored state's layout).
  void merge_area(Eigen::Ref<Eigen::VectorXd> x, Eigen::Ref<Eigen::MatrixXd> p, MergeWorkspace& ws) const;

  double sensor_range_;
  double area_half_side_;
  Vector2 area_centre_ = Vector2::Zero();
  // The local area, empty when none is open. The local state is [vehicle | A0's landmarks |
  // landmarks added since], in which order area_offsets_ lists the stored offsets; pa() is its full
  // symmetric covariance. x_ holds the local state in place. pa_, phi_, psi_ and theta_ are buffers
  // of a capacity that only grows; pa() etc. view them.
  std::vector<std::size_t> area_offsets_;
  std::vector<long> local_of_;  // per landmark: local offset, or -1
  Eigen::MatrixXd pa_;
  Eigen::Index d_ = 0;     // dim(A)
  Eigen::Index a0_ = 0;    // dim(A0), the active part when the area began
  Eigen::MatrixXd phi_;    // dim(A) x dim(A0): P_BA = P_BA(0) phi^T
  Eigen::MatrixXd psi_;    // dim(A0) square:   P_BB = P_BB(0) - P_BA(0) psi P_AB(0)
  Eigen::VectorXd theta_;  // dim(A0):          x_B  = x_B(0) + P_BA(0) theta
  // B's stored offsets (ascending) and P_BA(0), gathered when the area begins: neither changes while
  // it is open (landmarks added join A), and the flush and every read of the whole map use them.
  std::vector<std::size_t> outside_;
  Eigen::MatrixXd u_b_;  // rows: the stored state's capacity; columns: the largest A0 so far
  // The joint update's workspace, sized for the largest scan so far: H_A phi (k x capacity), S, the
  // innovation and the observations' Jacobians (P_AA H_A^T goes in pht_).
  Eigen::MatrixXd h_phi_;
  Eigen::MatrixXd s_;
  Eigen::VectorXd nu_;
  std::vector<LandmarkObservation> fused_;  // the landmarks a fusion needs active
  template <int D>
  struct Jacobians {
    std::vector<PoseRows<D>> hx;
    std::vector<LandmarkRows<D>> hm;
  };
  PerMeasurementDim<Jacobians> jacobians_;
  MergeWorkspace merge_;
  std::size_t flushes_ = 0;
};

}  // namespace slamkit
