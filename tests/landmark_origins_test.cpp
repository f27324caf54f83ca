// The landmark origins a particle filter reports (SlamFilter::landmark_origin): which observation
// started each landmark it names, which evaluation scores its map by, and the run folder keeps.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

Dataset sparse_lap(std::uint64_t seed) {
  Scenario s = scenario("sparse-cluttered");
  s.config.seed = seed;
  s.config.loops = 1;
  return simulate(s.world, s.config);
}

FilterConfig fastslam1(int particles) {
  FilterConfig config;
  config.filter = FilterKind::kFastSlam1;
  config.particles = particles;
  config.threads = 1;
  config.association.method = AssociationMethod::kNearestNeighbour;
  return config;
}

// A particle filter records the best particle's decisions, so the observation that started a
// landmark of the final map may be in no record; the origins the filter reports place it.
TEST(LandmarkOrigins, ScoreAParticleFiltersMapWhereTheRecordsDoNotShowTheStart) {
  GroundTruth truth;
  truth.observation_ids = {{7}, {7}};
  RunResult run;
  run.association = "nn";
  run.scan_times = {0.0, 1.0};
  // The best particle of scan 0 discarded the observation; another one started landmark 3 from it.
  run.associations = {{AssociationRecord{AssociationDecision::kDiscard, kUnknownId}},
                      {AssociationRecord{AssociationDecision::kUpdate, 3}}};
  run.map = {Landmark{3, Vector2(1.0, 2.0), Matrix2::Identity()}};
  const Metrics unplaced = evaluate_run(run, truth);
  ASSERT_TRUE(unplaced.association);
  EXPECT_EQ(unplaced.association->spurious_landmarks, 1U);
  EXPECT_EQ(unplaced.association->wrong, 1U);
  run.landmark_origins[3] = LandmarkOrigin{0, 0};
  const Metrics placed = evaluate_run(run, truth);
  EXPECT_EQ(placed.association->spurious_landmarks, 0U);
  EXPECT_EQ(placed.association->correct, 1U);
  EXPECT_EQ(placed.association->wrong, 0U);
}

TEST(LandmarkOrigins, AFastSlamRunReportsTheOriginOfEveryLandmarkItNames) {
  const Dataset d = sparse_lap(5);
  const RunResult r = run_filter(*make_filter(fastslam1(10), d), d);
  for (const Landmark& lm : r.map) EXPECT_TRUE(r.landmark_origins.count(lm.id)) << lm.id;
  for (const auto& records : r.associations)
    for (const AssociationRecord& record : records)
      if (record.landmark_id != kUnknownId) EXPECT_TRUE(r.landmark_origins.count(record.landmark_id));
}

TEST(LandmarkOrigins, TheRunFolderKeepsThemAndRefusesAnOriginOutsideTheRun) {
  const Dataset d = sparse_lap(5);
  RunResult r = run_filter(*make_filter(fastslam1(5), d), d);
  r.association = "nn";
  const test_data::ScratchDir dir;
  const std::string folder = (dir.path() / "run").string();
  write_run(folder, r);
  const RunResult back = read_run(folder);
  EXPECT_EQ(back.landmark_origins.size(), r.landmark_origins.size());
  for (const auto& [id, origin] : r.landmark_origins) {
    ASSERT_TRUE(back.landmark_origins.count(id));
    EXPECT_EQ(back.landmark_origins.at(id).scan, origin.scan);
    EXPECT_EQ(back.landmark_origins.at(id).observation, origin.observation);
  }
  const std::string file = (std::filesystem::path(folder) / "landmark_origins.txt").string();
  std::ofstream(file, std::ios::app) << "999999 " << r.scans << " 0\n";
  test_data::input_error_at([&] { read_run(folder); }, file, r.landmark_origins.size() + 2);
}

}  // namespace
}  // namespace slamkit
