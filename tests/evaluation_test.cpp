// How evaluate_run pairs the estimated map with the true one: by the landmarks' origins where the
// truth names the landmark of every observation, by id only with known association, else not at all.
#include "slamkit/eval/evaluation.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "slamkit/io/load_dataset.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"

using namespace slamkit;

namespace {

Landmark landmark(int id, double x, double y) { return Landmark{id, Vector2(x, y), Matrix2::Zero()}; }

/// A filter that numbered its two landmarks 0 and 1 itself, started by observations of the true
/// landmarks 7 and 3; the truth also has landmarks numbered 0 and 1, far away.
struct TwoLandmarkRun {
  TwoLandmarkRun() {
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
