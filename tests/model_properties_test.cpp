// What every motion model and every observation model must satisfy, written once and checked over
// all of them by a typed suite each (GoogleTest's per-type tests, as manif tests its Lie groups).
// A traits struct per model gives its instances and sample points; the properties are generic:
//   motion       both Jacobians against central differences, the heading wrapped, the control and
//                process noise symmetric positive (semi)definite, and sample_control's draws
//                against the stated control covariance;
//   observation  both pairs of Jacobians against central differences, bearings and residuals
//                wrapped, the inverse model consistent with the forward one (values and Jacobians),
//                and the simulator's measurement noise against the stated covariance R.
// Jacobians are held to the one tolerance of test_data::jacobian_matches; covariances to one
// likelihood-ratio bound (covariance_matches, below). A new model gets every check by adding its
// traits and its type to the list. Each model's own known answers stay in its own test file.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/chi_square.hpp"
#include "slamkit/models/acfr_car.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/models/velocity_model.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"

using namespace slamkit;
using test_data::jacobian_matches;
using test_data::numeric_jacobian;

namespace {

Control control(std::initializer_list<double> values) {
  Control u(static_cast<Eigen::Index>(values.size()));
  Eigen::Index i = 0;
  for (const double v : values) u[i++] = v;
  return u;
}

/// Poses all round, two of them a hair from +-pi, where a heading or bearing must wrap.
std::vector<Pose2> sample_poses() {
  return {Pose2(0, 0, 0), Pose2(1.5, -2.0, 0.7), Pose2(-3, 4, -2.9), Pose2(10, 2, kPi - 1e-3),
          Pose2(-1, 5, -kPi + 1e-3)};
}

bool wrapped(double angle) { return angle > -kPi && angle <= kPi; }

/// Draws d_i ~ N(0, sigma), mean known, against sigma. Whitened by sigma's Cholesky factor their
/// sample covariance S should be the identity; the likelihood-ratio statistic n (tr S - ln det S - k)
/// is asymptotically chi-square with k (k + 1) / 2 degrees of freedom (the test of a Wishart
/// matrix's scale). The bound is its 0.9999 quantile; every seed is fixed, so a pass is final. With
/// the ~18,000 to 20,000 draws used here a 3% error in a standard deviation fails.
::testing::AssertionResult covariance_matches(const std::vector<Eigen::VectorXd>& draws, const Eigen::MatrixXd& sigma) {
  const Eigen::LLT<Eigen::MatrixXd> llt(sigma);
  if (llt.info() != Eigen::Success) return ::testing::AssertionFailure() << "not positive definite:\n" << sigma;
  const Eigen::Index k = sigma.rows();
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(k, k);
  for (const Eigen::VectorXd& d : draws) {
    const Eigen::VectorXd e = llt.matrixL().solve(d);
    s += e * e.transpose();
  }
  const double n = static_cast<double>(draws.size());
  s /= n;
  const double statistic = n * (s.trace() - std::log(s.determinant()) - static_cast<double>(k));
  const double bound = eval::chi_square_quantile(0.9999, static_cast<double>(k * (k + 1) / 2));
  if (statistic <= bound) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "statistic " << statistic << " > " << bound
                                       << "; whitened sample covariance\n" << s;
}

::testing::AssertionResult symmetric_positive_semidefinite(const Eigen::MatrixXd& m) {
  if (!m.allFinite() || !m.isApprox(m.transpose(), 1e-14))
    return ::testing::AssertionFailure() << "not symmetric:\n" << m;
  const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(m).eigenvalues().minCoeff();
  if (smallest < -1e-12 * std::max(1.0, m.norm())) return ::testing::AssertionFailure() << "eigenvalue " << smallest;
  return ::testing::AssertionSuccess();
}

/// exp(xi) X on SE_{1+n}(2) for a state [x y theta | m1 | ...]: the heading turns by xi_theta, every
/// position p goes to R(xi_theta) p + V(xi_theta) xi_p (the invariant EKF's retraction).
Matrix2 rotation(double phi) { return (Matrix2() << std::cos(phi), -std::sin(phi), std::sin(phi), std::cos(phi)).finished(); }
/// V(phi), which takes xi_p to the translation of exp(xi).
Matrix2 exp_translation(double phi) {
  if (std::abs(phi) < 1e-12) return Matrix2::Identity();
  const double a = std::sin(phi) / phi, b = (1 - std::cos(phi)) / phi;
  return (Matrix2() << a, -b, b, a).finished();
}
Eigen::VectorXd group_retract(const Eigen::VectorXd& x, const Eigen::VectorXd& xi) {
  const double phi = xi[2];
  Eigen::VectorXd out = x;
  for (Eigen::Index o = 0; o < x.size(); o += (o == 0 ? 3 : 2))
    out.segment<2>(o) = rotation(phi) * x.segment<2>(o) + exp_translation(phi) * xi.segment<2>(o);
  out[2] = wrap_angle(x[2] + phi);
  return out;
}

/// The standard error d of a pose in the right-invariant error's coordinates, xi = T(x) d:
/// xi_theta = d_theta, xi_p = d_p - d_theta J p.
Matrix3 to_invariant(const Pose2& x) {
  Matrix3 t = Matrix3::Identity();
  t(0, 2) = x[1];
  t(1, 2) = -x[0];
  return t;
}

// ---- Motion models ------------------------------------------------------------------------------

/// For each motion model: `models()` its instances, `controls()` and `periods()` the inputs it is
/// tested at (every pair with every sample pose). The sample includes steps that turn the heading
/// across +-pi from the poses beside it.
template <typename Model>
struct MotionTraits;

template <>
struct MotionTraits<AckermannModel> {
  static constexpr const char* kName = "Ackermann";
  static std::vector<AckermannModel> models() { return {AckermannModel{}, AckermannModel({2.0, 0.5, 0.1})}; }
  static std::vector<Control> controls() {
    return {control({2.7, -0.5}), control({2.7, 0.0}), control({2.7, 0.3}), control({-1.0, 0.2})};
  }
  static std::vector<double> periods() { return {0.025, 0.4}; }
};

template <>
struct MotionTraits<OdometryModel> {
  static constexpr const char* kName = "Odometry";
  static std::vector<OdometryModel> models() {
    return {OdometryModel{}, OdometryModel({.alpha_rot_rot = 0.1, .alpha_rot_trans = 0.02, .alpha_trans_trans = 0.05,
                                            .alpha_trans_rot = 0.01, .min_variance = 1e-6})};
  }
  static std::vector<Control> controls() {
    return {control({0.2, 0.8, -0.4}), control({0.0, 0.0, 0.0}), control({3.0, 0.5, 3.0}), control({-0.1, 2.0, 0.0})};
  }
  static std::vector<double> periods() { return {0.1}; }
};

template <>
struct MotionTraits<VelocityModel> {
  static constexpr const char* kName = "Velocity";
  static std::vector<VelocityModel> models() { return {VelocityModel{}, VelocityModel({.q_v = 2e-4, .q_omega = 3e-3})}; }
  static std::vector<Control> controls() {
    return {control({0.086, -0.4}), control({0.05, 0.0}), control({-0.3, 0.57}), control({2.0, 3.0})};
  }
  static std::vector<double> periods() { return {0.015, 0.5}; }
};

template <>
struct MotionTraits<AcfrCarModel> {
  static constexpr const char* kName = "AcfrCar";
  static std::vector<AcfrCarModel> models() {
    AcfrCarModel::Params other;
    other.encoder_offset = 0.0;
    other.laser_left = -0.3;
    return {AcfrCarModel{}, AcfrCarModel(other)};
  }
  static std::vector<Control> controls() {
    std::vector<Control> u;
    for (const double steer : {-0.55, -0.1, 0.0, 0.3, 0.56})
      for (const double speed : {0.0, 3.2, -0.05}) u.push_back(control({speed, steer}));
    return u;
  }
  static std::vector<double> periods() { return {0.025}; }
};

/// Names each typed test after its model's traits.
template <template <typename> class Traits>
struct TraitsName {
  template <typename Model>
  static std::string GetName(int) {
    return Traits<Model>::kName;
  }
};

template <typename Model>
class MotionModelProperties : public ::testing::Test {
 protected:
  using Traits = MotionTraits<Model>;

