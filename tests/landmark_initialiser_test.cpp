// Landmark initialisation where one measurement does not place the landmark: the delayed start
// triangulates ranges and bearings, waits while they admit two positions, drops an outlier; and the
// filters run on range-only and bearing-only data end to end.
#include <gtest/gtest.h>

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/filters/landmark_initialiser.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "allocation_counter.hpp"
#include "sim_test_support.hpp"
#include "test_data.hpp"

using namespace slamkit;

namespace {

const Matrix3 kNoDrift = Matrix3::Zero();
const RangeCorrection kNoCorrection;

std::shared_ptr<const ObservationModel> range_only() { return std::make_shared<RangeOnlyModel>(); }
std::shared_ptr<const ObservationModel> bearing_only() { return std::make_shared<BearingOnlyModel>(); }

/// Offers the exact measurement of `m` from each pose in turn; the landmark that starts, if any, and
/// after how many offers.
std::optional<InitialLandmark> offer_exact(LandmarkInitialiser& init, const ObservationModel& model,
                                           const std::vector<Pose2>& poses, const Vector2& m, int* offers = nullptr) {
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (offers) *offers = static_cast<int>(i + 1);
    if (auto l = init.offer(7, poses[i], kNoDrift, model.predict(poses[i], m), static_cast<double>(i), kNoCorrection))
      return l;
  }
  return std::nullopt;
}

}  // namespace

TEST(DelayedInitialiser, PlacesALandmarkFromExactRangesAtThreeSpreadPoses) {
  const auto model = range_only();
  DelayedInitialiser init(model, {});
  const Vector2 m(4.0, 5.0);
  int offers = 0;
  const auto l = offer_exact(init, *model, {Pose2(0, 0, 0), Pose2(8, 0, 0.3), Pose2(4, 12, 1.2)}, m, &offers);
  ASSERT_TRUE(l.has_value());
  EXPECT_EQ(offers, 3) << "a circle meets another in two points and a third picks one";
  EXPECT_LT((l->mean - m).norm(), 1e-6);
  // Rigidly attached to the last pose, as an inverted measurement: dm/dx = [I, J (m - p)].
  Matrix23 gx;
  gx << 1, 0, -(m.y() - 12.0), 0, 1, m.x() - 4.0;
  EXPECT_LT((l->gx - gx).norm(), 1e-6);
  EXPECT_EQ(init.waiting(), 0u);
}

TEST(DelayedInitialiser, PlacesALandmarkFromExactBearingsAtTwoPoses) {
  const auto model = bearing_only();
  DelayedInitialiser init(model, {});
  const Vector2 m(10.0, 3.0);
  int offers = 0;
  const auto l = offer_exact(init, *model, {Pose2(0, 0, 0.1), Pose2(3, -2, 0.4)}, m, &offers);
  ASSERT_TRUE(l.has_value());
  EXPECT_EQ(offers, 2);
  EXPECT_LT((l->mean - m).norm(), 1e-6);
}

TEST(DelayedInitialiser, KeepsBothPositionsARangeAlongALineAdmitsUntilTheVehicleTurns) {
  // One beacon north of a straight road: ranges from the road fit it and its mirror image south of
  // the road equally, so it must not start until the vehicle leaves the line.
  const auto model = std::make_shared<RangeOnlyModel>(RangeOnlyModel::Params{.sigma_range = 0.05});
  DelayedInitialiser init(model, {});
  const Vector2 beacon(10.0, 6.0);
  double t = 0.0;
  for (double x = 0.0; x <= 20.0; x += 1.0, t += 1.0)
    ASSERT_FALSE(
        init.offer(0, Pose2(x, 0.0, 0.0), kNoDrift, model->predict(Pose2(x, 0.0, 0.0), beacon), t, kNoCorrection))
        << "started at x = " << x << " while the mirror image (10, -6) fits as well";
  EXPECT_EQ(init.waiting(), 1u);
  // What it holds meanwhile: the beacon and its mirror image, equally likely.
  const std::vector<LandmarkHypothesis> held = init.hypotheses();
  ASSERT_EQ(held.size(), 2u);
  for (const LandmarkHypothesis& h : held) {
    EXPECT_EQ(h.landmark.id, 0);
    EXPECT_EQ(h.weight, 0.5);
    EXPECT_LT(std::min((h.landmark.position - beacon).norm(), (h.landmark.position - Vector2(10.0, -6.0)).norm()),
              1e-3);
  }
  EXPECT_GT((held[0].landmark.position - held[1].landmark.position).norm(), 11.0);
  // Turning north off the road resolves it, to the true side.
  std::optional<InitialLandmark> l;
  for (double y = 1.0; y <= 6.0 && !l; y += 1.0, t += 1.0) {
    const Pose2 x(20.0, y, kPi / 2);
    l = init.offer(0, x, kNoDrift, model->predict(x, beacon), t, kNoCorrection);
  }
  ASSERT_TRUE(l.has_value());
  EXPECT_LT((l->mean - beacon).norm(), 1e-3);
  EXPECT_TRUE(init.hypotheses().empty()) << "a started landmark is no hypothesis";
}

