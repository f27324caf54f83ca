// How evaluate_run pairs the estimated map with the true one: by the landmarks' origins where the
// truth names the landmark of every observation, by id only with known association, else not at all.
#include "slamkit/eval/evaluation.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"

using namespace slamkit;

namespace {

Landmark landmark(int id, double x, double y) { return Landmark{id, Vector2(x, y), Matrix2::Zero()}; }

/// A filter that numbered its two landmarks 0 and 1 itself, started by observations of the true
/// landmarks 7 and 3; the truth also has landmarks numbered 0 and 1, far away. The estimated path is
/// the true one, so the map is judged in the truth's frame.
struct TwoLandmarkRun {
  TwoLandmarkRun() {
    truth.poses = {{0.0, Pose2(0.0, 0.0, 0.0)}, {1.0, Pose2(1.0, 0.0, 0.0)}};
    truth.poses_have_heading = false;  // positions only: no NEES, which would need covariances
    run.filtered = run.trajectory = run.dead_reckoning = truth.poses;
    run.association = "nn";
    run.map = {landmark(0, 1.0, 1.0), landmark(1, 5.0, 5.0)};
    run.scans = 1;
    run.associations = {{{AssociationDecision::kNew, 0}, {AssociationDecision::kNew, 1}}};
    truth.landmarks = {landmark(0, 100.0, 100.0), landmark(1, -100.0, 0.0), landmark(3, 5.0, 5.1),
                       landmark(7, 1.0, 1.2)};
    truth.observation_ids = {{7, 3}};
  }
  RunResult run;
  GroundTruth truth;
};

}  // namespace

TEST(EvaluateRun, WithoutKnownAssociationTheMapIsPairedByOrigin) {
  const TwoLandmarkRun r;
  const Metrics m = evaluate_run(r.run, r.truth);
  ASSERT_TRUE(m.map_rmse_m);
  EXPECT_EQ(m.map_landmarks_paired, 2u);
  EXPECT_NEAR(*m.map_rmse_m, std::sqrt((0.2 * 0.2 + 0.1 * 0.1) / 2.0), 1e-12);
}

TEST(EvaluateRun, WithoutOriginsOnlyKnownAssociationPairsById) {
  TwoLandmarkRun r;
  r.truth.observation_ids.clear();
  // The filter's own numbers say nothing about the truth's: no pairing, rather than a wrong one.
  const Metrics unknown = evaluate_run(r.run, r.truth);
  EXPECT_FALSE(unknown.map_rmse_m);
  EXPECT_EQ(unknown.map_landmarks_paired, 0u);

  r.run.association = "known";
  r.run.map = {landmark(7, 1.0, 1.0), landmark(3, 5.0, 5.0)};
  const Metrics known = evaluate_run(r.run, r.truth);
  ASSERT_TRUE(known.map_rmse_m);
  EXPECT_EQ(known.map_landmarks_paired, 2u);
  EXPECT_NEAR(*known.map_rmse_m, std::sqrt((0.2 * 0.2 + 0.1 * 0.1) / 2.0), 1e-12);
}

// Loop closure: true landmark 5 is seen at t = 0 and 1, then after a gap of 100 s (a lap) at t = 101,
// 102, 103, 104 and 105. The filter started landmark 0 from it; on the return it started a duplicate
// (landmark 1) and paired with it twice, then once with landmark 0 and once with landmark 2, which
// true landmark 8 started. Landmark 8 returns once, to its own landmark.
TEST(EvaluateRun, LoopClosureFractionCountsReturnsPairedWithTheFirstVisitsLandmark) {
  RunResult run;
  run.association = "nn";
  GroundTruth truth;
  auto scan = [&](double t, std::vector<AssociationRecord> records, std::vector<int> ids) {
    run.scan_times.push_back(t);
    run.associations.push_back(std::move(records));
    truth.observation_ids.push_back(std::move(ids));
  };
  using D = AssociationDecision;
  scan(0.0, {{D::kNew, 0}, {D::kNew, 2}}, {5, 8});
  scan(1.0, {{D::kUpdate, 0}}, {5});
  scan(101.0, {{D::kNew, 1}}, {5});
  scan(102.0, {{D::kUpdate, 1}}, {5});
  scan(103.0, {{D::kUpdate, 1}, {D::kUpdate, 2}}, {5, 8});
  scan(104.0, {{D::kUpdate, 0}}, {5});
  scan(105.0, {{D::kUpdate, 2}}, {5});
  run.scans = run.associations.size();
  EvaluationOptions options;
  options.revisit_gap_s = 60.0;
  const Metrics m = evaluate_run(run, truth, options);
  ASSERT_TRUE(m.association.has_value());
  EXPECT_EQ(m.association->return_observations, 6U) << "5 of landmark 5, 1 of landmark 8";
  // 8's return at 103 s is paired with its own first landmark; of 5's five, only the one at 104 s.
  EXPECT_EQ(m.association->return_observations_closed, 2U);
  ASSERT_TRUE(m.association->loop_closure_fraction());
  EXPECT_NEAR(*m.association->loop_closure_fraction(), 2.0 / 6.0, 1e-12);
  EXPECT_EQ(to_json(m)["loop_closed"], false);

  options.revisit_gap_s = 200.0;  // no gap that long: no returns, no fraction
  const Metrics none = evaluate_run(run, truth, options);
  EXPECT_FALSE(none.association->loop_closure_fraction());
  EXPECT_TRUE(to_json(none)["loop_closure_fraction"].is_null());
}

