// A range sensor's calibration (offset and scale error) estimated in the state: the EKF's updates
// with it equal a dense Kalman update over [vehicle, calibration, map] written independently here,
// and on simulated worlds whose radio reads long the filter recovers the calibration and the map.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <filesystem>
#include <memory>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "linear_models.hpp"
#include "sim_test_support.hpp"
#include "test_data.hpp"

using namespace slamkit;

namespace {

std::shared_ptr<const MotionModel> motion() {
  return std::make_shared<AckermannModel>(AckermannModel::Params{2.5, 0.3, 0.05});
}

/// The range (1 + s) d + b of landmark rows `l` from the dense state x = [vehicle, b, s, map], and
/// its Jacobian row over the whole state.
struct DensePrediction {
  Measurement z;
  Eigen::MatrixXd h;
};

DensePrediction dense_prediction(const ObservationModel& model, const Eigen::VectorXd& x, Eigen::Index l) {
  PoseJacobian hx;
  LandmarkJacobian hm;
  model.jacobians(x.head<3>(), x.segment<2>(l), hx, hm);
  DensePrediction p{model.predict(x.head<3>(), x.segment<2>(l)), Eigen::MatrixXd::Zero(model.dim(), x.size())};
  p.h.leftCols(3) = hx;
  p.h.middleCols(l, 2) = hm;
  const int range = model.rows().range;
  const double distance = p.z[range];
  p.h.row(range) *= 1.0 + x[4];
  p.h(range, 3) = 1.0;
  p.h(range, 4) = distance;
  p.z[range] = (1.0 + x[4]) * distance + x[3];
  return p;
}

/// The dense EKF update of x and P with the observations zs of the landmarks whose rows start at
/// `offsets`, all linearised at the prior: x += K (z - h), P -= K S K^T.
void dense_update(const ObservationModel& model, Eigen::VectorXd& x, Eigen::MatrixXd& p,
                  const std::vector<Eigen::Index>& offsets, const std::vector<Measurement>& zs) {
  const int d = model.dim();
  const auto k = static_cast<Eigen::Index>(d * zs.size());
  Eigen::MatrixXd h(k, x.size());
  Eigen::VectorXd nu(k);
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(k, k);
  for (std::size_t i = 0; i < zs.size(); ++i) {
    const DensePrediction prediction = dense_prediction(model, x, offsets[i]);
    const auto row = static_cast<Eigen::Index>(d * i);
    h.middleRows(row, d) = prediction.h;
    nu.segment(row, d) = model.residual(zs[i], prediction.z);
    r.block(row, row, d, d) = model.noise();
  }
  const Eigen::MatrixXd s = h * p * h.transpose() + r;
  const Eigen::MatrixXd gain = p * h.transpose() * s.inverse();
  x += gain * nu;
  p -= gain * s * gain.transpose();
}

void expect_near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tolerance) {
  ASSERT_EQ(a.rows(), b.rows());
  ASSERT_EQ(a.cols(), b.cols());
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), tolerance) << "\n" << a << "\n\n" << b;
}

}  // namespace

