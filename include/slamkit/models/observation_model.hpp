#pragma once
// Observation model plug-in interface, eq. (7) of the tutorial: z = h(x, m) + v, for point landmarks
// in the plane and two-dimensional measurements. Besides h, its Jacobians and R, a model gives its
// inverse g(x, z) (where a landmark seen as z from x is) with Jacobians, used to initialise new
// landmarks with their full correlations, and the residual z - h with angles wrapped.
#include <Eigen/Core>
#include <span>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

using Matrix23 = Eigen::Matrix<double, 2, 3>;

class ObservationModel {
 public:
  virtual ~ObservationModel() = default;
  virtual std::string name() const = 0;

  /// h(x, m): the noise-free measurement of landmark m from pose x.
  virtual Vector2 predict(const Pose2& x, const Vector2& m) const = 0;
  /// predict(x, m) of every landmark of `m` into `z` (as many): the same values, for callers that
  /// predict many landmarks from one pose (the UKF's sigma points), so that a model can do the
  /// pose's part (for a range-bearing sensor, its position: a sine and a cosine) once.
  virtual void predict_many(const Pose2& x, std::span<const Vector2> m, std::span<Vector2> z) const {
    for (std::size_t i = 0; i < m.size(); ++i) z[i] = predict(x, m[i]);
  }
  /// dh/dx (2x3) and dh/dm (2x2) at (x, m).
  virtual void jacobians(const Pose2& x, const Vector2& m, Matrix23& hx, Matrix2& hm) const = 0;
  /// Measurement noise covariance R.
  virtual Matrix2 noise() const = 0;
  /// z - zhat, angular components wrapped to (-pi, pi].
  virtual Vector2 residual(const Vector2& z, const Vector2& zhat) const = 0;

  /// g(x, z): the landmark position that produces measurement z from pose x.
  virtual Vector2 inverse(const Pose2& x, const Vector2& z) const = 0;
  /// dg/dx (2x3) and dg/dz (2x2) at (x, z).
  virtual void inverse_jacobians(const Pose2& x, const Vector2& z, Matrix23& gx, Matrix2& gz) const = 0;
};

/// Range [m] and bearing [rad] from a sensor mounted at (offset_x, offset_y) in the vehicle frame
/// (x forward, y left). Bearing is relative to the vehicle heading, wrapped to (-pi, pi].
class RangeBearingModel final : public ObservationModel {
 public:
  struct Params {
    double sigma_range = 0.1;                                     // m
    double sigma_bearing = deg2rad(1.0);  // rad
    double offset_x = 0.0;                                        // m, sensor ahead of the pose origin
    double offset_y = 0.0;                                        // m, sensor left of the pose origin
  };
  RangeBearingModel() = default;
  explicit RangeBearingModel(const Params& p) : p_(p) {}

  std::string name() const override { return "range-bearing"; }
  Vector2 predict(const Pose2& x, const Vector2& m) const override;
  void predict_many(const Pose2& x, std::span<const Vector2> m, std::span<Vector2> z) const override;
  void jacobians(const Pose2& x, const Vector2& m, Matrix23& hx, Matrix2& hm) const override;
  Matrix2 noise() const override;
  Vector2 residual(const Vector2& z, const Vector2& zhat) const override;
  Vector2 inverse(const Pose2& x, const Vector2& z) const override;
  void inverse_jacobians(const Pose2& x, const Vector2& z, Matrix23& gx, Matrix2& gz) const override;

  /// Where the sensor is in the world when the vehicle is at x.
  Vector2 sensor_position(const Pose2& x) const;
  const Params& params() const { return p_; }

 private:
  Params p_;
};

}  // namespace slamkit