// The shipped course example with nearest-neighbour association reported a map RMSE of 4.24 m over
// 3 landmarks, pairing the filter's numbers with world.dat's ids; by origin all 7 pair, within 0.2 m.
TEST(EvaluateRun, CourseLogWithUnknownAssociationPairsEveryLandmarkByOrigin) {
  const Dataset data =
      load_dataset("course:" + (std::filesystem::path(SLAMKIT_SOURCE_DIR) / "examples" / "course").string());
  for (const AssociationMethod method : {AssociationMethod::kNearestNeighbour, AssociationMethod::kJcbb}) {
    FilterConfig config;
    config.association.method = method;
    const auto filter = make_filter(config, data);
    RunResult run = run_filter(*filter, data);
    run.association = to_string(method);
    const Metrics m = evaluate_run(run, data.truth);
    ASSERT_TRUE(m.map_rmse_m) << run.association;
    ASSERT_TRUE(m.association) << run.association;
    EXPECT_EQ(m.association->wrong, 0u) << run.association;
    EXPECT_EQ(m.map_landmarks_paired, m.landmarks) << run.association;
    EXPECT_GE(m.landmarks, 7u) << run.association;
    EXPECT_LT(*m.map_rmse_m, 0.2) << run.association;
  }
}

// With no trajectory truth (MRCLAM Dataset1, a surveyed map) the run's frame is its start, which
// nothing ties to the truth's: the map is aligned onto the true landmarks it pairs with, and says so.
TEST(EvaluateRun, WithoutTrajectoryTruthTheMapIsAlignedOnItsLandmarks) {
  RunResult run;
  run.association = "known";
  GroundTruth truth;
  truth.landmarks = {landmark(1, 0.0, 0.0), landmark(2, 10.0, 0.0), landmark(3, 10.0, 5.0), landmark(4, 0.0, 5.0)};
  // One landmark 0.4 m off along x, then the whole map turned by 30 degrees and moved by (7, -3).
  std::vector<Vector2> moved, actual;
  for (const Landmark& l : truth.landmarks) {
    actual.push_back(l.position);
    moved.push_back(l.position + (l.id == 3 ? Vector2(0.4, 0.0) : Vector2(0.0, 0.0)));
  }
  const eval::Se2Transform frame{deg2rad(30.0), Vector2(7.0, -3.0)};
  // One scan started each landmark from an observation of it, as a log with identities would.
  run.associations.emplace_back();
  truth.observation_ids.emplace_back();
  for (std::size_t i = 0; i < moved.size(); ++i) {
    const Vector2 p = frame.apply(moved[i]);
    const int id = truth.landmarks[i].id;
    run.map.push_back(landmark(id, p.x(), p.y()));
    run.associations.back().push_back({AssociationDecision::kNew, id});
    truth.observation_ids.back().push_back(id);
  }
  const Metrics m = evaluate_run(run, truth);
  ASSERT_TRUE(m.map_rmse_m);
  EXPECT_EQ(m.map_alignment, "landmarks");
  EXPECT_EQ(m.map_landmarks_paired, 4u);
  // What no rigid motion removes of one landmark's 0.4 m, spread over four: the same least squares
  // in the truth's own frame.
  const eval::Se2Transform fit = eval::align_se2(moved, actual);
  double sum = 0.0;
  for (std::size_t i = 0; i < moved.size(); ++i) sum += (fit.apply(moved[i]) - actual[i]).squaredNorm();
  EXPECT_NEAR(*m.map_rmse_m, std::sqrt(sum / 4.0), 1e-9);
  EXPECT_LT(*m.map_rmse_m, 0.4);
  EXPECT_NEAR(wrap_angle(m.alignment.theta + deg2rad(30.0)), 0.0, 0.05);
  const nlohmann::json j = to_json(m);
  EXPECT_EQ(j["map_alignment"], "landmarks");
  EXPECT_NE(headline(m).find("aligned on its 4 paired landmarks: no trajectory truth"), std::string::npos)
      << headline(m);

  // Fewer than three pairs fit too well to score: no map RMSE rather than a flattering one.
  run.map.resize(2);
  const Metrics two = evaluate_run(run, truth);
  EXPECT_FALSE(two.map_rmse_m);
  EXPECT_EQ(two.map_landmarks_paired, 2u);
  EXPECT_TRUE(to_json(two)["map_alignment"].is_null());
}

