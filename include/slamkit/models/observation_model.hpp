#pragma once
// Observation model plug-in interface, eq. (7) of the tutorial: z = h(x, m) + v, for point landmarks
// in the plane and measurements of the model's own dimension: range and bearing (2), range only (1,
// a radio beacon), bearing only (1, a camera). A model gives h, its Jacobians on request, R, the
// residual z - h with angles wrapped, and where the sensor is. Where one measurement determines the
// landmark (range and bearing) it also gives the inverse g(x, z) with its Jacobians, which the
// filters use to start a landmark with its full correlations; where it does not, the filters start
// landmarks through a LandmarkInitialiser (filters/landmark_initialiser.hpp) instead.
#include <Eigen/Core>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

using Matrix23 = Eigen::Matrix<double, 2, 3>;
/// dh/dx: dim() rows, one column per pose component.
using PoseJacobian = Eigen::Matrix<double, Eigen::Dynamic, 3, 0, kMaxMeasurementDim, 3>;
/// dh/dm: dim() rows, one column per landmark coordinate.
using LandmarkJacobian = Eigen::Matrix<double, Eigen::Dynamic, 2, 0, kMaxMeasurementDim, 2>;
/// dg/dz of an inverse: two rows (the landmark), dim() columns.
using InverseMeasurementJacobian = Eigen::Matrix<double, 2, Eigen::Dynamic, 0, 2, kMaxMeasurementDim>;

/// g(x, z), the landmark position that produces z from x, with dg/dx and dg/dz.
struct InverseObservation {
  Vector2 position = Vector2::Zero();
  Matrix23 gx = Matrix23::Zero();
  InverseMeasurementJacobian gz;
};

/// A landmark about to join a Gaussian belief: its mean, its Jacobian gx with respect to the vehicle
/// (its correlations are those of the vehicle carried by gx: P(m, :) = gx P(v, :)), and the
/// covariance it has besides, gx P(v, v) gx^T + covariance being its marginal.
struct InitialLandmark {
  Vector2 mean = Vector2::Zero();
  Matrix23 gx = Matrix23::Zero();
  Matrix2 covariance = Matrix2::Zero();
  /// How the mean moves with the ranges it was placed from (zero where no range placed it): by
  /// range_gain per metre added to every one, and by range_scale_gain per unit of a scale error s
  /// that makes each range r read (1 + s) r. A filter that calibrates its ranges correlates the
  /// landmark with the calibration through them.
  Vector2 range_gain = Vector2::Zero();
  Vector2 range_scale_gain = Vector2::Zero();
};

/// A range sensor's systematic error: it reads (1 + scale_error) d + offset_m for a distance d
/// (radio ranging reads long, by an offset of the electronics' delay and a scale of the speed of
/// the signal assumed). The zero correction is exact.
struct RangeCorrection {
  double offset_m = 0.0;
  double scale_error = 0.0;
  double distance(double range) const { return (range - offset_m) / (1.0 + scale_error); }
  double range(double distance) const { return (1.0 + scale_error) * distance + offset_m; }
};

/// Independent Gaussian priors of a range sensor's offset [m] and scale error (RangeCorrection).
struct RangeCalibrationPrior {
  double offset_m = 0.0;
  double offset_std_m = 1.0;
  double scale_error = 0.0;
  double scale_error_std = 0.1;
};

class ObservationModel;

/// Throws std::invalid_argument unless the model measures range and the prior has a finite offset,
/// a scale error between -0.5 and 0.5, and positive, finite deviations.
void validate(const RangeCalibrationPrior& prior, const ObservationModel& model);

/// What a measurement says about where its landmark is, for pictures: on the segment from `sensor`
/// to `end` (range and bearing: the landmark is at `end`; bearing only: somewhere along the ray,
/// drawn out to the sensor's reach), or, when `radius` > 0, on the circle of that radius about
/// `sensor` (range only).
struct MeasurementShape {
  Vector2 sensor = Vector2::Zero();
  Vector2 end = Vector2::Zero();
  double radius = 0.0;
};

/// Which rows of a measurement hold the landmark's range [m] and its bearing [rad] from the sensor
/// (-1: not measured). Triangulation and the simulator read the measurement in these terms.
struct MeasuredRows {
  int range = -1;
  int bearing = -1;
};

/// The landmark one measurement z from pose x determines, with covariance Gz R Gz^T: an immediate
/// start. Nothing where the model cannot invert z.
std::optional<InitialLandmark> inverted_landmark(const ObservationModel& model, const Pose2& x, const Measurement& z);

