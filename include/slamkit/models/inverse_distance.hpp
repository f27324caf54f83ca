#pragma once
// Inverse-distance landmarks: a bearing-only sensor's undelayed start (Civera, Davison and Montiel,
// "Inverse depth parametrization for monocular SLAM", 2008; Sola et al. 2012's anchored points).
//
// A bearing alone puts its landmark on a ray. A Gaussian over the point itself cannot stand for a
// ray that may reach to infinity, but a Gaussian over the ray's azimuth theta and the inverse of the
// distance along it, rho, can: rho's interval [0, 1/d_min] spans every distance from d_min out to
// infinity, and the bearing is close to linear in rho. So the landmark joins the state at its first
// bearing as p = (theta, rho), the point origin + (cos theta, sin theta) / rho, and every later
// bearing updates it and the vehicle at once.
//
// The origin is the sensor's estimated position at the first bearing, held fixed: the landmark
// keeps the two rows every landmark has. (Civera et al. estimate the anchor as state too; here its
// uncertainty enters through the landmark's correlations with the vehicle at that moment, linearised
// at the prior's rho.) A bearing depends on the landmark only through its direction from the
// sensor s, so it is predicted from d = rho (origin - s) + (cos theta, sin theta), which is
// rho (m - s): smooth through rho = 0, where the landmark is a direction at infinity.
//
// Once the distance is known well enough that a Gaussian over the point is as good (Civera,
// Davison and Montiel's linearity index of the depth, below 0.1), the filter converts the landmark
// to the point and its covariance to the point's, which is exact to first order and costs O(n).
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

/// The inverse-distance start's prior of rho: its mean 1 / prior_distance_m, where the filter
/// linearises the first updates, and its two standard deviations above that reaching
/// 1 / min_distance_m, so that the prior admits any distance from min_distance_m out to infinity.
struct InverseDistanceOptions {
  double min_distance_m = 1.0;     ///< the nearest a landmark is expected [m]
  double prior_distance_m = 10.0;  ///< where a landmark is first put along its ray [m] (Civera et al.'s)
  double prior_rho() const { return 1.0 / prior_distance_m; }
  double prior_rho_std() const { return 0.5 * (1.0 / min_distance_m - prior_rho()); }
};

/// Throws std::invalid_argument unless both distances are finite and 0 < min_distance_m <
/// prior_distance_m.
void validate(const InverseDistanceOptions& options);

/// Throws std::invalid_argument unless the model measures a bearing and no range: the prediction
/// through d relies on a measurement that does not change along the ray.
void require_bearing_only(const ObservationModel& model, const std::string& what);

/// Civera, Davison and Montiel's threshold of the linearity index below which a landmark is
/// converted to its point.
inline constexpr double kInverseDistanceLinearityThreshold = 0.1;

/// A landmark held as p = (theta, rho) about a fixed origin.
struct InverseDistancePoint {
  Vector2 origin = Vector2::Zero();

  /// The point p stands for, origin + (cos theta, sin theta) / rho, with rho held above
  /// kSmallestRho (a landmark whose rho the filter has pushed to zero or below lies beyond any
  /// distance a picture or a view test needs).
  Vector2 position(const Vector2& p) const;
  /// d position / dp at p (rho held as in position()).
  Matrix2 position_jacobian(const Vector2& p) const;
  /// h(x, p) of a bearing-only model, and its Jacobians dh/dx and dh/dp where asked for.
  Measurement predict(const ObservationModel& model, const Pose2& x, const Vector2& p, PoseJacobian* hx = nullptr,
                      LandmarkJacobian* hp = nullptr) const;
  /// The variance the bearing's product of rho's error and the sensor's error adds to its innovation
  /// (the second-order EKF's term for it): rho_variance c P_vv c^T + (c P_v,rho)^2, with c = dh/ds,
  /// s the sensor's position, taken at rho = 0 and carried to the vehicle through ds/dx. Linearised
  /// at the estimate alone, a bearing of a landmark whose distance is still a guess would tell the
  /// filter about the vehicle's position as if the distance were known.
  double coupling_variance(const ObservationModel& model, const Pose2& x, const Vector2& p, const Matrix3& pose_covariance,
                           const Eigen::RowVector3d& rho_pose_covariance, double rho_variance) const;
  /// The linearity index of the distance seen from x (Civera et al.): 4 sigma_d / d1 |cos alpha|, with
  /// sigma_d = sigma_rho / rho^2, d1 the distance from the sensor at x and alpha the angle between
  /// the rays to the landmark from the origin and from that sensor. Infinite while rho's interval
  /// reaches zero.
  double linearity(const ObservationModel& model, const Pose2& x, const Vector2& p, double rho_variance) const;

  static constexpr double kSmallestRho = 1e-6;
};

/// The landmark first seen as bearing z from a vehicle estimated at x with `pose_covariance`, as
/// InitialLandmark over p = (theta, rho) about `origin` (set to the sensor's position at x), with
/// the prior of `options`.
InitialLandmark inverse_distance_start(const ObservationModel& model, const Pose2& x, const Matrix3& pose_covariance,
                                       const Measurement& z, const InverseDistanceOptions& options, Vector2& origin);

}  // namespace slamkit
