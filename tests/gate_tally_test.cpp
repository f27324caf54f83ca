// The known-identity gate's tally (assoc/gate_tally.hpp): the share of identified observations it
// rejected, overall and by tenth of the run, and the word that the filter lost itself when most were,
// for both filter families.
#include <gtest/gtest.h>

#include <memory>

#include "slamkit/assoc/gate_tally.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/models/velocity_model.hpp"

using namespace slamkit;

namespace {

TEST(GateTally, SaysWhenMostObservationsWereRejected) {
  GateTally tally;
  std::map<std::string, double> quiet;
  tally.add_statistics(quiet);
  EXPECT_EQ(quiet.at("known_id_judged"), 0.0);
  EXPECT_EQ(quiet.count("known_id_rejected_fraction"), 0u);

  // 101 scans over 100 s, one judged observation each, rejected from t = 70 s on.
  for (int t = 0; t <= 100; ++t) tally.add_scan(t, 1, t >= 70 ? 1 : 0);
  tally.add_scan(100.0, 0, 0);  // judging nothing leaves no trace
  std::map<std::string, double> s;
  tally.add_statistics(s);
  EXPECT_EQ(s.at("known_id_judged"), 101.0);
  EXPECT_EQ(s.at("outliers_rejected"), 31.0);
  EXPECT_DOUBLE_EQ(s.at("known_id_rejected_fraction"), 31.0 / 101.0);
  EXPECT_EQ(s.at("known_id_rejected_fraction_tenth_01"), 0.0);
  EXPECT_EQ(s.at("known_id_rejected_fraction_tenth_07"), 0.0);
  EXPECT_EQ(s.at("known_id_rejected_fraction_tenth_08"), 1.0);
  EXPECT_EQ(s.at("known_id_rejected_fraction_tenth_10"), 1.0);  // t = 90 to 100, 11 scans
  EXPECT_EQ(s.at("known_id_lost_tenths"), 3.0);
  EXPECT_DOUBLE_EQ(s.at("known_id_lost_at_s"), 70.0);

  // A tenth with too few judged observations to tell is not counted as lost.
  GateTally sparse;
  for (int t = 0; t <= 100; t += 10) sparse.add_scan(t, 1, t >= 90 ? 1 : 0);
  std::map<std::string, double> few;
  sparse.add_statistics(few);
  EXPECT_EQ(few.at("known_id_rejected_fraction_tenth_10"), 1.0);
  EXPECT_EQ(few.count("known_id_lost_at_s"), 0u);
}

// A run longer than the tally's buckets merges them, and the tenths come out as before.
TEST(GateTally, KeepsItsTenthsOverALongRun) {
  GateTally tally;
  for (int t = 0; t <= 10000; ++t) tally.add_scan(1e6 + t, 2, t >= 9000 ? 2 : t % 2);
  std::map<std::string, double> s;
  tally.add_statistics(s);
  EXPECT_EQ(s.at("known_id_judged"), 20002.0);
  EXPECT_NEAR(s.at("known_id_rejected_fraction_tenth_01"), 0.25, 0.01);
  EXPECT_NEAR(s.at("known_id_rejected_fraction_tenth_10"), 1.0, 0.01);
  EXPECT_EQ(s.at("known_id_lost_tenths"), 1.0);
  EXPECT_NEAR(s.at("known_id_lost_at_s"), 1e6 + 9000.0, 1e-6);
}

// A robot standing still, known exactly, observing a landmark whose estimate is 1.5 m off with a
// covariance of centimetres: every observation lies beyond the gate, and the run says so.
struct WrongLandmark {
  std::shared_ptr<VelocityModel> motion = std::make_shared<VelocityModel>(VelocityModel::Params{.q_v = 0.0, .q_omega = 0.0});
  std::shared_ptr<RangeBearingModel> observation = std::make_shared<RangeBearingModel>();
  Control still = (Control(2) << 0.0, 0.0).finished();
  Vector2 seen = observation->predict(Pose2::Zero(), Vector2(5.0, 1.5));

  static AssociationConfig gated() {
    AssociationConfig a;
    a.method = AssociationMethod::kKnown;
    a.gate_known = true;
    return a;
  }
  template <typename Filter>
  void drive(Filter& filter) const {
    for (int k = 1; k <= 100; ++k) {
      filter.predict(ControlEvent{static_cast<double>(k), 1.0, still});
      filter.update(ScanEvent{static_cast<double>(k), {Observation{seen, 7}}});
      EXPECT_EQ(filter.last_associations().front().decision, AssociationDecision::kDiscard);
    }
  }
};

TEST(EkfSlam, SaysWhenTheKnownIdentityGateRejectedMostObservations) {
  const WrongLandmark w;
  auto map = std::make_unique<JointGaussian>(w.motion, w.observation);
  map->add_landmark(w.observation->predict(Pose2::Zero(), Vector2(5.0, 0.0)));
  EkfSlamOptions options;
  options.association = WrongLandmark::gated();
  EkfSlam ekf(std::move(map), std::vector<int>{7}, options);
  w.drive(ekf);
  const auto s = ekf.statistics();
  EXPECT_EQ(s.at("known_id_judged"), 100.0);
  EXPECT_EQ(s.at("outliers_rejected"), 100.0);
  EXPECT_GE(s.at("known_id_lost_tenths"), 9.0);  // a tenth of 9 scans is too few to tell
  EXPECT_EQ(s.at("known_id_lost_at_s"), 1.0);
}

TEST(FastSlam, SaysWhenTheKnownIdentityGateRejectedMostObservations) {
  const WrongLandmark w;
  FastSlamConfig config;
  config.particles = 20;
  config.association = WrongLandmark::gated();
  FastSlam fastslam(w.motion, w.observation, config);
  fastslam.set_initial_map({Landmark{7, Vector2(5.0, 0.0), 0.01 * Matrix2::Identity()}});
  w.drive(fastslam);
  const auto s = fastslam.statistics();
  // Every particle judges its own landmark: 20 verdicts a scan.
  EXPECT_EQ(s.at("known_id_judged"), 2000.0);
  EXPECT_EQ(s.at("outliers_rejected"), 2000.0);
  EXPECT_EQ(s.at("known_id_lost_tenths"), 10.0);

  // Ungated (FastSLAM's default), nothing is tallied.
  config.association.gate_known.reset();
  FastSlam ungated(w.motion, w.observation, config);
  ungated.set_initial_map({Landmark{7, Vector2(5.0, 0.0), 0.01 * Matrix2::Identity()}});
  ungated.predict(ControlEvent{1.0, 1.0, w.still});
  ungated.update(ScanEvent{1.0, {Observation{w.seen, 7}}});
  EXPECT_EQ(ungated.statistics().count("known_id_judged"), 0u);
}

}  // namespace