// A landmark the views cannot place yet waits in the window; once the window is full, each further
// offer reuses the initialiser's scratch: no heap allocation per observation. Three ways of waiting:
// ranges along a line (the mirror image), the same read through a range calibration, and bearings
// from too short a baseline (too uncertain to start).
TEST(DelayedInitialiser, AWaitingLandmarkCostsNoAllocationPerObservation) {
  const auto ranges = std::make_shared<RangeOnlyModel>(RangeOnlyModel::Params{.sigma_range = 0.05});
  const auto bearings = std::make_shared<BearingOnlyModel>(BearingOnlyModel::Params{.sigma_bearing = 0.2});
  struct Case {
    std::shared_ptr<const ObservationModel> model;
    Vector2 landmark;
    RangeCorrection correction;
    double stride;  // along the road between offers [m]
  };
  const Case cases[] = {{ranges, {10.0, 6.0}, kNoCorrection, 0.5},
                        {ranges, {10.0, 6.0}, RangeCorrection{0.3, 0.01}, 0.5},
                        {bearings, {10.0, 8.0}, kNoCorrection, 1.0}};
  for (const Case& c : cases) {
    DelayedInitialiser init(c.model, {});
    auto offer = [&](int k) {
      // Back and forth along a few metres of road: the window never sees the vehicle leave it.
      const double x = c.stride * static_cast<double>(k % 5);
      const Pose2 pose(x, 0.0, 0.0);
      return init.offer(3, pose, kNoDrift, c.model->predict(pose, c.landmark), static_cast<double>(k), c.correction);
    };
    int k = 0;
    for (; k < 100; ++k) ASSERT_FALSE(offer(k)) << c.model->name() << ": started at offer " << k;
    ASSERT_FALSE(init.hypotheses().empty()) << c.model->name() << ": fits found while it waits";
    const test::AllocationCount allocations;
    bool started = false;
    for (; k < 200; ++k) started = started || offer(k).has_value();
    const std::uint64_t made = allocations.count();
    EXPECT_FALSE(started) << c.model->name();
    EXPECT_EQ(made, 0U) << c.model->name() << (c.correction.offset_m != 0.0 ? " (calibrated)" : "");
  }
}

// One beacon ranged from a straight road: the ring keeps both places the ranges allow, the beacon and
// its mirror image across the road, each with about half the weight, and starts nothing until the
// vehicle turns off the road and the mirror image dies.
TEST(RingInitialiser, KeepsBothHypothesesARoadAllowsUntilTheVehicleTurns) {
  const auto model = std::make_shared<RangeOnlyModel>(RangeOnlyModel::Params{.sigma_range = 0.05});
  RingInitialiser init(model, {});
  const Vector2 beacon(10.0, 6.0), mirror(10.0, -6.0);
  double t = 0.0;
  for (double x = 0.0; x <= 20.0; x += 1.0, t += 1.0)
    ASSERT_FALSE(
        init.offer(0, Pose2(x, 0.0, 0.0), kNoDrift, model->predict(Pose2(x, 0.0, 0.0), beacon), t, kNoCorrection))
        << "started at x = " << x << " while the mirror image fits as well";
  const auto weight_near = [&](const Vector2& p) {
    double w = 0.0;
    for (const RingInitialiser::Hypothesis& h : init.hypotheses(0))
      if ((h.mean - p).norm() < 1.0) w += std::exp(h.log_weight);
    return w;
  };
  EXPECT_NEAR(weight_near(beacon), 0.5, 0.1);
  EXPECT_NEAR(weight_near(mirror), 0.5, 0.1);
  EXPECT_NEAR(weight_near(beacon) + weight_near(mirror), 1.0, 1e-3) << "nothing else is alive";
  // The same for the replay page: every live hypothesis, the weights of its ring summing to one.
  double total = 0.0;
  for (const LandmarkHypothesis& h : init.hypotheses()) {
    EXPECT_EQ(h.landmark.id, 0);
    total += h.weight;
  }
  EXPECT_NEAR(total, 1.0, 1e-12);
  EXPECT_EQ(init.hypotheses().size(), init.hypotheses(0).size());
  std::optional<InitialLandmark> l;
  for (double y = 1.0; y <= 6.0 && !l; y += 1.0, t += 1.0) {
    const Pose2 x(20.0, y, kPi / 2);
    l = init.offer(0, x, kNoDrift, model->predict(x, beacon), t, kNoCorrection);
  }
  ASSERT_TRUE(l.has_value());
  EXPECT_LT((l->mean - beacon).norm(), 0.1);
  EXPECT_EQ(init.waiting(), 0u);
}

