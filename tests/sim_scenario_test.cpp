// The simulator's routes and named scenarios: open routes and their world files, the scenario
// table, and the loop closure above all. The detection conditions: sim_detection_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "sim_test_support.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

using namespace test_sim;
using test_data::ScratchDir;

double open_route_length(const World& w) {
  double length = 0.0;
  for (std::size_t i = 1; i < w.waypoints.size(); ++i) length += (w.waypoints[i] - w.waypoints[i - 1]).norm();
  return length;
}

// ---- Open routes ------------------------------------------------------------------------------------

TEST(OpenRoute, EndsAtItsLastWaypointAfterEveryLap) {
  World w{{}, {Vector2(0.0, 0.0), Vector2(60.0, 0.0), Vector2(120.0, 0.0)}};
  w.closed = false;
  SimulatorConfig c;
  c.loops = 1;
  const Dataset once = simulate(w, c);
  const Vector2 end = once.truth.poses.back().pose.head<2>();
  EXPECT_LT((end - w.waypoints.back()).norm(), c.waypoint_tolerance);
  EXPECT_NEAR(once.truth.poses.back().t, 120.0 / c.speed, 1.0);

  // A second lap turns back to the first waypoint and drives the route again.
  c.loops = 2;
  const Dataset twice = simulate(w, c);
  EXPECT_LT((twice.truth.poses.back().pose.head<2>() - w.waypoints.back()).norm(), c.waypoint_tolerance);
  EXPECT_GT(twice.truth.poses.back().t, 3.0 * 120.0 / c.speed);
  const auto closest_to_start =
      std::min_element(twice.truth.poses.begin() + static_cast<std::ptrdiff_t>(once.truth.poses.size()),
                       twice.truth.poses.end(), [](const StampedPose& a, const StampedPose& b) {
                         return a.pose.head<2>().norm() < b.pose.head<2>().norm();
                       });
  EXPECT_LT(closest_to_start->pose.head<2>().norm(), c.waypoint_tolerance);
}

TEST(WorldFile, RouteKindRoundTripsAndDefaultsToClosed) {
  const ScratchDir scratch;
  const World w = loop_closure_world();
  write_world(scratch.file("loop.txt"), w);
  const World r = read_world(scratch.file("loop.txt"));
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.waypoints, w.waypoints);
  ASSERT_EQ(r.landmarks.size(), w.landmarks.size());
  EXPECT_EQ(r.landmarks.back().position, w.landmarks.back().position);

  write_world(scratch.file("default.txt"), default_world());
  EXPECT_TRUE(read_world(scratch.file("default.txt")).closed);

  const std::string path = scratch.file("w.txt");
  std::ofstream(path) << "waypoint 0 0\nwaypoint 10 0\n";
  EXPECT_TRUE(read_world(path).closed);
  std::ofstream(path) << "waypoint 0 0\nroute open  # no way back\nwaypoint 10 0\n";
  EXPECT_FALSE(read_world(path).closed);
}

TEST(WorldFile, BadRouteLinesAreNamed) {
  const ScratchDir scratch;
  const std::string path = scratch.file("w.txt");
  const std::string good = "waypoint 0 0\nwaypoint 10 0\n";
  const std::vector<std::tuple<std::string, std::size_t, std::string>> cases = {
      {good + "route sideways\n", 3, "expected 'route open' or 'route closed', found 'route sideways'"},
      {good + "route\n", 3, "expected 2 fields (route open|closed), found 1"},
      {good + "route open closed\n", 3, "expected 2 fields"},
      {"route open\n" + good + "route open\n", 4, "duplicate route line (first on line 1)"},
  };
  for (const auto& [text, line, message] : cases) {
    std::ofstream(path) << text;
    const std::string error = test_data::input_error_at([&] { read_world(path); }, path, line);
    EXPECT_NE(error.find(message), std::string::npos) << error;
  }
}

// ---- Scenarios --------------------------------------------------------------------------------------

TEST(Scenario, NamesGiveTheirWorldsAndSettings) {
  EXPECT_EQ(scenario_names(),
            (std::vector<std::string>{"default", "loop-closure", "cluttered", "loop-closure-cluttered", "sparse",
                                      "sparse-cluttered", "room", "city"}));
  for (const std::string& name : scenario_names()) EXPECT_EQ(scenario(name).name, name);

  const Scenario plain = scenario("default");
  EXPECT_EQ(fingerprint(simulate(plain.world, plain.config)),
            fingerprint(simulate(default_world(), SimulatorConfig{})));

  const Scenario loop = scenario("loop-closure");
  EXPECT_EQ(loop.world.waypoints, loop_closure_world().waypoints);
  EXPECT_FALSE(loop.world.closed);
  EXPECT_EQ(loop.config.loops, 1);
  EXPECT_EQ(loop.config.clutter_rate, 0.0);
  EXPECT_TRUE(loop.config.provide_ids);

  const Scenario cluttered = scenario("cluttered");
  EXPECT_EQ(cluttered.world.waypoints, default_world().waypoints);
  EXPECT_EQ(cluttered.config.clutter_rate, 1.0);
  EXPECT_EQ(cluttered.config.detection_probability, 0.9);
  EXPECT_FALSE(cluttered.config.provide_ids);
  EXPECT_EQ(cluttered.config.loops, SimulatorConfig{}.loops);

  const Scenario both = scenario("loop-closure-cluttered");
  EXPECT_EQ(both.world.waypoints, loop.world.waypoints);
  EXPECT_EQ(both.config.loops, 1);
  EXPECT_EQ(both.config.clutter_rate, 1.0);
  EXPECT_EQ(both.config.detection_probability, 0.9);
  EXPECT_FALSE(both.config.provide_ids);
}