class ObservationModel {
 public:
  virtual ~ObservationModel() = default;
  virtual std::string name() const = 0;
  /// The measurement's dimension, from 1 to kMaxMeasurementDim.
  virtual int dim() const = 0;

  /// h(x, m): the noise-free measurement of landmark m from pose x.
  virtual Measurement predict(const Pose2& x, const Vector2& m) const = 0;
  /// predict(x, m) of every landmark of `m` into `z` (as many): the same values, for callers that
  /// predict many landmarks from one pose (the UKF's sigma points), so that a model can do the
  /// pose's part (the sensor's position: a sine and a cosine) once.
  virtual void predict_many(const Pose2& x, std::span<const Vector2> m, std::span<Measurement> z) const {
    for (std::size_t i = 0; i < m.size(); ++i) z[i] = predict(x, m[i]);
  }
  /// dh/dx (dim x 3) and dh/dm (dim x 2) at (x, m).
  virtual void jacobians(const Pose2& x, const Vector2& m, PoseJacobian& hx, LandmarkJacobian& hm) const = 0;
  /// Measurement noise covariance R (dim x dim).
  virtual MeasurementCovariance noise() const = 0;
  /// z - zhat, angular components wrapped to (-pi, pi].
  virtual Measurement residual(const Measurement& z, const Measurement& zhat) const = 0;
  /// Where the sensor is in the world when the vehicle is at x (its axis is the vehicle's heading).
  virtual Vector2 sensor_position(const Pose2& x) const = 0;
  /// d sensor_position / dx.
  virtual Matrix23 sensor_jacobian(const Pose2& x) const = 0;
  /// The volume of the measurement space the sensor's view spans (m rad for range and bearing, m for
  /// range only, rad for bearing only): false detections spread uniformly over it have a density of
  /// their number over this.
  virtual double measurement_volume(const SensorLimits& sensor) const = 0;

  /// Which rows hold range and bearing.
  virtual MeasuredRows rows() const = 0;
  /// Where z from x puts its landmark, for pictures; `reach` [m] ends a ray that has no range.
  virtual MeasurementShape shape(const Pose2& x, const Measurement& z, double reach) const = 0;

  /// Whether one measurement determines the landmark, so that invert() answers.
  virtual bool invertible() const { return false; }
  /// g(x, z) with its Jacobians where one measurement determines the landmark; nothing otherwise.
  virtual std::optional<InverseObservation> invert(const Pose2& /*x*/, const Measurement& /*z*/) const {
    return std::nullopt;
  }
};

/// Calls f(std::integral_constant<int, D>{}) with D = dim, so that the kernels of a scan run on
/// measurement types fixed at the model's dimension; throws std::invalid_argument outside 1 to
/// kMaxMeasurementDim.
template <class F>
decltype(auto) with_measurement_dim(int dim, F&& f) {
  static_assert(kMaxMeasurementDim == 3, "one case per dimension");
  switch (dim) {
    case 1: return f(std::integral_constant<int, 1>{});
    case 2: return f(std::integral_constant<int, 2>{});
    case 3: return f(std::integral_constant<int, 3>{});
    default: throw std::invalid_argument("a measurement has 1 to 3 components, found " + std::to_string(dim));
  }
}

/// Fixed-size types of a measurement of dimension D, for the kernels with_measurement_dim runs.
template <int D>
using MeasurementVector = Eigen::Matrix<double, D, 1>;
template <int D>
using MeasurementSquare = Eigen::Matrix<double, D, D>;
template <int D>
using PoseRows = Eigen::Matrix<double, D, 3>;
template <int D>
using LandmarkRows = Eigen::Matrix<double, D, 2>;

/// One T<D> per measurement dimension: the storage of kernels fixed at the dimension, kept apart
/// so that a filter switching models (tests do) still allocates only while its workspaces grow.
template <template <int> class T>
struct PerMeasurementDim {
  T<1> one;
  T<2> two;
  T<3> three;
  template <int D>
  T<D>& get() {
    static_assert(D >= 1 && D <= kMaxMeasurementDim);
    if constexpr (D == 1) return one;
    else if constexpr (D == 2) return two;
    else return three;
  }
  template <int D>
  const T<D>& get() const {
    return const_cast<PerMeasurementDim&>(*this).get<D>();
  }
};