TEST(DelayedInitialiser, DropsARangeNoPositionExplainsWithTheOthers) {
  const auto model = std::make_shared<RangeOnlyModel>(RangeOnlyModel::Params{.sigma_range = 0.1});
  DelayedInitialiser init(model, {});
  const Vector2 m(3.0, 8.0);
  const std::vector<Pose2> poses = {Pose2(0, 0, 0), Pose2(6, 0, 0), Pose2(6, 5, 0), Pose2(0, 5, 0), Pose2(3, 2, 0)};
  Measurement outlier = model->predict(poses[0], m);
  outlier[0] += 15.0;  // a reflection read long
  ASSERT_FALSE(init.offer(1, poses[0], kNoDrift, outlier, 0.0, kNoCorrection));
  std::optional<InitialLandmark> l;
  for (std::size_t i = 1; i < poses.size() && !l; ++i)
    l = init.offer(1, poses[i], kNoDrift, model->predict(poses[i], m), static_cast<double>(i), kNoCorrection);
  ASSERT_TRUE(l.has_value());
  EXPECT_LT((l->mean - m).norm(), 1e-6);
}

TEST(DelayedInitialiser, ForgetsObservationsOlderThanItsWindow) {
  const auto model = range_only();
  DelayedInitialisationOptions options;
  options.window_s = 10.0;
  DelayedInitialiser init(model, options);
  const Vector2 m(4.0, 7.0);
  EXPECT_FALSE(init.offer(2, Pose2(0, 0, 0), kNoDrift, model->predict(Pose2(0, 0, 0), m), 0.0, kNoCorrection));
  EXPECT_FALSE(init.offer(2, Pose2(5, 0, 0), kNoDrift, model->predict(Pose2(5, 0, 0), m), 1.0, kNoCorrection));
  // Twenty seconds on, the two are gone: a third range alone cannot place it.
  EXPECT_FALSE(init.offer(2, Pose2(6, 4, 0), kNoDrift, model->predict(Pose2(6, 4, 0), m), 21.0, kNoCorrection));
}

TEST(LandmarkInitialiser, AnInvertedMeasurementPlacesItsLandmarkAndOnlyRangeBearingInverts) {
  const RangeBearingModel rb;
  const auto l = inverted_landmark(rb, Pose2(1, 2, 0.5), rb.predict(Pose2(1, 2, 0.5), Vector2(4, 4)));
  ASSERT_TRUE(l.has_value());
  EXPECT_LT((l->mean - Vector2(4, 4)).norm(), 1e-12);
  EXPECT_FALSE(inverted_landmark(RangeOnlyModel{}, Pose2::Zero(), Measurement::Constant(1, 5.0)));
  EXPECT_FALSE(inverted_landmark(BearingOnlyModel{}, Pose2::Zero(), Measurement::Constant(1, 0.5)));
}

TEST(LandmarkInitialiser, SearchingAssociationAndImmediateStartsRefuseASensorThatCannotPlaceALandmark) {
  const auto motion = std::make_shared<AckermannModel>();
  EkfSlamOptions nn;
  nn.association.method = AssociationMethod::kNearestNeighbour;
  try {
    EkfSlam{motion, range_only(), nn};
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("known"), std::string::npos) << e.what();
  }
  EkfSlamOptions immediate;
  immediate.initialisation = LandmarkInitialisation::kImmediate;
  EXPECT_THROW((EkfSlam{motion, bearing_only(), immediate}), std::invalid_argument);
  FastSlamConfig fs;
  fs.association.method = AssociationMethod::kNearestNeighbour;
  try {
    FastSlam{motion, range_only(), fs};
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("known"), std::string::npos) << e.what();
  }
  FastSlamConfig fs_immediate;
  fs_immediate.association.method = AssociationMethod::kKnown;
  fs_immediate.initialisation = LandmarkInitialisation::kImmediate;
  EXPECT_THROW((FastSlam{motion, bearing_only(), fs_immediate}), std::invalid_argument);
}