TEST(RangeCalibration, JointGaussianUpdatesEqualTheDenseKalmanUpdateWithTheCalibrationInTheState) {
  const auto model = std::make_shared<RangeBearingModel>();
  JointGaussian filter(motion(), model, Pose2(1.0, 2.0, 0.3), Matrix3::Identity() * 1e-3);
  filter.estimate_range_calibration(
      {.offset_m = 0.4, .offset_std_m = 0.5, .scale_error = 0.03, .scale_error_std = 0.02});
  ASSERT_TRUE(filter.calibrates_ranges());
  EXPECT_EQ(filter.num_landmarks(), 0u);
  // A landmark started from a range read through the calibration moves with it: the dense start
  // from [vehicle, b, s] with m = g(x, (z - b) / (1 + s)).
  const Measurement z0 = Measurement{{8.0, 0.4}};
  Eigen::VectorXd x = filter.state();
  Eigen::MatrixXd p = filter.covariance();
  filter.add_landmark(z0);
  {
    Measurement distance = z0;
    distance[0] = (z0[0] - x[3]) / (1.0 + x[4]);
    const InverseObservation g = *model->invert(x.head<3>(), distance);
    Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(7, 5);
    jacobian.topLeftCorner(5, 5).setIdentity();
    jacobian.block<2, 3>(5, 0) = g.gx;
    jacobian.block<2, 1>(5, 3) = -g.gz.col(0) / (1.0 + x[4]);
    jacobian.block<2, 1>(5, 4) = -g.gz.col(0) * distance[0] / (1.0 + x[4]);
    Eigen::MatrixXd added = Eigen::MatrixXd::Zero(7, 7);
    added.bottomRightCorner(2, 2) = g.gz * Eigen::MatrixXd(model->noise()) * g.gz.transpose();
    Eigen::VectorXd expected_x(7);
    expected_x << x, g.position;
    expect_near(filter.state(), expected_x, 1e-12);
    expect_near(filter.covariance(), jacobian * p * jacobian.transpose() + added, 1e-12);
  }
  filter.add_landmark(Measurement{{12.0, -0.7}});
  filter.predict(Control{{2.0, 0.05}}, 0.5);
  filter.predict(Control{{2.0, -0.02}}, 0.5);

  // One observation: the estimator's prediction, innovation covariance and update.
  x = filter.state();
  p = filter.covariance();
  const Measurement z1 = Measurement{{7.1, 0.35}};
  Measurement zhat;
  MeasurementCovariance s;
  filter.innovation(0, zhat, s);
  const DensePrediction prediction = dense_prediction(*model, x, 5);
  expect_near(zhat, prediction.z, 1e-12);
  expect_near(s, prediction.h * p * prediction.h.transpose() + Eigen::MatrixXd(model->noise()), 1e-12);
  ASSERT_TRUE(filter.update_landmark(0, z1));
  dense_update(*model, x, p, {5}, {z1});
  expect_near(filter.state(), x, 1e-10);
  expect_near(filter.covariance(), p, 1e-10);

  // A joint update of both landmarks: the dense update of the stacked measurement.
  const Measurement z2 = Measurement{{11.5, -0.75}};
  const Measurement z3 = Measurement{{6.8, 0.33}};
  const LandmarkObservation batch[] = {{1, z2}, {0, z3}};
  ASSERT_TRUE(filter.update_landmarks(batch));
  dense_update(*model, x, p, {7, 5}, {z2, z3});
  expect_near(filter.state(), x, 1e-10);
  expect_near(filter.covariance(), p, 1e-10);
  // The calibration stays between the vehicle and the map when a landmark leaves.
  const Eigen::VectorXd before = filter.state();
  filter.remove_landmark(0);
  EXPECT_EQ(filter.num_landmarks(), 1u);
  EXPECT_EQ(filter.state().head(5), before.head(5));
  EXPECT_EQ(filter.state().tail(2), before.tail(2));
}

