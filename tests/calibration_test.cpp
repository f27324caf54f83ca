// calibrate() against logs made here with known errors: a velocity-model robot that carries out its
// commands late, with white velocity noise of known spectral density, measuring landmarks with known
// noise, white or with an error that holds over each pass.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <random>

#include "slamkit/calib/calibration.hpp"
#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/models/velocity_model.hpp"

namespace slamkit {
namespace {

struct TrueErrors {
  double delay = 0.2;                     // s
  double q_v = 2e-4, q_omega = 8e-4;      // m^2/s, rad^2/s
  double sigma_range = 0.05, sigma_bearing = 0.01;
  bool error_held_over_pass = false;  // the measurement error is drawn once per pass of a landmark
};

constexpr double kTruthStep = 0.01;    // s
constexpr double kLogPeriod = 0.02;    // s, odometry rows
constexpr double kScanPeriod = 0.2;    // s
constexpr double kDuration = 600.0;    // s
constexpr double kCommandSpell = 2.0;  // s between command changes

// A robot driving random commands in a field of landmarks, logged as MRCLAM logs it.
Dataset make_log(const TrueErrors& e, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Dataset d;
  d.name = "synthetic";
  d.motion = std::make_shared<VelocityModel>();
  d.observation = std::make_shared<RangeBearingModel>();
  for (int i = 0; i < 40; ++i)
    d.truth.landmarks.push_back({100 + i, Vector2(-8.0 + 16.0 * uniform(rng), -8.0 + 16.0 * uniform(rng)), Matrix2::Zero()});
  const auto steps = static_cast<long>(kDuration / kCommandSpell);
  std::vector<Control> commands;
  for (long i = 0; i < steps; ++i) {
    Control u(2);
    u << 0.05 + 0.15 * uniform(rng), 0.1 + 0.5 * uniform(rng);  // circles of at most 2 m: always in sight
    commands.push_back(u);
  }
  const auto command_at = [&](double t) {
    const auto i = static_cast<long>(std::floor(t / kCommandSpell));
    Control u(2);
    u.setZero();
    if (i >= 0 && i < steps) u = commands[static_cast<std::size_t>(i)];
    return u;
  };
  // The truth: the command of delay seconds ago, plus white noise.
  const VelocityModel model;
  Pose2 x = Pose2::Zero();
  for (double t = 0.0; t <= kDuration + 1e-9; t += kTruthStep) {
    d.truth.poses.push_back({t, x});
    Control u = command_at(t - e.delay);
    u[0] += std::sqrt(e.q_v / kTruthStep) * normal(rng);
    u[1] += std::sqrt(e.q_omega / kTruthStep) * normal(rng);
    x = model.predict(x, u, kTruthStep);
  }
  const auto truth_at = [&](double t) {
    const auto i = std::min(static_cast<std::size_t>(std::llround(t / kTruthStep)), d.truth.poses.size() - 1);
    return d.truth.poses[i].pose;
  };
  // The log: odometry rows and scans, every landmark within 8 m and 35 degrees.
  const RangeBearingModel sensor;
  std::map<int, std::pair<double, Vector2>> held;  // per landmark: last seen, its error this pass
  double t = 0.0;
  for (long k = 1; t < kDuration - 1.0; ++k) {
    const double end = static_cast<double>(k) * kLogPeriod;
    d.events.emplace_back(ControlEvent{end, end - t, command_at(t)});
    t = end;
    if (k % static_cast<long>(std::lround(kScanPeriod / kLogPeriod)) != 0) continue;
    ScanEvent scan{t, {}};
    for (const Landmark& l : d.truth.landmarks) {
      const Vector2 z = sensor.predict(truth_at(t), l.position);
      if (z[0] > 8.0 || std::abs(z[1]) > deg2rad(35.0)) continue;
      Vector2 error(e.sigma_range * normal(rng), e.sigma_bearing * normal(rng));
      if (e.error_held_over_pass) {
        auto [it, fresh] = held.try_emplace(l.id, t, error);
        if (!fresh && t - it->second.first > 2.0) it->second.second = error;
        it->second.first = t;
        error = it->second.second;
      }
      scan.observations.push_back({Vector2(z[0] + error[0], wrap_angle(z[1] + error[1])), l.id});
    }
    if (!scan.observations.empty()) d.events.emplace_back(std::move(scan));
  }
  d.truth.observation_ids = observation_ids(d.events);
  return d;
}

TEST(Calibration, RecoversTheDelayAndTheWhiteNoiseOfAKnownRobot) {
  const TrueErrors e;
  const std::vector<Dataset> logs = {make_log(e, 1), make_log(e, 2)};
  const Calibration c = calibrate(logs);
  EXPECT_NEAR(c.command_delay_s, e.delay, 0.015);
  EXPECT_NEAR(c.motion.q_v, e.q_v, 0.1 * e.q_v);
  EXPECT_NEAR(c.motion.q_omega, e.q_omega, 0.1 * e.q_omega);
  // White measurement noise: each observation is a pass's worth, and batch means is the variance.
  EXPECT_NEAR(c.measurement.sigma_range, e.sigma_range, 0.05 * e.sigma_range);
  EXPECT_NEAR(c.measurement.sigma_bearing, e.sigma_bearing, 0.05 * e.sigma_bearing);
  EXPECT_NEAR(c.rms_range_m, e.sigma_range, 0.05 * e.sigma_range);
  // Gaussian errors beyond the gate's 0.9999: about one in 10,000.
  EXPECT_LT(c.gross_outliers, 10u);
  // The horizons agree on white noise: the same q at every one.
  for (const MotionErrorAtHorizon& row : c.motion_by_horizon) {
    SCOPED_TRACE(row.horizon_s);
    EXPECT_NEAR(row.q_omega, e.q_omega, 0.25 * e.q_omega);
  }
}

TEST(Calibration, WithoutTheDelayTheShortHorizonsSeeTurnRateErrors) {
  TrueErrors e;
  e.delay = 0.0;
  const Calibration prompt = calibrate(std::vector<Dataset>{make_log(e, 3)});
  EXPECT_NEAR(prompt.command_delay_s, 0.0, 0.015);
  e.delay = 0.3;
  const Calibration late = calibrate(std::vector<Dataset>{make_log(e, 3)});
  EXPECT_NEAR(late.command_delay_s, 0.3, 0.015);
  // Measured with the delay found, the motion noise is the robot's, not the delay's.
  EXPECT_NEAR(late.motion.q_omega, prompt.motion.q_omega, 0.15 * prompt.motion.q_omega);
}

// An error that holds over a pass is not averaged away by the pass's observations: the noise a filter
// must assume for each is the pass's error, however many observations share it.
TEST(Calibration, ErrorsHeldOverAPassRaiseTheNoiseToThePasssError) {
  TrueErrors e;
  e.error_held_over_pass = true;
  const Calibration c = calibrate(std::vector<Dataset>{make_log(e, 4)});
  EXPECT_NEAR(c.rms_range_m, e.sigma_range, 0.2 * e.sigma_range);
  // A pass holds many observations with one error, so n (its mean)^2 is n sigma^2 on average.
  EXPECT_GT(c.measurement.sigma_range, 2.0 * c.rms_range_m);
  EXPECT_GT(c.measurement.sigma_bearing, 2.0 * c.rms_bearing_rad);
}

TEST(Calibration, LeavesOutGrossOutliers) {
  const TrueErrors e;
  const Dataset clean = make_log(e, 5);
  Dataset spoilt = clean;
  std::size_t scans = 0, spoiled = 0;
  for (Event& event : spoilt.events)
    if (auto* scan = std::get_if<ScanEvent>(&event); scan && ++scans % 97 == 0) {
      scan->observations.front().z[1] = wrap_angle(scan->observations.front().z[1] + 1.0);
      ++spoiled;
    }
  const Calibration c = calibrate(std::vector<Dataset>{clean});
  const Calibration s = calibrate(std::vector<Dataset>{spoilt});
  EXPECT_EQ(s.gross_outliers, c.gross_outliers + spoiled);
  EXPECT_NEAR(s.measurement.sigma_bearing, c.measurement.sigma_bearing, 0.01 * c.measurement.sigma_bearing);
  EXPECT_NEAR(s.measurement.sigma_range, c.measurement.sigma_range, 0.01 * c.measurement.sigma_range);
}

TEST(Calibration, RefusesALogItCannotMeasure) {
  const TrueErrors e;
  Dataset no_truth = make_log(e, 6);
  no_truth.truth.poses.clear();
  EXPECT_THROW(calibrate(std::vector<Dataset>{no_truth}), InputError);
  Dataset no_landmarks = make_log(e, 6);
  no_landmarks.truth.landmarks.clear();
  EXPECT_THROW(calibrate(std::vector<Dataset>{no_landmarks}), InputError);
  Dataset odometry = make_log(e, 6);
  odometry.motion = std::make_shared<OdometryModel>();
  try {
    calibrate(std::vector<Dataset>{odometry});
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("synthetic"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("velocit"), std::string::npos) << error.what();
  }
  EXPECT_THROW(calibrate(std::vector<Dataset>{}), InputError);
}

}  // namespace
}  // namespace slamkit
