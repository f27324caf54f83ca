// The Student-t measurement likelihood: its density and noise inflation, the EKF estimators' update
// with an inflated R, the delayed start that leaves outliers out, the simulator's multipath ranges,
// and range-only SLAM on a world whose radio reads long one time in ten.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <variant>

#include "sim_test_support.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/filters/compressed_joint_gaussian.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/filters/landmark_initialiser.hpp"
#include "slamkit/filters/unscented_joint_gaussian.hpp"
#include "slamkit/models/measurement_likelihood.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"

using namespace slamkit;

namespace {

MeasurementLikelihood student_t(double dof = 4.0) { return {LikelihoodKind::kStudentT, dof}; }
MeasurementLikelihood student_t_long(double dof = 4.0) { return {LikelihoodKind::kStudentTLong, dof}; }

}  // namespace

TEST(MeasurementLikelihood, TheGaussianNeverInflatesAndTheTOnlyBeyondTheMeasurementsDimension) {
  const MeasurementLikelihood gaussian;
  EXPECT_EQ(gaussian.noise_inflation(100.0, 1), 1.0);
  const MeasurementLikelihood t = student_t(4.0);
  EXPECT_EQ(t.noise_inflation(0.5, 1), 1.0);
  EXPECT_EQ(t.noise_inflation(2.0, 2), 1.0);
  EXPECT_DOUBLE_EQ(t.noise_inflation(9.0, 1), 13.0 / 5.0);
  EXPECT_DOUBLE_EQ(t.noise_inflation(16.0, 2), 20.0 / 6.0);
  EXPECT_EQ(t.noise_inflation(std::nan(""), 1), 1.0) << "no NaN passed on to R";
}

TEST(MeasurementLikelihood, TheTDensityIntegratesToOneHasHeavyTailsAndTendsToTheGaussian) {
  // In one dimension with S = s^2, over the innovation nu: m2 = nu^2 / s^2, log|S| = 2 log s.
  const double s = 0.7;
  for (const double dof : {1.0, 4.0, 30.0}) {
    const MeasurementLikelihood t = student_t(dof);
    double integral = 0.0;
    const double step = 1e-2;
    for (double nu = -2000.0; nu <= 2000.0; nu += step)
      integral += std::exp(t.log_density(nu * nu / (s * s), 1, 2.0 * std::log(s))) * step;
    // The Cauchy's tails beyond 2000 s hold 2 / (pi 2857) of its mass.
    EXPECT_NEAR(integral, 1.0, dof == 1.0 ? 3e-4 : 1e-6) << "dof " << dof;
  }
  const MeasurementLikelihood gaussian;
  EXPECT_NEAR(gaussian.log_density(2.5, 2, 0.3), -1.25 - std::log(2.0 * std::numbers::pi) - 0.15, 1e-14);
  EXPECT_GT(student_t().log_density(25.0, 1, 0.0), gaussian.log_density(25.0, 1, 0.0) + 5.0)
      << "five standard deviations out, the t is far likelier";
  EXPECT_NEAR(student_t(1e7).log_density(3.0, 2, 0.4), gaussian.log_density(3.0, 2, 0.4), 1e-5);
}

TEST(MeasurementLikelihood, NamesRoundTripAndDegreesOfFreedomMustBePositiveAndFinite) {
  for (const LikelihoodKind kind : {LikelihoodKind::kGaussian, LikelihoodKind::kStudentT, LikelihoodKind::kStudentTLong})
    EXPECT_EQ(parse_likelihood_kind(to_string(kind)), kind);
  EXPECT_THROW(parse_likelihood_kind("cauchy"), std::invalid_argument);
  for (const double dof : {0.0, -1.0, std::numeric_limits<double>::infinity(), std::nan("")})
    EXPECT_THROW(validate(student_t(dof)), std::invalid_argument) << dof;
  EkfSlamOptions options;
  options.likelihood = student_t(0.0);
  EXPECT_THROW(EkfSlam(std::make_shared<AckermannModel>(), std::make_shared<RangeOnlyModel>(), options),
               std::invalid_argument);
  FastSlamConfig config;
  config.likelihood = student_t(-2.0);
  EXPECT_THROW(FastSlam(std::make_shared<AckermannModel>(), std::make_shared<RangeOnlyModel>(), config),
               std::invalid_argument);
}