// The iterated EKF relinearises the calibration with the rest: its result is the dense Gauss-Newton
// iterate x_{i+1} = x + K_i (z - h(x_i) - H_i (x - x_i)) at convergence.
TEST(RangeCalibration, TheIteratedUpdateRelinearisesTheCalibration) {
  const auto model = std::make_shared<RangeBearingModel>();
  JointGaussian filter(motion(), model, Pose2(0.0, 0.0, 0.1), Matrix3::Identity() * 1e-2, Linearisation::kStandard,
                       JointGaussian::kMaxUpdateIterations);
  filter.estimate_range_calibration(
      {.offset_m = 0.0, .offset_std_m = 1.0, .scale_error = 0.0, .scale_error_std = 0.05});
  filter.add_landmark(Measurement{{9.0, 0.5}});
  filter.add_landmark(Measurement{{14.0, -0.4}});
  filter.predict(Control{{3.0, 0.1}}, 1.0);
  const Eigen::VectorXd x0 = filter.state();
  const Eigen::MatrixXd p0 = filter.covariance();
  const std::vector<Eigen::Index> offsets = {5, 7};
  const std::vector<Measurement> zs = {Measurement{{8.2, 0.75}}, Measurement{{12.1, -0.52}}};
  const LandmarkObservation batch[] = {{0, zs[0]}, {1, zs[1]}};
  ASSERT_TRUE(filter.update_landmarks(batch));

  Eigen::VectorXd xi = x0;
  Eigen::MatrixXd gain, h;
  for (int iteration = 0; iteration < 100; ++iteration) {
    h.resize(4, x0.size());
    Eigen::VectorXd nu(4);
    for (int i = 0; i < 2; ++i) {
      const DensePrediction prediction = dense_prediction(*model, xi, offsets[static_cast<std::size_t>(i)]);
      h.middleRows(2 * i, 2) = prediction.h;
      nu.segment<2>(2 * i) = model->residual(zs[static_cast<std::size_t>(i)], prediction.z);
    }
    Eigen::MatrixXd r = Eigen::MatrixXd::Zero(4, 4);
    r.topLeftCorner(2, 2) = model->noise();
    r.bottomRightCorner(2, 2) = model->noise();
    gain = p0 * h.transpose() * (h * p0 * h.transpose() + r).inverse();
    const Eigen::VectorXd next = x0 + gain * (nu - h * (x0 - xi));
    const double moved = (next - xi).cwiseAbs().maxCoeff();
    xi = next;
    if (moved < 1e-12) break;
  }
  expect_near(filter.state(), xi, 1e-6);
  expect_near(filter.covariance(), p0 - gain * h * p0, 1e-6);
  EXPECT_GT((filter.state() - x0).segment<2>(3).norm(), 1e-3) << "the observations move the calibration";
}

TEST(RangeCalibration, IsRefusedWhereItCannotBeKept) {
  JointGaussian bearing_only(motion(), std::make_shared<BearingOnlyModel>());
  EXPECT_THROW(bearing_only.estimate_range_calibration({}), std::invalid_argument);
  JointGaussian range_only(motion(), std::make_shared<RangeOnlyModel>());
  EXPECT_THROW(range_only.estimate_range_calibration({.offset_std_m = 0.0}), std::invalid_argument);
  EXPECT_THROW(range_only.estimate_range_calibration({.scale_error = 0.7}), std::invalid_argument);
  range_only.estimate_range_calibration({});
  EXPECT_THROW(range_only.estimate_range_calibration({}), std::logic_error) << "once";
  EkfSlamOptions options;
  options.range_calibration = RangeCalibrationPrior{};
  options.association.method = AssociationMethod::kNearestNeighbour;
  EXPECT_THROW(EkfSlam(motion(), std::make_shared<RangeBearingModel>(), options), std::invalid_argument)
      << "nn predicts measurements without the calibration";
  options.association.method = AssociationMethod::kKnown;
  options.variant = EkfVariant::kCompressed;
  EXPECT_THROW(EkfSlam(motion(), std::make_shared<RangeBearingModel>(), options), std::invalid_argument);
  options.variant = EkfVariant::kUnscented;
  EXPECT_THROW(EkfSlam(motion(), std::make_shared<RangeBearingModel>(), options), std::invalid_argument);
}

namespace {

struct CalibratedRun {
  Metrics metrics;
  std::map<std::string, double> statistics;
};

constexpr double kOffset = 1.5, kScaleError = 0.05;

CalibratedRun run_long_reading(SensorKind sensor, EkfVariant variant, bool calibrate, std::uint64_t seed) {
  Scenario s = scenario("default");
  s.config.sensor = sensor;
  s.config.range_offset = kOffset;
  s.config.range_scale_error = kScaleError;
  s.config.seed = seed;
  const Dataset d = simulate(s.world, s.config);
  EkfSlamOptions options = test_sim::ekf_options_for(d, variant);
  if (calibrate) options.range_calibration = RangeCalibrationPrior{.offset_std_m = 3.0, .scale_error_std = 0.1};
  EkfSlam filter(d.motion, d.observation, options);
  CalibratedRun out;
  out.metrics = evaluate_run(run_filter(filter, d), d.truth);
  out.statistics = filter.statistics();
  return out;
}

}  // namespace