  /// Calls check(model, x, u, dt) for every instance, sample pose, control and period.
  template <typename Check>
  void for_each_case(Check check) const {
    for (const Model& model : Traits::models())
      for (const Pose2& x : sample_poses())
        for (const Control& u : Traits::controls())
          for (const double dt : Traits::periods()) {
            SCOPED_TRACE(::testing::Message() << "x " << x.transpose() << ", u " << u.transpose() << ", dt " << dt);
            check(model, x, u, dt);
          }
  }
};

using MotionModels = ::testing::Types<AckermannModel, OdometryModel, VelocityModel, AcfrCarModel>;
TYPED_TEST_SUITE(MotionModelProperties, MotionModels, TraitsName<MotionTraits>);

TYPED_TEST(MotionModelProperties, JacobianOfTheStateMatchesCentralDifferences) {
  this->for_each_case([](const TypeParam& model, const Pose2& x, const Control& u, double dt) {
    const Eigen::MatrixXd numeric =
        numeric_jacobian<3>([&](const Eigen::VectorXd& s) { return model.predict(s, u, dt); }, x, {2});
    EXPECT_TRUE(jacobian_matches(model.jacobian_state(x, u, dt), numeric));
  });
}

// The consistent EKF variants evaluate df/dx at pose pairs through jacobian_between: at the pair a
// step links, it must be the Jacobian itself, for every model.
TYPED_TEST(MotionModelProperties, JacobianBetweenTheStepsPosesMatchesCentralDifferences) {
  this->for_each_case([](const TypeParam& model, const Pose2& x, const Control& u, double dt) {
    const Eigen::MatrixXd numeric =
        numeric_jacobian<3>([&](const Eigen::VectorXd& s) { return model.predict(s, u, dt); }, x, {2});
    EXPECT_TRUE(jacobian_matches(MotionModel::jacobian_between(x, model.predict(x, u, dt)), numeric));
  });
}

// The invariant EKF takes the motion to carry the right-invariant error unchanged (the model moves
// the vehicle by an increment in its own frame): the time update's Jacobian in the invariant error,
// by central differences through the group's exponential, and T(x') F T(x)^-1 with the model's F,
// are the identity. For the ACFR car it must hold with the laser's pose as the state.
TYPED_TEST(MotionModelProperties, CarriesTheInvariantErrorUnchanged) {
  this->for_each_case([](const TypeParam& model, const Pose2& x, const Control& u, double dt) {
    const Pose2 next = model.predict(x, u, dt);
    const auto error_after = [&](const Eigen::VectorXd& xi) -> Eigen::Vector3d {
      const Pose2 moved = model.predict(group_retract(x, xi), u, dt);
      const double phi = wrap_angle(moved[2] - next[2]);
      const Vector2 xi_p = exp_translation(phi).inverse() * (moved.head<2>() - rotation(phi) * next.head<2>());
      return Eigen::Vector3d(xi_p[0], xi_p[1], phi);
    };
    EXPECT_TRUE(jacobian_matches(Matrix3::Identity(), numeric_jacobian<3>(error_after, Eigen::Vector3d::Zero(), {2})));
    const Matrix3 carried = to_invariant(next) * model.jacobian_state(x, u, dt) * to_invariant(x).inverse();
    EXPECT_TRUE(jacobian_matches(carried, Matrix3::Identity()));
  });
}

TYPED_TEST(MotionModelProperties, JacobianOfTheControlMatchesCentralDifferences) {
  this->for_each_case([](const TypeParam& model, const Pose2& x, const Control& u, double dt) {
    ASSERT_EQ(u.size(), model.control_dim());
    const Eigen::MatrixXd numeric =
        numeric_jacobian<3>([&](const Eigen::VectorXd& c) { return model.predict(x, Control(c), dt); }, u, {2});
    EXPECT_TRUE(jacobian_matches(model.jacobian_control(x, u, dt), numeric));
  });
}

TYPED_TEST(MotionModelProperties, HeadingIsWrapped) {
  int crossings = 0;
  this->for_each_case([&](const TypeParam& model, const Pose2& x, const Control& u, double dt) {
    const Pose2 next = model.predict(x, u, dt);
    EXPECT_TRUE(next.allFinite());
    EXPECT_TRUE(wrapped(next[2])) << next[2];
    crossings += std::abs(next[2] - x[2]) > kPi;
  });
  EXPECT_GT(crossings, 0) << "no sample step turns the heading across +-pi";
}

TYPED_TEST(MotionModelProperties, NoiseCovariancesAreSymmetricPositiveSemidefinite) {
  this->for_each_case([](const TypeParam& model, const Pose2& x, const Control& u, double dt) {
    EXPECT_TRUE(symmetric_positive_semidefinite(model.control_noise(u, dt)));
    EXPECT_TRUE(symmetric_positive_semidefinite(model.process_noise(x, u, dt)));
  });
}

TYPED_TEST(MotionModelProperties, SampledControlsHaveTheStatedCovariance) {
  std::mt19937_64 rng(7);
  for (const TypeParam& model : MotionTraits<TypeParam>::models())
    for (const Control& u : MotionTraits<TypeParam>::controls())
      for (const double dt : MotionTraits<TypeParam>::periods()) {
        std::vector<Eigen::VectorXd> draws(20000);
        for (Eigen::VectorXd& d : draws) d = model.sample_control(u, dt, rng) - u;
        EXPECT_TRUE(covariance_matches(draws, model.control_noise(u, dt))) << "u " << u.transpose() << ", dt " << dt;
      }
}

// ---- Observation models -------------------------------------------------------------------------

/// A model's measurement noise as the simulator draws it: each simulated observation's residual
/// against the noise-free measurement from the true pose, and the R the simulator states for it.
struct NoiseDraws {
  std::vector<Eigen::VectorXd> draws;
  Eigen::MatrixXd stated;
};

/// Every simulated observation's residual against the noise-free measurement from the true pose, for
/// the default scenario with the given sensor.
NoiseDraws simulated_noise_of(SensorKind sensor) {
  Scenario s = scenario("default");
  s.config.sensor = sensor;
  const Dataset data = simulate(s.world, s.config);
  std::map<double, Pose2> pose_at;
  for (const StampedPose& p : data.truth.poses) pose_at[p.t] = p.pose;
  std::map<int, Vector2> landmark;
  for (const Landmark& l : data.truth.landmarks) landmark[l.id] = l.position;
  const ObservationModel& model = *data.observation;
  NoiseDraws noise{{}, model.noise()};
  std::size_t k = 0;
  for (const Event& event : data.events) {
    const auto* scan = std::get_if<ScanEvent>(&event);
    if (scan == nullptr) continue;
    const Pose2& x = pose_at.at(scan->t);
    for (std::size_t i = 0; i < scan->observations.size(); ++i) {
      const Measurement zhat = model.predict(x, landmark.at(data.truth.observation_ids[k][i]));
      noise.draws.emplace_back(model.residual(scan->observations[i].z, zhat));
    }
    ++k;
  }
  return noise;
}

/// For each observation model: `models()` its instances, `landmarks()` the points seen from every
/// sample pose, `angular_rows()` the measurement's angles, and `simulated_noise()`.
template <typename Model>
struct ObservationTraits;

template <>
struct ObservationTraits<RangeBearingModel> {
  static constexpr const char* kName = "RangeBearing";
  static std::vector<RangeBearingModel> models() {
    return {RangeBearingModel{}, RangeBearingModel({.sigma_range = 0.2, .sigma_bearing = 0.01, .offset_x = 3.78,
                                                    .offset_y = 0.5})};
  }
  static std::vector<Vector2> landmarks() {
    return {Vector2(5, 1), Vector2(-3, -7), Vector2(0.5, 12), Vector2(-20, 0.1), Vector2(-20, -0.1)};
  }
  static std::vector<int> angular_rows() { return {1}; }
  static NoiseDraws simulated_noise() { return simulated_noise_of(SensorKind::kRangeBearing); }
};

template <>
struct ObservationTraits<RangeOnlyModel> {
  static constexpr const char* kName = "RangeOnly";
  static std::vector<RangeOnlyModel> models() {
    return {RangeOnlyModel{}, RangeOnlyModel({.sigma_range = 0.5, .offset_x = 3.78, .offset_y = 0.5})};
  }
  static std::vector<Vector2> landmarks() { return ObservationTraits<RangeBearingModel>::landmarks(); }
  static std::vector<int> angular_rows() { return {}; }
  static NoiseDraws simulated_noise() { return simulated_noise_of(SensorKind::kRangeOnly); }
};

template <>
struct ObservationTraits<BearingOnlyModel> {
  static constexpr const char* kName = "BearingOnly";
  static std::vector<BearingOnlyModel> models() {
    return {BearingOnlyModel{}, BearingOnlyModel({.sigma_bearing = 0.01, .offset_x = 3.78, .offset_y = 0.5})};
  }
  static std::vector<Vector2> landmarks() { return ObservationTraits<RangeBearingModel>::landmarks(); }
  static std::vector<int> angular_rows() { return {0}; }
  static NoiseDraws simulated_noise() { return simulated_noise_of(SensorKind::kBearingOnly); }
};


template <typename Model>
class ObservationModelProperties : public ::testing::Test {
 protected:
  using Traits = ObservationTraits<Model>;

