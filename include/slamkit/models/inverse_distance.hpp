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
// The origin is the sensor's position at the first bearing, and it is state too (Civera et al.'s
// anchor): the landmark holds four rows, (theta, rho, origin), the origin a copy of the sensor's
// position, correlated with the vehicle as that position was. So the start is exact: theta is the
// heading plus the bearing, rho the prior, the origin the sensor, and no Jacobian depends on the
// distance nobody knows yet. (Held fixed at its estimate instead, the origin left the start's
// correlations linearised at the prior's distance, and the pose NEES was a hundred times its
// expectation.) A bearing depends on the landmark only through its direction from the sensor s, so it
// is predicted from d = rho (origin - s) + (cos theta, sin theta), which is rho (m - s): smooth
// through rho = 0, where the landmark is a direction at infinity.
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

/// The largest InverseDistancePoint::bearing_spread at which a bearing is still taken as linear in
/// rho: over rho's 2-sigma interval the bearing then turns by less than about a radian.
inline constexpr double kInverseDistanceMaxBearingSpread = 1.0;

/// A landmark held as p = (theta, rho) about `origin`.
struct InverseDistancePoint {
  Vector2 origin = Vector2::Zero();

  /// The point p stands for, origin + (cos theta, sin theta) / rho, with rho held above
  /// kSmallestRho (a landmark whose rho the filter has pushed to zero or below lies beyond any
  /// distance a picture or a view test needs). Its Jacobian in the origin is the identity.
  Vector2 position(const Vector2& p) const;
  /// d position / dp at p (rho held as in position()).
  Matrix2 position_jacobian(const Vector2& p) const;
  /// h(x, p, origin) of a bearing-only model, and its Jacobians dh/dx, dh/dp and dh/dorigin where
  /// asked for.
  Measurement predict(const ObservationModel& model, const Pose2& x, const Vector2& p, PoseJacobian* hx = nullptr,
                      LandmarkJacobian* hp = nullptr, LandmarkJacobian* horigin = nullptr) const;
  /// The linearity index of the distance seen from x (Civera et al.): 4 sigma_d / d1 |cos alpha|, with
  /// sigma_d = sigma_rho / rho^2, d1 the distance from the sensor at x and alpha the angle between
  /// the rays to the landmark from the origin and from that sensor. Infinite while rho's interval
  /// reaches zero.
  double linearity(const ObservationModel& model, const Pose2& x, const Vector2& p, double rho_variance) const;
  /// How far a bearing from x turns over rho's 2-sigma interval, to first order: 2 sigma_rho |a_perp|,
  /// a_perp the sensor's offset from the origin across the ray (the bearing is atan2(rho a_perp,
  /// 1 + rho a_along)). Near zero along the ray, where the bearing does not depend on rho; large
  /// when the landmark is seen again from far off its origin before its distance is known, where
  /// one linearisation cannot stand for the bearings rho allows.
  double bearing_spread(const ObservationModel& model, const Pose2& x, const Vector2& p, double rho_variance) const;

  static constexpr double kSmallestRho = 1e-6;
};

/// The start of a landmark first seen as a bearing: its parameters p = (theta, rho) and its origin,
/// each as a function of the vehicle's pose plus independent noise.
struct InverseDistanceStart {
  /// p's mean, d p / dx and the covariance of its own noise: theta the heading plus the bearing
  /// (the bearing's noise), rho the prior's (independent of everything).
  InitialLandmark parameters;
  Vector2 origin = Vector2::Zero();    ///< the sensor's position
  Matrix23 origin_gx = Matrix23::Zero();  ///< d origin / dx; the origin adds no noise of its own
};

/// The landmark first seen as bearing z from a vehicle estimated at x, with the prior of `options`.
InverseDistanceStart inverse_distance_start(const ObservationModel& model, const Pose2& x, const Measurement& z,
                                            const InverseDistanceOptions& options);

}  // namespace slamkit