// The reference world through a radio that reads 5% plus 1.5 m long, unknown to the filter (priors
// 0 +- 3 m and 0 +- 0.1): calibrated, the filter finds both within their 99.99% intervals, its
// map and path are at most half as far off as those of the first-estimates EKF that ignores them,
// and it stays consistent.
TEST(RangeCalibration, ARadioThatReadsLongIsCalibratedWhileItMaps) {
  for (const SensorKind sensor : {SensorKind::kRangeOnly, SensorKind::kRangeBearing}) {
    const CalibratedRun ignored = run_long_reading(sensor, EkfVariant::kFirstEstimates, false, 2);
    for (const EkfVariant variant : {EkfVariant::kFirstEstimates, EkfVariant::kInvariant}) {
      SCOPED_TRACE(to_string(sensor) + (variant == EkfVariant::kInvariant ? " invariant" : " fej"));
      const CalibratedRun calibrated = run_long_reading(sensor, variant, true, 2);
      const auto& st = calibrated.statistics;
      // Within the 99.99% interval (3.9 standard deviations) of one Gaussian quantity.
      EXPECT_LT(std::abs(st.at("range_offset_m") - kOffset), 3.9 * st.at("range_offset_std_m"));
      EXPECT_LT(std::abs(st.at("range_scale_error") - kScaleError), 3.9 * st.at("range_scale_error_std"));
      ASSERT_TRUE(calibrated.metrics.map_rmse_m && ignored.metrics.map_rmse_m && calibrated.metrics.nees_pose);
      EXPECT_LT(*calibrated.metrics.map_rmse_m, 0.5 * *ignored.metrics.map_rmse_m);
      EXPECT_LT(*calibrated.metrics.ate_rmse_m, 0.5 * *ignored.metrics.ate_rmse_m);
      EXPECT_GE(calibrated.metrics.nees_pose->in_interval_fraction, 0.8);
    }
  }
}

namespace {

/// Every one of Plaza1's four beacons within 0.5 m of the survey, the scale error near the data's
/// 7%, and what the calibration adds at the ranges' median distance near their median excess.
void expect_plaza1_beacons_and_calibration(const RunResult& run, const Metrics& m, const Dataset& d) {
  ASSERT_EQ(run.map.size(), 4u);
  for (const Landmark& beacon : run.map) {
    const auto surveyed = std::find_if(d.truth.landmarks.begin(), d.truth.landmarks.end(),
                                       [&](const Landmark& t) { return t.id == beacon.id; });
    ASSERT_NE(surveyed, d.truth.landmarks.end());
    EXPECT_LT((m.alignment.apply(beacon.position) - surveyed->position).norm(), 0.5) << "beacon " << beacon.id;
  }
  const auto& st = m.filter_statistics;
  EXPECT_NEAR(st.at("range_scale_error"), 0.07, 0.01);
  EXPECT_NEAR(st.at("range_offset_m") + 40.9 * st.at("range_scale_error"), 2.85, 0.4);
}

}  // namespace

// CMU Plaza1: four radio beacons, started with no prior from ranges alone, which read 7% long
// (range minus true distance: median +2.85 m at a median distance of 40.9 m; fitted against the
// ground truth, 1.069 times the distance plus 0.03 m, each beacon alike). Calibrated, the
// consistent variants find a scale error near it and an offset near zero, and put every beacon
// within 0.5 m of the survey.
TEST(RangeCalibration, Plaza1BeaconsLandWithinHalfAMetreOfTheSurvey) {
  const std::filesystem::path dir = test_data::shared_dataset("plaza_range_only");
  SLAMKIT_REQUIRE_DATASET(dir);
  const Dataset d = load_dataset("plaza:" + dir.string() + ":Plaza1");
  for (const EkfVariant variant : {EkfVariant::kFirstEstimates, EkfVariant::kInvariant}) {
    SCOPED_TRACE(variant == EkfVariant::kInvariant ? "invariant" : "fej");
    EkfSlamOptions options = test_sim::ekf_options_for(d, variant);
    options.range_calibration = RangeCalibrationPrior{};
    EkfSlam filter(d.motion, d.observation, options);
    const RunResult run = run_filter(filter, d);
    const Metrics m = evaluate_run(run, d.truth);
    ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m);
    EXPECT_LT(*m.ate_rmse_m, 0.5);
    EXPECT_LT(*m.ate_rmse_m, 0.35 * *m.dead_reckoning_ate_rmse_m);
    expect_plaza1_beacons_and_calibration(run, m, d);
    EXPECT_LT(std::abs(m.filter_statistics.at("range_offset_m")), 0.5);
  }
}