namespace {

Metrics run_on(SensorKind sensor, EkfVariant variant, std::uint64_t seed,
               LandmarkInitialisation start = LandmarkInitialisation::kDelayed) {
  Scenario s = scenario("default");
  s.config.sensor = sensor;
  s.config.seed = seed;
  const Dataset d = simulate(s.world, s.config);
  EkfSlamOptions options = test_sim::ekf_options_for(d, variant);
  options.initialisation = start;
  EkfSlam filter(d.motion, d.observation, options);
  return evaluate_run(run_filter(filter, d), d.truth);
}

}  // namespace

// The ring start on the same world: it beats dead reckoning by far and stays consistent, though the
// delayed start does better there (docs/results.md: over 50 seeds ATE 1.32 m against 0.89 m).
TEST(RingStart, RangeOnlyEkfSlamBeatsDeadReckoningAndStaysConsistent) {
  const Metrics m = run_on(SensorKind::kRangeOnly, EkfVariant::kFirstEstimates, 1, LandmarkInitialisation::kRing);
  ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m && m.nees_pose);
  EXPECT_LT(*m.ate_rmse_m, 0.5 * *m.dead_reckoning_ate_rmse_m);
  EXPECT_GE(m.nees_pose->in_interval_fraction, 0.8);
  EXPECT_GE(m.landmarks, 40u);
}

TEST(RingStart, IsForRangesAloneWithKnownIdentitiesAndNoCalibration) {
  const auto motion = std::make_shared<AckermannModel>();
  EXPECT_THROW(RingInitialiser(std::make_shared<RangeBearingModel>(), {}), std::invalid_argument);
  EXPECT_THROW(RingInitialiser(range_only(), {}, {.max_hypotheses = 2}), std::invalid_argument);
  EkfSlamOptions options;
  options.initialisation = LandmarkInitialisation::kRing;
  options.range_calibration = RangeCalibrationPrior{};
  EXPECT_THROW(EkfSlam(motion, range_only(), options), std::invalid_argument);
  options.range_calibration.reset();
  EXPECT_NO_THROW(EkfSlam(motion, range_only(), options));
  options.association.method = AssociationMethod::kNearestNeighbour;
  EXPECT_THROW(EkfSlam(motion, range_only(), options), std::invalid_argument);
}

// The reference world seen by a range-only radio and by a bearing-only camera, every landmark
// started by triangulation: the consistent variants beat dead reckoning by far and stay consistent.
TEST(DelayedStart, RangeOnlyAndBearingOnlyEkfSlamBeatDeadReckoningAndStayConsistent) {
  for (const SensorKind sensor : {SensorKind::kRangeOnly, SensorKind::kBearingOnly}) {
    const Metrics m = run_on(sensor, EkfVariant::kFirstEstimates, 1);
    SCOPED_TRACE(to_string(sensor));
    ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m && m.nees_pose);
    EXPECT_LT(*m.ate_rmse_m, 0.5 * *m.dead_reckoning_ate_rmse_m);
    EXPECT_GE(m.nees_pose->in_interval_fraction, 0.8);
    EXPECT_GE(m.landmarks, 50u) << "most of the world's 100 landmarks start";
  }
}

namespace {

/// After every scan: the filter's hypotheses are of landmarks not in its map, finite, with weights
/// in (0, 1]; counts them.
class HypothesisCheck final : public RunObserver {
 public:
  void on_scan(const SlamFilter& filter, const ScanEvent&, std::size_t, std::size_t) override {
    const std::vector<Landmark> map = filter.landmarks();
    for (const LandmarkHypothesis& h : filter.landmark_hypotheses()) {
      ++seen;
      EXPECT_TRUE(std::none_of(map.begin(), map.end(), [&](const Landmark& l) { return l.id == h.landmark.id; }))
          << "landmark " << h.landmark.id << " is mapped";
      EXPECT_TRUE(h.landmark.position.allFinite() && h.weight > 0.0 && h.weight <= 1.0);
    }
  }
  std::size_t seen = 0;
};

}  // namespace

