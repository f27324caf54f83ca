#pragma once
// EKF-SLAM, eqs. (6)-(11) of the tutorial: one joint Gaussian over the vehicle pose and every landmark.
//
// Storage: the state is [x y theta | m1x m1y | m2x m2y | ...]; the covariance is kept in one dense
// column-major buffer of which only the LOWER triangle is meaningful. Symmetry therefore holds by
// construction (no symmetrisation pass), and every update touches half the matrix. Buffers grow by
// doubling, so adding a landmark does not reallocate each time.
//
// Cost: a time update is O(n) (vehicle block and vehicle-map cross-covariance only); an observation
// update is O(n^2) with the constant of one symmetric rank-2 downdate, because the observation
// Jacobian has non-zeros only in the vehicle's 3 and the landmark's 2 columns.
#include <Eigen/Core>
#include <memory>
#include <unordered_map>
#include <vector>

#include "slamkit/filters/slam_filter.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

struct EkfSlamOptions {
  Pose2 initial_pose = Pose2::Zero();
  /// The map frame is defined by the start pose, so by default it is known exactly.
  Matrix3 initial_covariance = Matrix3::Zero();
};

class EkfSlam final : public SlamFilter {
 public:
  EkfSlam(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
          const EkfSlamOptions& options = {});

  std::string name() const override { return "ekf"; }
  void predict(const ControlEvent& control) override;
  /// Known association: an observation's id names its landmark; unseen ids become new landmarks
  /// after the scan's updates. Throws std::invalid_argument for an observation without an id.
  void update(const ScanEvent& scan) override;

  Pose2 pose() const override { return x_.head<3>(); }
  Matrix3 pose_covariance() const override;
  std::size_t num_landmarks() const override { return ids_.size(); }
  std::vector<Landmark> landmarks() const override;

  // ---- Lower-level operations, for association strategies, tests and benchmarks ----
  /// Eqs. (8)-(9) with an explicit control.
  void predict(const Control& u, double dt);
  /// Eqs. (10)-(11) for one observation z of the landmark at map index `index`.
  /// Returns false (and changes nothing) if the innovation covariance is not positive definite.
  bool update_landmark(std::size_t index, const Vector2& z);
  /// Appends the landmark seen as z, with its full cross-covariances; returns its map index.
  std::size_t add_landmark(const Vector2& z, int id);
  /// Predicted measurement and innovation covariance S of landmark `index` (for gating).
  void innovation(std::size_t index, Vector2& zhat, Matrix2& s) const;

  std::size_t state_dim() const { return dim_; }
  Eigen::VectorXd state() const { return x_.head(dim_); }
  /// The full symmetric covariance (a copy: O(n^2); for tests and exports, not for the hot path).
  Eigen::MatrixXd covariance() const;
  Vector2 landmark_position(std::size_t index) const { return x_.segment<2>(landmark_offset(index)); }
  Matrix2 landmark_covariance(std::size_t index) const;
  /// Cross-covariance block cov(m_i, m_j).
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const;
  int landmark_id(std::size_t index) const { return ids_[index]; }
  /// Map index of the landmark with this id, or -1.
  long find_landmark(int id) const;

  const MotionModel& motion_model() const { return *motion_; }
  const ObservationModel& observation_model() const { return *observation_; }

 private:
  static std::size_t landmark_offset(std::size_t index) { return 3 + 2 * index; }
  void reserve(std::size_t dim);
  /// Symmetric 2x2 or 3x3 diagonal block from the lower triangle.
  template <int N>
  Eigen::Matrix<double, N, N> diagonal_block(std::size_t offset) const;
  /// Fills pht_ with P H^T for an observation Jacobian with blocks hx (vehicle) and hm (landmark).
  void covariance_times_jacobian(std::size_t lm_offset, const Matrix23& hx, const Matrix2& hm);

  std::shared_ptr<const MotionModel> motion_;
  std::shared_ptr<const ObservationModel> observation_;

  std::size_t dim_ = 3;
  Eigen::VectorXd x_;
  Eigen::MatrixXd p_;  // capacity x capacity; lower triangle of the leading dim_ x dim_ block is P
  Eigen::Matrix<double, Eigen::Dynamic, 3> scratch3_;  // capacity x 3, reused by the time update
  Eigen::Matrix<double, Eigen::Dynamic, 2> pht_;       // capacity x 2, P H^T of the current update
  std::vector<int> ids_;
  std::unordered_map<int, std::size_t> index_of_id_;
  std::vector<std::size_t> new_observations_;  // reused per scan
};

}  // namespace slamkit