namespace {

FastSlamConfig fastslam_for(const Dataset& d, int particles) {
  FastSlamConfig c = test_sim::fastslam_config_for(d, 2, particles);
  c.initialisation = LandmarkInitialisation::kDelayed;
  return c;
}

}  // namespace

TEST(RangeCalibration, FastSlamKeepsItOnlyWhereItsProposalAndTheDelayedStartCan) {
  const auto range_only = std::make_shared<RangeOnlyModel>();
  FastSlamConfig c;
  c.initialisation = LandmarkInitialisation::kDelayed;
  c.range_calibration = RangeCalibrationPrior{};
  EXPECT_NO_THROW(FastSlam(motion(), range_only, c));
  FastSlamConfig one = c;
  one.version = 1;
  EXPECT_THROW(FastSlam(motion(), range_only, one), std::invalid_argument) << "FastSLAM 1.0 proposes from the motion";
  FastSlamConfig ring = c;
  ring.initialisation = LandmarkInitialisation::kRing;
  EXPECT_THROW(FastSlam(motion(), range_only, ring), std::invalid_argument);
  FastSlamConfig immediate = c;
  immediate.initialisation = LandmarkInitialisation::kImmediate;
  EXPECT_THROW(FastSlam(motion(), std::make_shared<RangeBearingModel>(), immediate), std::invalid_argument);
  FastSlamConfig nn = c;
  nn.initialisation.reset();
  nn.association.method = AssociationMethod::kNearestNeighbour;
  EXPECT_THROW(FastSlam(motion(), std::make_shared<RangeBearingModel>(), nn), std::invalid_argument);
  EXPECT_THROW(FastSlam(motion(), std::make_shared<BearingOnlyModel>(), c), std::invalid_argument);
}