// With trajectory truth the map goes with the trajectory's alignment, and the time matching is
// chosen: evo's pairs give the number evo_ape prints (the case of MatchNearest, by hand: 4.472 mm).
TEST(EvaluateRun, TimeMatchingAndMapAlignmentAreNamed) {
  RunResult run;
  run.association = "known";
  GroundTruth truth;
  for (const double t : {0.0, 1.0, 2.0, 3.0, 4.0}) truth.poses.push_back({t, Pose2(t, 0.0, 0.0)});
  truth.poses_have_heading = false;  // positions only, as a GPS truth
  for (const double t : {0.004, 1.0, 1.5, 2.008, 3.02, 3.996}) run.filtered.push_back({t, Pose2(t, 0.0, 0.0)});
  run.trajectory = run.filtered;
  run.dead_reckoning = run.filtered;
  truth.landmarks = {landmark(1, 2.0, 3.0)};
  run.map = {landmark(1, 2.0, 3.5)};
  run.associations = {{{AssociationDecision::kNew, 1}}};
  truth.observation_ids = {{1}};
  const Metrics interpolated = evaluate_run(run, truth);
  ASSERT_TRUE(interpolated.ate_rmse_m);
  EXPECT_NEAR(*interpolated.ate_rmse_m, 0.0, 1e-12);
  EXPECT_EQ(interpolated.time_matching, "interpolate");
  EXPECT_EQ(interpolated.map_alignment, "trajectory");
  EXPECT_NEAR(*interpolated.map_rmse_m, 0.5, 1e-9);

  EvaluationOptions evo;
  evo.time_matching = TimeMatching::kEvo;
  const Metrics m = evaluate_run(run, truth, evo);
  ASSERT_TRUE(m.ate_rmse_m);
  EXPECT_NEAR(*m.ate_rmse_m, std::sqrt(2e-5), 1e-12);
  EXPECT_EQ(m.matched_poses, 4u);
  const nlohmann::json j = to_json(m);
  EXPECT_EQ(j["time_matching"], "evo");
  EXPECT_EQ(j["time_matching_max_difference_s"], 0.01);
  EXPECT_NE(headline(m).find("evo's time matching, within 0.01 s"), std::string::npos) << headline(m);
  EXPECT_EQ(parse_time_matching("evo"), TimeMatching::kEvo);
  EXPECT_THROW(parse_time_matching("evoo"), std::invalid_argument);
}

// A particle filter's pose covariance is its cloud's; the console line says what that NEES is.
TEST(EvaluateRun, TheHeadlineSaysWhoseNeesAParticleFilterReports) {
  Metrics m;
  m.nees_pose = eval::summarize_nees({1.0, 50.0}, 3);
  EXPECT_EQ(headline(m).find("particle cloud"), std::string::npos);
  EXPECT_FALSE(to_json(m).contains("nees_pose_note"));
  m.filter = "fastslam2";
  EXPECT_NE(headline(m).find("pose NEES in 95% bounds 50% of steps (of the particle cloud, which resampling "
                             "collapses; judge accuracy by the ATE)"),
            std::string::npos)
      << headline(m);
  EXPECT_TRUE(to_json(m).contains("nees_pose_note"));
}

// A trajectory turned as a whole about the start, where the truth's frame is the map's: the aligned ATE
// forgives the turn, the unaligned RMSE keeps it; a truth without headings (GPS) has no frame to keep.
TEST(EvaluateRun, TheUnalignedPositionErrorKeepsATurnOfTheWholeTrajectory) {
  RunResult run;
  GroundTruth truth;
  const double turn = 0.1;
  for (int i = 0; i <= 100; ++i) {
    const double t = i;
    const Pose2 p(0.5 * t, 3.0 * std::sin(0.1 * t), 0.0);
    truth.poses.push_back({t, p});
    const Vector2 turned = Eigen::Rotation2Dd(turn) * p.head<2>();
    run.filtered.push_back({t, Pose2(turned.x(), turned.y(), turn)});
    run.pose_covariances.push_back(0.01 * Matrix3::Identity());
  }
  run.trajectory = run.filtered;
  const Metrics m = evaluate_run(run, truth);
  ASSERT_TRUE(m.ate_rmse_m && m.unaligned_position_rmse_m);
  EXPECT_LT(*m.ate_rmse_m, 1e-9);
  double squares = 0.0;
  for (int i = 0; i <= 100; ++i) squares += std::pow(2.0 * std::sin(turn / 2.0) * truth.poses[i].pose.head<2>().norm(), 2);
  EXPECT_NEAR(*m.unaligned_position_rmse_m, std::sqrt(squares / 101.0), 1e-9);
  EXPECT_EQ(to_json(m).at("unaligned_position_rmse_m"), *m.unaligned_position_rmse_m);

  truth.poses_have_heading = false;
  EXPECT_FALSE(evaluate_run(run, truth).unaligned_position_rmse_m);
}