  /// Calls check(model, x, m) for every instance, sample pose and landmark.
  template <typename Check>
  void for_each_case(Check check) const {
    for (const Model& model : Traits::models())
      for (const Pose2& x : sample_poses())
        for (const Vector2& m : Traits::landmarks()) {
          SCOPED_TRACE(::testing::Message() << "x " << x.transpose() << ", m " << m.transpose());
          check(model, x, m);
        }
  }
};

using ObservationModels = ::testing::Types<RangeBearingModel, RangeOnlyModel, BearingOnlyModel>;
TYPED_TEST_SUITE(ObservationModelProperties, ObservationModels, TraitsName<ObservationTraits>);

TYPED_TEST(ObservationModelProperties, MeasurementJacobiansMatchCentralDifferences) {
  const std::vector<int> angles = ObservationTraits<TypeParam>::angular_rows();
  this->for_each_case([&](const TypeParam& model, const Pose2& x, const Vector2& m) {
    PoseJacobian hx;
    LandmarkJacobian hm;
    model.jacobians(x, m, hx, hm);
    EXPECT_EQ(model.predict(x, m).size(), model.dim());
    EXPECT_TRUE(jacobian_matches(hx, numeric_jacobian<Eigen::Dynamic>(
                                         [&](const Eigen::VectorXd& s) { return model.predict(s, m); }, x, angles)));
    EXPECT_TRUE(jacobian_matches(hm, numeric_jacobian<Eigen::Dynamic>(
                                         [&](const Eigen::VectorXd& l) { return model.predict(x, l); }, m, angles)));
  });
}

TYPED_TEST(ObservationModelProperties, SensorJacobianMatchesCentralDifferences) {
  this->for_each_case([](const TypeParam& model, const Pose2& x, const Vector2&) {
    EXPECT_TRUE(jacobian_matches(
        model.sensor_jacobian(x),
        numeric_jacobian<2>([&](const Eigen::VectorXd& s) -> Vector2 { return model.sensor_position(s); }, x, {})));
  });
}

// Turning the whole scene about the origin (the invariant error's heading direction, which no
// observation can see) leaves the measurement unchanged, with the sensor off the vehicle's origin
// too: the observation Jacobian in the invariant error has a zero heading column, and it is the
// standard one times T(x)^-1.
TYPED_TEST(ObservationModelProperties, InvariantErrorJacobianHasNoHeadingColumn) {
  this->for_each_case([](const TypeParam& model, const Pose2& x, const Vector2& m) {
    Eigen::VectorXd state(5);
    state << x, m;
    const Eigen::MatrixXd numeric = numeric_jacobian<Eigen::Dynamic>(
        [&](const Eigen::VectorXd& xi) -> Eigen::VectorXd {
          const Eigen::VectorXd moved = group_retract(state, xi);
          return model.predict(moved.head<3>(), moved.tail<2>());
        },
        Eigen::VectorXd::Zero(5), ObservationTraits<TypeParam>::angular_rows());
    EXPECT_LT(numeric.col(2).cwiseAbs().maxCoeff(), 1e-7) << numeric;
    PoseJacobian hx;
    LandmarkJacobian hm;
    model.jacobians(x, m, hx, hm);
    Eigen::MatrixXd h(model.dim(), 5);
    h << hx, hm;
    Eigen::Matrix<double, 5, 5> t = Eigen::Matrix<double, 5, 5>::Identity();
    t.topLeftCorner<3, 3>() = to_invariant(x);
    t(3, 2) = m[1];
    t(4, 2) = -m[0];
    EXPECT_TRUE(jacobian_matches(h * t.inverse(), numeric));
  });
}

// The UKF predicts a sigma point's landmarks together and relies on getting predict's values exactly.
TYPED_TEST(ObservationModelProperties, PredictManyEqualsPredictBitForBit) {
  const std::vector<Vector2> landmarks = ObservationTraits<TypeParam>::landmarks();
  std::vector<Measurement> z(landmarks.size());
  for (const TypeParam& model : ObservationTraits<TypeParam>::models())
    for (const Pose2& x : sample_poses()) {
      model.predict_many(x, landmarks, z);
      for (std::size_t i = 0; i < landmarks.size(); ++i)
        EXPECT_EQ(z[i], model.predict(x, landmarks[i])) << "x " << x.transpose() << ", m " << landmarks[i].transpose();
    }
}

// The inverse where a model has one: a range alone or a bearing alone places no landmark, and such
// a model must say so rather than answer.
TYPED_TEST(ObservationModelProperties, InverseJacobiansMatchCentralDifferences) {
  this->for_each_case([](const TypeParam& model, const Pose2& x, const Vector2& m) {
    const Measurement z = model.predict(x, m);
    const std::optional<InverseObservation> g = model.invert(x, z);
    ASSERT_EQ(g.has_value(), model.invertible());
    if (!g) return;
    const auto at = [&](const Eigen::VectorXd& s, const Eigen::VectorXd& c) -> Vector2 {
      return model.invert(s, c)->position;
    };
    EXPECT_TRUE(jacobian_matches(g->gx, numeric_jacobian<2>([&](const Eigen::VectorXd& s) { return at(s, z); }, x, {})));
    EXPECT_TRUE(jacobian_matches(g->gz, numeric_jacobian<2>([&](const Eigen::VectorXd& c) { return at(x, c); }, z, {})));
  });
}

TYPED_TEST(ObservationModelProperties, BearingsAndResidualsAreWrapped) {
  const std::vector<int> angles = ObservationTraits<TypeParam>::angular_rows();
  std::vector<Measurement> measurements;
  for (const TypeParam& model : ObservationTraits<TypeParam>::models())
    for (const Pose2& x : sample_poses())
      for (const Vector2& m : ObservationTraits<TypeParam>::landmarks()) measurements.push_back(model.predict(x, m));
  const TypeParam model;
  bool straddles = false;
  for (const Measurement& z : measurements) {
    for (const int r : angles) EXPECT_TRUE(wrapped(z[r])) << z.transpose();
    for (const Measurement& zhat : measurements) {
      const Measurement e = model.residual(z, zhat);
      for (int r = 0; r < model.dim(); ++r) {
        if (std::find(angles.begin(), angles.end(), r) == angles.end()) {
          EXPECT_EQ(e[r], z[r] - zhat[r]);
          continue;
        }
        // The difference the short way round.
        EXPECT_TRUE(wrapped(e[r])) << e.transpose();
        EXPECT_NEAR(wrap_angle(e[r] - (z[r] - zhat[r])), 0.0, 1e-12);
        straddles = straddles || std::abs(z[r] - zhat[r]) > kPi;
      }
    }
  }
  EXPECT_TRUE(straddles || angles.empty()) << "no sample pair of measurements straddles +-pi";
}

TYPED_TEST(ObservationModelProperties, InverseIsConsistentWithTheForwardModel) {
  this->for_each_case([](const TypeParam& model, const Pose2& x, const Vector2& m) {
    const Measurement z = model.predict(x, m);
    const std::optional<InverseObservation> g = model.invert(x, z);
    if (!g) return;
    EXPECT_LT((g->position - m).norm(), 1e-10 * (1.0 + m.norm()));
    EXPECT_LT(model.residual(model.predict(x, g->position), z).norm(), 1e-10 * (1.0 + z.norm()));
    // h(x, g(x, z)) = z for all x and z: differentiated, hm gz = I and hx + hm gx = 0.
    PoseJacobian hx;
    LandmarkJacobian hm;
    model.jacobians(x, m, hx, hm);
    EXPECT_LT((hm * g->gz - Eigen::MatrixXd::Identity(model.dim(), model.dim())).norm(), 1e-10);
    EXPECT_LT((hx + hm * g->gx).norm(), 1e-10);
  });
}

TYPED_TEST(ObservationModelProperties, SimulatedNoiseHasTheStatedCovariance) {
  for (const TypeParam& model : ObservationTraits<TypeParam>::models())
    EXPECT_TRUE(symmetric_positive_semidefinite(model.noise()));
  const NoiseDraws noise = ObservationTraits<TypeParam>::simulated_noise();
  ASSERT_GT(noise.draws.size(), 15000u);
  EXPECT_TRUE(covariance_matches(noise.draws, noise.stated));
}

}  // namespace