// One FastSLAM 2.0 particle on a known path (odometry without noise) is a Kalman filter over the
// calibration and its map: keeping the calibration's Gaussian and each landmark's given it, an
// observation updating only the calibration and its own landmark, must give what a dense extended
// Kalman filter over (offset, scale error, every landmark) gives, linearised at the same means.
TEST(RangeCalibration, OneFastSlamParticleOnAKnownPathEqualsTheDenseFilter) {
  const auto radio = std::make_shared<RangeOnlyModel>(RangeOnlyModel::Params{.sigma_range = 0.3});
  FastSlamConfig c;
  c.particles = 1;
  c.threads = 1;
  c.initialisation = LandmarkInitialisation::kDelayed;
  c.range_calibration = RangeCalibrationPrior{.offset_m = 0.2, .offset_std_m = 1.0, .scale_error_std = 0.1};
  FastSlam filter(std::make_shared<test_models::LinearMotion>(Matrix3::Zero()), radio, c);
  const std::vector<Landmark> map = {{0, Vector2(10.0, 5.0), Vector2(0.5, 0.3).asDiagonal()},
                                     {1, Vector2(-3.0, 12.0), (Matrix2() << 0.8, 0.2, 0.2, 0.4).finished()}};
  filter.set_initial_map(map);

  // The dense filter: y = (b, s, m0, m1).
  Eigen::VectorXd y(6);
  y << 0.2, 0.0, map[0].position, map[1].position;
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(6, 6);
  p.diagonal().head<2>() << 1.0, 0.01;
  p.block<2, 2>(2, 2) = map[0].covariance;
  p.block<2, 2>(4, 4) = map[1].covariance;
  Pose2 x = Pose2::Zero();
  const double ranges[3][2] = {{12.3, 14.1}, {11.6, 13.2}, {11.9, 14.8}};
  for (const auto& scan_ranges : ranges) {
    const ControlEvent control{0.0, 1.0, Eigen::Vector3d(1.5, 0.5, 0.1)};
    filter.predict(control);
    x += control.u;
    ScanEvent scan;
    for (int id = 0; id < 2; ++id) {
      scan.observations.push_back({Measurement::Constant(1, scan_ranges[id]), id});
      const Vector2 delta = y.segment<2>(2 + 2 * id) - x.head<2>();
      const double d = delta.norm();
      Eigen::RowVectorXd h = Eigen::RowVectorXd::Zero(6);
      h(0) = 1.0;
      h(1) = d;
      h.segment<2>(2 + 2 * id) = (1.0 + y(1)) * delta.transpose() / d;
      const double innovation = scan_ranges[id] - ((1.0 + y(1)) * d + y(0));
      const double s = (h * p * h.transpose())(0, 0) + 0.09;
      const Eigen::VectorXd gain = p * h.transpose() / s;
      y += gain * innovation;
      p = (Eigen::MatrixXd::Identity(6, 6) - gain * h) * p;
    }
    filter.update(scan);
  }
  const auto st = filter.statistics();
  EXPECT_NEAR(st.at("range_offset_m"), y(0), 1e-9);
  EXPECT_NEAR(st.at("range_scale_error"), y(1), 1e-9);
  EXPECT_NEAR(st.at("range_offset_std_m"), std::sqrt(p(0, 0)), 1e-9);
  EXPECT_NEAR(st.at("range_scale_error_std"), std::sqrt(p(1, 1)), 1e-9);
  const std::vector<Landmark> out = filter.landmarks();
  ASSERT_EQ(out.size(), 2u);
  for (const Landmark& lm : out) {
    EXPECT_TRUE(lm.position.isApprox(y.segment<2>(2 + 2 * lm.id), 1e-9)) << lm.id;
    EXPECT_TRUE(lm.covariance.isApprox(p.block<2, 2>(2 + 2 * lm.id, 2 + 2 * lm.id), 1e-8)) << lm.id;
  }
  EXPECT_GT(std::abs(y(1)), 1e-3) << "the ranges move the calibration";
}

// The same on a known circle where the landmark starts through the delayed start, read through a
// calibration other than zero: the particle's landmark starts with the gain in the calibration the
// EKF gives its correlation (dm/dc = -(range_gain, range_scale_gain) / (1 + s)), and the two filters,
// updating one range at a time, end equal.
TEST(RangeCalibration, AFastSlamLandmarkPlacedThroughTheCalibrationMovesWithItAsTheEkfs) {
  const auto radio = std::make_shared<RangeOnlyModel>(RangeOnlyModel::Params{.sigma_range = 0.2});
  const auto odometry = std::make_shared<test_models::LinearMotion>(Matrix3::Zero());
  const RangeCalibrationPrior prior{.offset_m = 0.8, .offset_std_m = 0.5, .scale_error = 0.03, .scale_error_std = 0.05};
  EkfSlamOptions ekf_options;
  ekf_options.initialisation = LandmarkInitialisation::kDelayed;
  ekf_options.range_calibration = prior;
  ekf_options.joint_scan_update = false;
  ekf_options.association.gate_known = false;
  ekf_options.threads = 1;
  EkfSlam ekf(odometry, radio, ekf_options);
  FastSlamConfig c;
  c.particles = 1;
  c.threads = 1;
  c.range_calibration = prior;
  FastSlam particle(odometry, radio, c);
  const Vector2 beacon(3.0, 8.0);
  Pose2 x = Pose2::Zero();
  for (int k = 0; k < 40; ++k) {
    const ControlEvent control{k + 1.0, 1.0, Eigen::Vector3d(std::cos(0.2 * k), std::sin(0.2 * k), 0.0)};
    ekf.predict(control);
    particle.predict(control);
    x += control.u;
    // Ranges 4% plus 1 m long, with a fixed wobble for noise.
    const double range = 1.04 * (beacon - x.head<2>()).norm() + 1.0 + 0.15 * std::sin(1.7 * k);
    const ScanEvent scan{control.t, {{Measurement::Constant(1, range), 0}}};
    ekf.update(scan);
    particle.update(scan);
  }
  const std::vector<Landmark> a = ekf.landmarks(), b = particle.landmarks();
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_TRUE(b[0].position.isApprox(a[0].position, 1e-8)) << b[0].position.transpose() << " / "
                                                            << a[0].position.transpose();
  EXPECT_TRUE(b[0].covariance.isApprox(a[0].covariance, 1e-7));
  const auto sa = ekf.statistics(), sb = particle.statistics();
  for (const char* key : {"range_offset_m", "range_offset_std_m", "range_scale_error", "range_scale_error_std"})
    EXPECT_NEAR(sb.at(key), sa.at(key), 1e-8) << key;
  EXPECT_GT(std::abs(sb.at("range_offset_m") - prior.offset_m), 1e-3) << "the ranges move the calibration";
}