// Only a range can be read long: the one-sided t on a bearing-only sensor is a usage error naming the
// likelihood that fits, for both filter families; with ranges it is accepted.
TEST(MeasurementLikelihood, TheOneSidedTNeedsASensorThatMeasuresRange) {
  EkfSlamOptions options;
  options.likelihood = student_t_long();
  try {
    EkfSlam(std::make_shared<AckermannModel>(), std::make_shared<BearingOnlyModel>(), options);
    ADD_FAILURE() << "accepted a bearing-only sensor";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("use 'student-t'"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(EkfSlam(std::make_shared<AckermannModel>(), std::make_shared<RangeOnlyModel>(), options));
  EXPECT_NO_THROW(EkfSlam(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>(), options));
  FastSlamConfig config;
  config.likelihood = student_t_long();
  EXPECT_THROW(FastSlam(std::make_shared<AckermannModel>(), std::make_shared<BearingOnlyModel>(), config),
               std::invalid_argument);
  EXPECT_NO_THROW(FastSlam(std::make_shared<AckermannModel>(), std::make_shared<RangeOnlyModel>(), config));
}

// An update with R scaled by k is the update of a sensor whose noise is k times R: for every
// estimator, alone and in a joint update.
TEST(NoiseScale, UpdatesAsASensorWithThatMuchMoreNoise) {
  const auto motion = std::make_shared<AckermannModel>();
  const auto sensor = std::make_shared<RangeBearingModel>();
  const auto noisier = std::make_shared<RangeBearingModel>(
      RangeBearingModel::Params{.sigma_range = 0.2, .sigma_bearing = 2.0 * deg2rad(1.0)});
  using Make = std::function<std::unique_ptr<EkfEstimator>(std::shared_ptr<const ObservationModel>)>;
  const std::pair<std::string, Make> estimators[] = {
      {"full", [&](auto o) -> std::unique_ptr<EkfEstimator> { return std::make_unique<JointGaussian>(motion, o); }},
      {"fej",
       [&](auto o) -> std::unique_ptr<EkfEstimator> {
         return std::make_unique<JointGaussian>(motion, o, Pose2::Zero(), Matrix3::Zero(),
                                                Linearisation::kFirstEstimates);
       }},
      {"compressed",
       [&](auto o) -> std::unique_ptr<EkfEstimator> { return std::make_unique<CompressedJointGaussian>(motion, o, 30.0); }},
      {"ukf",
       [&](auto o) -> std::unique_ptr<EkfEstimator> { return std::make_unique<UnscentedJointGaussian>(motion, o); }},
  };
  for (const auto& [name, make] : estimators) {
    SCOPED_TRACE(name);
    const std::unique_ptr<EkfEstimator> scaled = make(sensor), reference = make(noisier);
    for (EkfEstimator* e : {scaled.get(), reference.get()}) {
      e->predict(Control{{2.0, 0.1}}, 1.0);
      for (const Vector2 m : {Vector2(9.0, 4.0), Vector2(10.0, -6.0)}) {
        InitialLandmark l;
        l.mean = m;
        l.gx = attached_to_pose(e->pose(), m);
        l.covariance << 0.3, 0.05, 0.05, 0.2;
        e->add_landmark(l);
      }
      e->predict(Control{{2.0, -0.05}}, 1.0);
      e->begin_scan();
    }
    ASSERT_TRUE(scaled->update_landmark({0, Measurement{{6.9, 0.45}}, 4.0}));
    ASSERT_TRUE(reference->update_landmark(0, Measurement{{6.9, 0.45}}));
    const LandmarkObservation batch[] = {{1, Measurement{{9.6, -0.71}}, 4.0}, {0, Measurement{{7.2, 0.40}}, 4.0}};
    const LandmarkObservation plain[] = {{1, Measurement{{9.6, -0.71}}}, {0, Measurement{{7.2, 0.40}}}};
    ASSERT_TRUE(scaled->update_landmarks(batch));
    ASSERT_TRUE(reference->update_landmarks(plain));
    EXPECT_LT((scaled->state() - reference->state()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((scaled->covariance() - reference->covariance()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// Exact ranges from spread poses, two of them read long: where outliers are expected the start
// leaves them out and places the beacon exactly; more than a quarter of outliers and it waits.
TEST(DelayedInitialiser, WhereOutliersAreExpectedLeavesThemOutOfTheFit) {
  const auto model = std::make_shared<RangeOnlyModel>();
  const Vector2 m(6.0, 9.0);
  const auto offer_all = [&](DelayedInitialiser& init, const std::vector<int>& misread, double excess = 4.0) {
    std::optional<InitialLandmark> placed;
    for (int i = 0; i < 12 && !placed; ++i) {
      const Pose2 x(2.0 * i, 0.2 * i * i - 3.0, 0.1 * i);
      Measurement z = model->predict(x, m);
      // Read long by a longer path, or short where the excess is negative.
      if (std::find(misread.begin(), misread.end(), i) != misread.end()) z[0] += excess;
      placed = init.offer(3, x, Matrix3::Zero(), z, static_cast<double>(i), RangeCorrection{});
    }
    return placed;
  };
  DelayedInitialisationOptions options;
  options.min_views = 12;  // judged once, on all twelve
  options.outliers_expected = true;
  DelayedInitialiser robust(model, options);
  const std::optional<InitialLandmark> l = offer_all(robust, {1, 6});
  ASSERT_TRUE(l.has_value());
  EXPECT_LT((l->mean - m).norm(), 1e-6);
  DelayedInitialiser crowded(model, options);
  EXPECT_FALSE(offer_all(crowded, {1, 3, 5, 7, 9})) << "five of twelve long: more than a quarter";
  EXPECT_EQ(crowded.waiting(), 1u);

  // Where only long ranges are outliers, the two read long are left out as before, but two read
  // short are evidence the position cannot shrug off: no position explains them, so it waits.
  options.outliers_read_long = true;
  DelayedInitialiser one_sided(model, options);
  const std::optional<InitialLandmark> long_left_out = offer_all(one_sided, {1, 6});
  ASSERT_TRUE(long_left_out.has_value());
  EXPECT_LT((long_left_out->mean - m).norm(), 1e-6);
  options.outliers_read_long = false;
  DelayedInitialiser symmetric(model, options);
  const std::optional<InitialLandmark> short_left_out = offer_all(symmetric, {1, 6}, -4.0);
  ASSERT_TRUE(short_left_out.has_value()) << "the symmetric t leaves out short ranges too";
  EXPECT_LT((short_left_out->mean - m).norm(), 1e-6);
  options.outliers_read_long = true;
  DelayedInitialiser short_kept(model, options);
  EXPECT_FALSE(offer_all(short_kept, {1, 6}, -4.0));
  EXPECT_EQ(short_kept.waiting(), 1u);
}

TEST(SimulatedMultipath, ReadsARangeLongAsOftenAndByAsMuchAsConfigured) {
  Scenario s = scenario("default");
  s.config.sensor = SensorKind::kRangeOnly;
  s.config.loops = 1;
  const Dataset clean = simulate(s.world, s.config);
  EXPECT_FALSE(to_json(s.config).contains("range_outlier_probability")) << "written only when not 0";
  s.config.range_outlier_probability = 0.1;
  s.config.range_outlier_mean = 3.0;
  const nlohmann::json json = to_json(s.config);
  EXPECT_EQ(json.at("range_outlier_mean_m"), 3.0);
  EXPECT_EQ(simulator_config_from_json(json, "test").range_outlier_probability, 0.1);
  const Dataset multipath = simulate(s.world, s.config);
  const std::vector<ScanEvent> a = test_sim::scans_of(clean), b = test_sim::scans_of(multipath);
  ASSERT_EQ(a.size(), b.size());
  double n = 0.0, long_ones = 0.0, excess = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].observations.size(), b[k].observations.size());
    for (std::size_t i = 0; i < a[k].observations.size(); ++i) {
      ASSERT_EQ(a[k].observations[i].id, b[k].observations[i].id);
      const double more = b[k].observations[i].z[0] - a[k].observations[i].z[0];
      ASSERT_GE(more, 0.0) << "multipath only lengthens a range";
      n += 1.0;
      if (more > 0.0) {
        long_ones += 1.0;
        excess += more;
      }
    }
  }
  ASSERT_GT(n, 1000.0);
  // Within four standard deviations of the binomial count and of the exponential's mean.
  EXPECT_NEAR(long_ones / n, 0.1, 4.0 * std::sqrt(0.1 * 0.9 / n));
  EXPECT_NEAR(excess / long_ones, 3.0, 4.0 * 3.0 / std::sqrt(long_ones));
  s.config.range_outlier_probability = 1.5;
  EXPECT_THROW(validate(s.config, "test"), InputError);
}

namespace {

Metrics run_range_only(const Dataset& d, EkfVariant variant, const MeasurementLikelihood& likelihood) {
  EkfSlamOptions options = test_sim::ekf_options_for(d, variant);
  options.likelihood = likelihood;
  EkfSlam filter(d.motion, d.observation, options);
  return evaluate_run(run_filter(filter, d), d.truth);
}

Dataset multipath_world(std::uint64_t seed) {
  Scenario s = scenario("default");
  s.config.sensor = SensorKind::kRangeOnly;
  s.config.seed = seed;
  s.config.range_outlier_probability = 0.1;
  s.config.range_outlier_mean = 3.0;
  return simulate(s.world, s.config);
}

Metrics run_fastslam2(const Dataset& d, const MeasurementLikelihood& likelihood) {
  FastSlamConfig c = test_sim::fastslam_config_for(d, 2, 30);
  c.likelihood = likelihood;
  FastSlam filter(d.motion, d.observation, c);
  return evaluate_run(run_filter(filter, d), d.truth);
}

}  // namespace

// The reference world seen by a radio that reads one range in ten long by 3 m on average (seed 3;
// the settings were chosen on seeds 1 and 2). Every landmark starts delayed. With the Gaussian
// likelihood the long ranges start beacons on the wrong side of the road and FastSLAM's weights
// follow the outliers; with the t both filters stay on track. Only that much: over 50 seeds the t's
// map is 2.2 m off the truth at the median, a few beacons of each run still started on the wrong
// side (docs/sensing.md).
TEST(RobustLikelihood, KeepsRangeOnlySlamOnTrackThroughMultipath) {
  const Dataset d = multipath_world(3);
  const Metrics gaussian = run_range_only(d, EkfVariant::kFirstEstimates, {});
  const Metrics t = run_range_only(d, EkfVariant::kFirstEstimates, student_t());
  ASSERT_TRUE(t.ate_rmse_m && t.dead_reckoning_ate_rmse_m && t.map_rmse_m && gaussian.map_rmse_m);
  EXPECT_LT(*t.ate_rmse_m, 0.5 * *t.dead_reckoning_ate_rmse_m);
  EXPECT_LT(*t.map_rmse_m, 3.0);
  EXPECT_GT(*gaussian.map_rmse_m, 2.0 * *t.map_rmse_m);
  EXPECT_GE(t.landmarks, 40u);

  const Metrics fs_gaussian = run_fastslam2(d, {});
  const Metrics fs_t = run_fastslam2(d, student_t());
  ASSERT_TRUE(fs_t.ate_rmse_m && fs_gaussian.ate_rmse_m && fs_t.map_rmse_m);
  EXPECT_LT(*fs_t.ate_rmse_m, *fs_t.dead_reckoning_ate_rmse_m);
  EXPECT_LT(*fs_t.map_rmse_m, 3.0);
  EXPECT_GT(*fs_gaussian.ate_rmse_m, *fs_gaussian.dead_reckoning_ate_rmse_m);
}