/// Where a sensor sits on the vehicle: ahead of the pose origin by offset_x [m] and left of it by
/// offset_y [m] (vehicle frame: x forward, y left).
struct SensorMount {
  double offset_x = 0.0;
  double offset_y = 0.0;
  /// The sensor's position in the world for a vehicle at x.
  Vector2 position(const Pose2& x) const;
  /// d position / d theta.
  Vector2 turn_derivative(const Pose2& x) const;
  /// d position / dx.
  Matrix23 jacobian(const Pose2& x) const;
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
  explicit RangeBearingModel(const Params& p) : p_(p), mount_{p.offset_x, p.offset_y} {}

  std::string name() const override { return "range-bearing"; }
  int dim() const override { return 2; }
  Measurement predict(const Pose2& x, const Vector2& m) const override;
  void predict_many(const Pose2& x, std::span<const Vector2> m, std::span<Measurement> z) const override;
  void jacobians(const Pose2& x, const Vector2& m, PoseJacobian& hx, LandmarkJacobian& hm) const override;
  MeasurementCovariance noise() const override;
  Measurement residual(const Measurement& z, const Measurement& zhat) const override;
  Vector2 sensor_position(const Pose2& x) const override { return mount_.position(x); }
  Matrix23 sensor_jacobian(const Pose2& x) const override { return mount_.jacobian(x); }
  double measurement_volume(const SensorLimits& sensor) const override;
  MeasuredRows rows() const override { return {0, 1}; }
  MeasurementShape shape(const Pose2& x, const Measurement& z, double reach) const override;
  bool invertible() const override { return true; }
  std::optional<InverseObservation> invert(const Pose2& x, const Measurement& z) const override;

  const Params& params() const { return p_; }

 private:
  Params p_;
  SensorMount mount_;
};

/// Range [m] alone, from a sensor mounted as RangeBearingModel's (a radio ranging to beacons).
class RangeOnlyModel final : public ObservationModel {
 public:
  struct Params {
    double sigma_range = 0.1;  // m
    double offset_x = 0.0;     // m, sensor ahead of the pose origin
    double offset_y = 0.0;     // m, sensor left of the pose origin
  };
  RangeOnlyModel() = default;
  explicit RangeOnlyModel(const Params& p) : p_(p), mount_{p.offset_x, p.offset_y} {}

  std::string name() const override { return "range-only"; }
  int dim() const override { return 1; }
  Measurement predict(const Pose2& x, const Vector2& m) const override;
  void jacobians(const Pose2& x, const Vector2& m, PoseJacobian& hx, LandmarkJacobian& hm) const override;
  MeasurementCovariance noise() const override;
  Measurement residual(const Measurement& z, const Measurement& zhat) const override { return z - zhat; }
  Vector2 sensor_position(const Pose2& x) const override { return mount_.position(x); }
  Matrix23 sensor_jacobian(const Pose2& x) const override { return mount_.jacobian(x); }
  double measurement_volume(const SensorLimits& sensor) const override { return sensor.max_range; }
  MeasuredRows rows() const override { return {0, -1}; }
  MeasurementShape shape(const Pose2& x, const Measurement& z, double reach) const override;

  const Params& params() const { return p_; }

 private:
  Params p_;
  SensorMount mount_;
};

/// Bearing [rad] alone, relative to the vehicle heading and wrapped to (-pi, pi], from a sensor
/// mounted as RangeBearingModel's (a camera's azimuth to a feature).
class BearingOnlyModel final : public ObservationModel {
 public:
  struct Params {
    double sigma_bearing = deg2rad(1.0);  // rad
    double offset_x = 0.0;                // m, sensor ahead of the pose origin
    double offset_y = 0.0;                // m, sensor left of the pose origin
  };
  BearingOnlyModel() = default;
  explicit BearingOnlyModel(const Params& p) : p_(p), mount_{p.offset_x, p.offset_y} {}

  std::string name() const override { return "bearing-only"; }
  int dim() const override { return 1; }
  Measurement predict(const Pose2& x, const Vector2& m) const override;
  void jacobians(const Pose2& x, const Vector2& m, PoseJacobian& hx, LandmarkJacobian& hm) const override;
  MeasurementCovariance noise() const override;
  Measurement residual(const Measurement& z, const Measurement& zhat) const override;
  Vector2 sensor_position(const Pose2& x) const override { return mount_.position(x); }
  Matrix23 sensor_jacobian(const Pose2& x) const override { return mount_.jacobian(x); }
  double measurement_volume(const SensorLimits& sensor) const override { return sensor.fov; }
  MeasuredRows rows() const override { return {-1, 0}; }
  MeasurementShape shape(const Pose2& x, const Measurement& z, double reach) const override;

  const Params& params() const { return p_; }

 private:
  Params p_;
  SensorMount mount_;
};

}  // namespace slamkit