// FastSLAM 2.0 with the radio that reads 5% plus 1.5 m long, seen with bearings: each particle's
// calibration, with its landmarks' Gaussians given it, finds the offset within 0.1 m and the scale
// error within half of itself, and its map is at most half as far off as that of FastSLAM 2.0
// ignoring them. (Given a particle's path the calibration is learnt as if that path were true, so
// the scale error comes out short by a tenth to a third and its deviation far too small: the
// FastSLAM inconsistency resampling brings about; docs/sensing.md.)
TEST(RangeCalibration, FastSlamCalibratesARadioThatReadsLongWhileItMaps) {
  Scenario s = scenario("default");
  s.config.range_offset = kOffset;
  s.config.range_scale_error = kScaleError;
  s.config.seed = 2;
  const Dataset d = simulate(s.world, s.config);
  FastSlam ignoring(d.motion, d.observation, fastslam_for(d, 30));
  const Metrics ignored = evaluate_run(run_filter(ignoring, d), d.truth);
  FastSlamConfig c = fastslam_for(d, 30);
  c.range_calibration = RangeCalibrationPrior{.offset_std_m = 3.0, .scale_error_std = 0.1};
  FastSlam calibrating(d.motion, d.observation, c);
  const Metrics calibrated = evaluate_run(run_filter(calibrating, d), d.truth);
  const auto& st = calibrated.filter_statistics;
  EXPECT_NEAR(st.at("range_offset_m"), kOffset, 0.1);
  EXPECT_NEAR(st.at("range_scale_error"), kScaleError, 0.5 * kScaleError);
  ASSERT_TRUE(calibrated.map_rmse_m && ignored.map_rmse_m && calibrated.ate_rmse_m && ignored.ate_rmse_m);
  EXPECT_LT(*calibrated.map_rmse_m, 0.5 * *ignored.map_rmse_m);
  EXPECT_LT(*calibrated.ate_rmse_m, *ignored.ate_rmse_m);
}

// Plaza1 with FastSLAM 2.0 (100 particles, the proposal sampled in full: the defaults), beacons
// started with no prior: it beats dead reckoning, every beacon lands within 0.5 m of the survey,
// and the calibration adds what the ranges' excess is at their median distance.
TEST(RangeCalibration, Plaza1FastSlamBeaconsLandWithinHalfAMetreOfTheSurvey) {
  const std::filesystem::path dir = test_data::shared_dataset("plaza_range_only");
  SLAMKIT_REQUIRE_DATASET(dir);
  const Dataset d = load_dataset("plaza:" + dir.string() + ":Plaza1");
  FastSlamConfig c = fastslam_for(d, 100);
  c.range_calibration = RangeCalibrationPrior{};
  FastSlam filter(d.motion, d.observation, c);
  const RunResult run = run_filter(filter, d);
  const Metrics m = evaluate_run(run, d.truth);
  ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m);
  EXPECT_LT(*m.ate_rmse_m, *m.dead_reckoning_ate_rmse_m);
  expect_plaza1_beacons_and_calibration(run, m, d);
}