// What a filter shows of its initialiser: the hypotheses of landmarks not yet in its map, carried from
// dead reckoning's frame to where they lie relative to its estimate, as they would start.
TEST(LandmarkHypotheses, AreTheInitialisersCarriedToTheEstimateForLandmarksNotYetMapped) {
  Scenario s = scenario("default");
  s.config.sensor = SensorKind::kRangeOnly;
  s.config.loops = 1;
  const Dataset d = simulate(s.world, s.config);
  for (const LandmarkInitialisation start : {LandmarkInitialisation::kDelayed, LandmarkInitialisation::kRing}) {
    SCOPED_TRACE(start == LandmarkInitialisation::kRing ? "ring" : "delayed");
    EkfSlamOptions options = test_sim::ekf_options_for(d, EkfVariant::kFirstEstimates);
    options.initialisation = start;
    EkfSlam filter(d.motion, d.observation, options);
    HypothesisCheck check;
    RunOptions run;
    run.observers.push_back(&check);
    run_filter(filter, d, run);
    EXPECT_GT(check.seen, 0u);
  }
  // Carried rigidly: a hypothesis keeps its place relative to the vehicle.
  const auto model = std::make_shared<RangeOnlyModel>(RangeOnlyModel::Params{.sigma_range = 3.0});
  DelayedInitialiser init(model, {});
  const Vector2 m(4.0, 5.0);
  for (const Pose2& x : {Pose2(0, 0, 0), Pose2(8, 0, 0.3), Pose2(4, 12, 1.2)})
    init.offer(1, x, Matrix3::Identity(), model->predict(x, m), 0.0, kNoCorrection);
  ASSERT_FALSE(init.hypotheses().empty()) << "too uncertain to start, so held as a hypothesis";
  DeadReckoning dr;
  dr.pose = Pose2(4, 12, 1.2);
  const Pose2 estimate(-3.0, 2.0, -0.4);
  const std::vector<LandmarkHypothesis> here = hypotheses_at(init, dr, estimate);
  ASSERT_EQ(here.size(), init.hypotheses().size());
  const RangeBearingModel sensor;
  EXPECT_TRUE(sensor.predict(estimate, here[0].landmark.position)
                  .isApprox(sensor.predict(dr.pose, init.hypotheses()[0].landmark.position), 1e-12));
}

// FastSLAM starts a landmark the initialiser placed in dead reckoning's frame where it lies relative
// to each particle: a particle at another pose and heading holds it at the same range and bearing.
TEST(DeadReckoning, CarriesAPlacedLandmarkToTheSamePlaceRelativeToAnyVehicle) {
  DeadReckoning dr;
  dr.pose = Pose2(2.0, -1.0, 0.3);
  InitialLandmark placed;
  placed.mean = Vector2(7.0, 3.0);
  placed.covariance << 0.5, 0.1, 0.1, 0.2;
  placed.range_gain = Vector2(0.8, 0.6);
  const Pose2 x(-4.0, 5.0, -1.2);
  const InitialLandmark here = dr.carried_to(x, placed);
  const RangeBearingModel sensor;
  EXPECT_TRUE(sensor.predict(x, here.mean).isApprox(sensor.predict(dr.pose, placed.mean), 1e-12));
  // The covariance and the gains turn with the heading; the spread is unchanged.
  EXPECT_NEAR(here.covariance.trace(), placed.covariance.trace(), 1e-12);
  EXPECT_NEAR(here.covariance.determinant(), placed.covariance.determinant(), 1e-12);
  EXPECT_NEAR(here.range_gain.norm(), 1.0, 1e-12);
  EXPECT_TRUE(here.gx.isApprox(attached_to_pose(x, here.mean)));
}