TEST(Scenario, UnknownNameListsTheKnownOnes) {
  try {
    scenario("loop");
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("unknown scenario 'loop'"), std::string::npos) << what;
    for (const std::string& name : scenario_names()) EXPECT_NE(what.find(name), std::string::npos) << what;
  }
}

// ---- The loop closure -------------------------------------------------------------------------------

class LoopClosure : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scenario_ = new Scenario(scenario("loop-closure"));
    data_ = new Dataset(simulate(scenario_->world, scenario_->config));
  }
  static void TearDownTestSuite() {
    delete data_;
    delete scenario_;
  }

  static Scenario* scenario_;
  static Dataset* data_;
};

Scenario* LoopClosure::scenario_ = nullptr;
Dataset* LoopClosure::data_ = nullptr;

TEST_F(LoopClosure, IsAKilometreLapThatEndsPastTheStart) {
  const World& w = scenario_->world;
  EXPECT_GT(open_route_length(w), 950.0);
  EXPECT_LT(open_route_length(w), 1100.0);
  EXPECT_EQ(w.landmarks.size(), 150u);
  const Vector2 start = data_->initial_pose.head<2>();
  const Pose2& end = data_->truth.poses.back().pose;
  // Past the start along the first straight, heading on the way it started.
  EXPECT_GT((end.head<2>() - start).norm(), 60.0);
  EXPECT_LT((end.head<2>() - start).norm(), 100.0);
  EXPECT_NEAR(end.y(), start.y(), 2.0);
  EXPECT_GT(end.x(), start.x());
  EXPECT_LT(std::abs(wrap_angle(end.z() - data_->initial_pose.z())), deg2rad(10.0));
  // Halfway round it is far from the start: a real loop, not a shuttle.
  const Pose2& half = data_->truth.poses[data_->truth.poses.size() / 2].pose;
  EXPECT_GT((half.head<2>() - start).norm(), 150.0);
}

TEST_F(LoopClosure, SeesAHandfulOfLandmarksAtATime) {
  const std::vector<ScanEvent> scans = scans_of(*data_);
  EXPECT_EQ(scans.size(), sweeps_of(*data_, scenario_->config)) << "a sweep without landmarks";
  std::size_t observations = 0, fewest = SIZE_MAX, most = 0;
  for (const ScanEvent& s : scans) {
    observations += s.observations.size();
    fewest = std::min(fewest, s.observations.size());
    most = std::max(most, s.observations.size());
  }
  const double mean = static_cast<double>(observations) / static_cast<double>(scans.size());
  EXPECT_GT(mean, 5.0);
  EXPECT_LT(mean, 15.0);
  EXPECT_GE(fewest, 2u);
  EXPECT_LE(most, 25u);
}

TEST_F(LoopClosure, ReobservesTheFirstLandmarksAtTheEndAfterLosingThem) {
  const double duration = data_->truth.poses.back().t;
  const std::vector<ScanEvent> scans = scans_of(*data_);
  std::set<int> early;
  for (const ScanEvent& s : scans)
    if (s.t < 0.1 * duration)
      for (const Observation& o : s.observations) early.insert(o.id);
  ASSERT_GE(early.size(), 15u);
  std::size_t late = 0, late_of_early = 0, middle_of_early = 0;
  for (const ScanEvent& s : scans) {
    for (const Observation& o : s.observations) {
      const bool is_early = early.count(o.id) > 0;
      if (s.t > 0.3 * duration && s.t < 0.7 * duration && is_early) ++middle_of_early;
      if (s.t > 0.8 * duration) {
        ++late;
        if (is_early) ++late_of_early;
      }
    }
  }
  EXPECT_EQ(middle_of_early, 0u);
  EXPECT_GT(late_of_early, 500u);
  EXPECT_GT(static_cast<double>(late_of_early), 0.3 * static_cast<double>(late));
}

TEST_F(LoopClosure, DeadReckoningDriftsByMetres) {
  // The drift of the controls alone over the lap, averaged over seeds: what SLAM has to undo.
  double total = 0.0;
  constexpr int kSeeds = 5;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    SimulatorConfig c = scenario_->config;
    c.seed = static_cast<std::uint64_t>(seed);
    const Dataset d = seed == 1 ? *data_ : simulate(scenario_->world, c);
    Pose2 pose = d.initial_pose;
    for (const ControlEvent& u : controls_of(d)) pose = d.motion->predict(pose, u.u, u.dt);
    total += (pose.head<2>() - d.truth.poses.back().pose.head<2>()).norm();
  }
  EXPECT_GT(total / kSeeds, 5.0);
}

TEST_F(LoopClosure, ClutteredVariantDrivesTheSameRoute) {
  const Scenario s = scenario("loop-closure-cluttered");
  const Dataset d = simulate(s.world, s.config);
  EXPECT_EQ(d.truth.poses.size(), data_->truth.poses.size());
  EXPECT_EQ(d.truth.poses.back().pose, data_->truth.poses.back().pose);
  std::size_t clutter = 0, observations = 0;
  for (const std::vector<int>& ids : d.truth.observation_ids) {
    observations += ids.size();
    clutter += static_cast<std::size_t>(std::count(ids.begin(), ids.end(), kUnknownId));
  }
  // One clutter per sweep on average: a Poisson total with the sweep count as mean and variance.
  const double sweeps = static_cast<double>(sweeps_of(d, s.config));
  EXPECT_NEAR(static_cast<double>(clutter), sweeps, 4.0 * std::sqrt(sweeps));
  EXPECT_GT(observations, clutter);
}

}  // namespace
}  // namespace slamkit