// FastSLAM 1.0 and 2.0 with a radio and with a camera on the reference world, every landmark started
// by the shared delayed start (and the ring for the radio): each beats dead reckoning, and the
// delayed start's map lies within a few metres of the truth. Only that much: with 30 particles a
// particle filter's path on one seed turns on the rounding of the build (one sanitizer build ended
// seed 1's range-only FastSLAM 2.0 run at 2.0 m where the release build ended it at 1.4 m), and over
// 50 seeds it ends worse than dead reckoning in 2 to 10 runs (docs/results.md). The ring lets a
// landmark or two collapse onto their mirror images, as it does in the EKF.
TEST(DelayedStart, RangeOnlyAndBearingOnlyFastSlamBeatDeadReckoning) {
  Scenario s = scenario("default");
  s.config.seed = 2;
  for (const SensorKind sensor : {SensorKind::kRangeOnly, SensorKind::kBearingOnly}) {
    s.config.sensor = sensor;
    const Dataset d = simulate(s.world, s.config);
    for (const int version : {1, 2})
      for (const LandmarkInitialisation start : {LandmarkInitialisation::kDelayed, LandmarkInitialisation::kRing}) {
        if (start == LandmarkInitialisation::kRing && sensor != SensorKind::kRangeOnly) continue;
        SCOPED_TRACE(to_string(sensor) + " fastslam" + std::to_string(version) +
                     (start == LandmarkInitialisation::kRing ? " ring" : " delayed"));
        FastSlamConfig c = test_sim::fastslam_config_for(d, version, 30);
        c.initialisation = start;
        FastSlam filter(d.motion, d.observation, c);
        const Metrics m = evaluate_run(run_filter(filter, d), d.truth);
        ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m && m.map_rmse_m);
        EXPECT_LT(*m.ate_rmse_m, *m.dead_reckoning_ate_rmse_m);
        if (start == LandmarkInitialisation::kDelayed) EXPECT_LT(*m.map_rmse_m, 3.0);
        EXPECT_GE(m.landmarks, 40u);
        EXPECT_GT(filter.statistics().at("observations_pending"), 0.0);
      }
  }
}

TEST(SimulatedSensors, ReportTheirPartOfRangeAndBearingWithTheirNoise) {
  Scenario s = scenario("default");
  for (const SensorKind sensor : {SensorKind::kRangeOnly, SensorKind::kBearingOnly}) {
    s.config.sensor = sensor;
    const Dataset d = simulate(s.world, s.config);
    EXPECT_EQ(d.observation->dim(), 1);
    EXPECT_EQ(d.observation->name(), to_string(sensor));
    for (const Event& e : d.events)
      if (const auto* scan = std::get_if<ScanEvent>(&e))
        for (const Observation& o : scan->observations) ASSERT_EQ(o.z.size(), 1);
    // The config says which sensor, and reads back as it was written.
    EXPECT_EQ(simulator_config_from_json(to_json(s.config), "test").sensor, sensor);
  }
  // A config without the key is range and bearing, and one written for it carries no key.
  EXPECT_FALSE(to_json(SimulatorConfig{}).contains("sensor"));
  EXPECT_THROW(parse_sensor_kind("sonar"), std::invalid_argument);
}

TEST(SimulatedSensors, ARangeOnlyLogReadsBackAsItWasWritten) {
  test_data::ScratchDir dir;
  Scenario s = scenario("default");
  s.config.sensor = SensorKind::kRangeOnly;
  s.config.loops = 1;
  const Dataset d = simulate(s.world, s.config);
  write_sim_log(dir.path().string(), d, s.config, s.world);
  const Dataset back = read_sim_log(dir.path().string());
  EXPECT_EQ(back.observation->name(), "range-only");
  ASSERT_EQ(back.events.size(), d.events.size());
  for (std::size_t i = 0; i < d.events.size(); ++i) {
    const auto* a = std::get_if<ScanEvent>(&d.events[i]);
    const auto* b = std::get_if<ScanEvent>(&back.events[i]);
    ASSERT_EQ(a == nullptr, b == nullptr);
    if (!a) continue;
    ASSERT_EQ(a->observations.size(), b->observations.size());
    for (std::size_t k = 0; k < a->observations.size(); ++k) {
      EXPECT_EQ(b->observations[k].z.size(), 1);
      EXPECT_NEAR(b->observations[k].z[0], a->observations[k].z[0], 1e-9);
    }
  }
}

// CMU Plaza1: four radio beacons, known identities, none given a prior position. The consistent
// EKF starts every beacon by triangulation and beats dead reckoning; the beacons lie about the
// ranges' +2.8 m bias from the survey, which is not modelled yet.
TEST(DelayedStart, Plaza1BeaconsStartFromRangesAloneAndTheEkfBeatsDeadReckoning) {
  const std::filesystem::path dir = test_data::shared_dataset("plaza_range_only");
  SLAMKIT_REQUIRE_DATASET(dir);
  const Dataset d = load_dataset("plaza:" + dir.string() + ":Plaza1");
  EkfSlam filter(d.motion, d.observation, test_sim::ekf_options_for(d, EkfVariant::kFirstEstimates));
  const Metrics m = evaluate_run(run_filter(filter, d), d.truth);
  ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m && m.map_rmse_m);
  EXPECT_EQ(m.landmarks, 4u);
  EXPECT_LT(*m.ate_rmse_m, 0.8 * *m.dead_reckoning_ate_rmse_m);
  EXPECT_LT(*m.map_rmse_m, 4.0);
}
