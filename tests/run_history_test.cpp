// The runner's history modes and its guard on event streams: `none` keeps the start and the final
// estimate, `decimated` at most its capacity of evenly spread samples plus the final one, both the
// same final estimate and map as a full run; the run folder keeps the mode and reads back; and an
// event stream no filter can be fed is refused with one InputError naming the event.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <set>

#include "slamkit/core/error.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "sim_test_support.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

using test_sim::one_lap;

RunResult run_with(History history, std::size_t decimated_samples = 10'000,
                   FilterKind kind = FilterKind::kEkf) {
  FilterConfig config;
  config.filter = kind;
  config.particles = 20;
  auto filter = make_filter(config, one_lap());
  RunOptions options;
  options.history = history;
  options.decimated_samples = decimated_samples;
  return run_filter(*filter, one_lap(), options);
}

void expect_same_end(const RunResult& a, const RunResult& b) {
  EXPECT_EQ(a.filtered.back().t, b.filtered.back().t);
  EXPECT_EQ(a.filtered.back().pose, b.filtered.back().pose);
  EXPECT_EQ(a.pose_covariances.back(), b.pose_covariances.back());
  ASSERT_EQ(a.map.size(), b.map.size());
  for (std::size_t i = 0; i < a.map.size(); ++i) EXPECT_EQ(a.map[i].position, b.map[i].position);
  EXPECT_EQ(a.dead_reckoning.back().t, b.dead_reckoning.back().t);
  EXPECT_EQ(a.dead_reckoning.back().pose, b.dead_reckoning.back().pose);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.scans, b.scans);
}

TEST(RunHistory, NoneKeepsTheStartAndTheFinalEstimateOnly) {
  const RunResult full = run_with(History::kFull);
  const RunResult none = run_with(History::kNone);
  ASSERT_EQ(none.filtered.size(), 2u);
  EXPECT_EQ(none.filtered.front().t, full.filtered.front().t);
  EXPECT_EQ(none.pose_covariances.size(), 2u);
  EXPECT_EQ(none.dead_reckoning.size(), 2u);
  EXPECT_TRUE(none.associations.empty());
  EXPECT_TRUE(none.landmark_std.empty());
  EXPECT_EQ(none.history, "none");
  expect_same_end(none, full);
}

// Two kept poses fit any SE(2) alignment exactly: scoring them would report an ATE near zero.
TEST(RunHistory, WithoutHistoryTheTrajectoryMetricsAreLeftEmptyNotNearZero) {
  const Metrics full = evaluate_run(run_with(History::kFull), one_lap().truth);
  const Metrics none = evaluate_run(run_with(History::kNone), one_lap().truth);
  ASSERT_TRUE(full.ate_rmse_m.has_value());
  EXPECT_GT(*full.ate_rmse_m, 0.05);
  EXPECT_FALSE(none.ate_rmse_m.has_value());
  EXPECT_FALSE(none.nees_pose.has_value());
  EXPECT_FALSE(none.map_rmse_m.has_value());
  EXPECT_EQ(none.landmarks, full.landmarks);
  const nlohmann::json j = to_json(none);
  EXPECT_EQ(j.at("history"), "none");
  EXPECT_TRUE(j.at("ate_rmse_m").is_null());
  EXPECT_TRUE(j.contains("history_note"));
}

TEST(RunHistory, DecimatedKeepsAtMostItsCapacityEvenlySpreadAndTheEnd) {
  const RunResult full = run_with(History::kFull);
  constexpr std::size_t kCapacity = 100;
  const RunResult thin = run_with(History::kDecimated, kCapacity);
  ASSERT_GT(full.filtered.size(), 20 * kCapacity);
  EXPECT_LE(thin.filtered.size(), kCapacity + 1);  // the final estimate may come on top
  EXPECT_GT(thin.filtered.size(), kCapacity / 2);
  EXPECT_EQ(thin.filtered.size(), thin.pose_covariances.size());
  // Every kept sample is the full run's at the same time, and the gaps between them are equal
  // (in samples of the full run): the stride, a power of two.
  std::vector<std::size_t> index;
  for (const StampedPose& p : thin.filtered) {
    const auto it = std::find_if(full.filtered.begin(), full.filtered.end(),
                                 [&](const StampedPose& q) { return q.t == p.t; });
    ASSERT_NE(it, full.filtered.end());
    EXPECT_EQ(it->pose, p.pose);
    index.push_back(static_cast<std::size_t>(it - full.filtered.begin()));
  }
  const std::size_t stride = index[1] - index[0];
  EXPECT_EQ(stride & (stride - 1), 0u) << stride;
  for (std::size_t i = 1; i + 1 < index.size(); ++i) EXPECT_EQ(index[i] - index[i - 1], stride);
  EXPECT_LE(thin.dead_reckoning.size(), kCapacity + 1);
  EXPECT_TRUE(thin.associations.empty());
  std::set<double> std_times;
  for (const LandmarkStdSample& s : thin.landmark_std) std_times.insert(s.t);
  EXPECT_LE(std_times.size(), kCapacity);
  EXPECT_GT(std_times.size(), 0u);
  expect_same_end(thin, full);
}

TEST(RunHistory, ParticleFiltersKeepTheirCloudsThinnedAndNoPathWithoutFullHistory) {
  const RunResult thin = run_with(History::kDecimated, 50, FilterKind::kFastSlam2);
  EXPECT_FALSE(thin.smoothed);
  std::set<double> cloud_times;
  for (const ParticleSample& s : thin.particles) cloud_times.insert(s.t);
  EXPECT_LE(cloud_times.size(), 50u);
  EXPECT_GT(cloud_times.size(), 0u);
  const RunResult none = run_with(History::kNone, 50, FilterKind::kFastSlam2);
  EXPECT_TRUE(none.particles.empty());
  EXPECT_EQ(none.trajectory.size(), 2u);
  // The paths the particles stop keeping only ever served the smoothed trajectory.
  expect_same_end(none, run_with(History::kFull, 50, FilterKind::kFastSlam2));
}

TEST(RunHistory, AParticleFilterToldToForgetItsPathsKeepsNone) {
  FilterConfig config;
  config.filter = FilterKind::kFastSlam1;
  config.particles = 10;
  auto filter = make_filter(config, one_lap());
  RunOptions options;
  options.history = History::kDecimated;
  run_filter(*filter, one_lap(), options);
  EXPECT_TRUE(filter->smoothed_trajectory().empty());
  auto kept = make_filter(config, one_lap());
  run_filter(*kept, one_lap());
  EXPECT_GT(kept->smoothed_trajectory().size(), 1000u);
}

TEST(RunHistory, TheRunFolderKeepsTheModeAndReadsBack) {
  const fs::path dir = fs::temp_directory_path() / "slamkit_run_history_test";
  fs::remove_all(dir);
  for (History history : {History::kNone, History::kDecimated}) {
    RunResult run = run_with(history, 100);
    run.association = "known";
    write_run(dir.string(), run);
    const RunResult back = read_run(dir.string());
    EXPECT_EQ(back.history, to_string(history));
    EXPECT_EQ(back.filtered.size(), run.filtered.size());
    EXPECT_EQ(back.scans, run.scans);
    EXPECT_TRUE(back.associations.empty());
  }
  fs::remove_all(dir);
}

TEST(RunHistory, NamesParseAndPrintBack) {
  for (History h : {History::kFull, History::kDecimated, History::kNone}) EXPECT_EQ(parse_history(to_string(h)), h);
  EXPECT_THROW(parse_history("some"), std::invalid_argument);
}

/// A copy of the lap with one event changed by `change`; the run must refuse it naming that event.
template <typename Change>
void expect_refused(std::size_t event, Change change, const std::string& expected) {
  Dataset data = one_lap();
  data.spec = "sim:changed";
  change(data.events.at(event));
  auto filter = make_filter(FilterConfig{}, data);
  try {
    run_filter(*filter, data);
    FAIL() << "expected an InputError for " << expected;
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("sim:changed: event " + std::to_string(event) + " "), std::string::npos) << message;
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
}

TEST(CheckEvents, RefusesWhatNoFilterCanBeFed) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const auto control = [](Event& e) -> ControlEvent& { return std::get<ControlEvent>(e); };
  ASSERT_TRUE(std::holds_alternative<ControlEvent>(one_lap().events.at(10)));
  expect_refused(10, [&](Event& e) { control(e).t = kNaN; }, "a time within +-1e+12 s");
  expect_refused(10, [&](Event& e) { control(e).t = 2e12; }, "a time within +-1e+12 s");
  expect_refused(10, [&](Event& e) { control(e).t = 0.0; }, "a time not before the previous event's");
  expect_refused(10, [&](Event& e) { control(e).dt = -0.1; }, "a control interval dt from 0");
  expect_refused(10, [&](Event& e) { control(e).dt = INFINITY; }, "a control interval dt from 0");
  expect_refused(10, [&](Event& e) { control(e).u(1) = kNaN; }, "control values within +-1e+06");
  expect_refused(10, [&](Event& e) { control(e).u(0) = 1e300; }, "control values within +-1e+06");
  expect_refused(10, [&](Event& e) { control(e).u.resize(3); }, "a control of 2 values for the motion model");
  std::size_t scan = 0;
  while (!std::holds_alternative<ScanEvent>(one_lap().events.at(scan))) ++scan;
  expect_refused(scan, [](Event& e) { std::get<ScanEvent>(e).observations.at(0).z.y() = -INFINITY; },
                 "measurement values within +-1e+06");
}

// A dataset built in code is not checked by a reader: a start 1e20 m out was scored as a map error
// of 1e20 m.
TEST(CheckEvents, RefusesAStartPoseBeyondTheCoordinateBound) {
  for (const Pose2& start : {Pose2(1e20, 0.0, 0.0), Pose2(0.0, -2.5e6, 0.0), Pose2(0.0, 0.0, INFINITY)}) {
    Dataset data = one_lap();
    data.spec = "sim:moved";
    data.initial_pose = start;
    try {
      check_events(data);
      ADD_FAILURE() << "expected an InputError for the start " << start.transpose();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("sim:moved: expected an initial pose with x and y within"),
                std::string::npos)
          << e.what();
    }
  }
  Dataset data = one_lap();
  data.initial_pose = Pose2(2e6, -2e6, 3.0);
  EXPECT_NO_THROW(check_events(data));
}

TEST(CheckEvents, AcceptsLongGapsAndRepeatedTimes) {
  Dataset data = one_lap();
  // From a control on, every event a day later: one long control interval, then the log as it was.
  std::size_t gap = 100;
  while (!std::holds_alternative<ControlEvent>(data.events.at(gap))) ++gap;
  for (std::size_t i = gap; i < data.events.size(); ++i) std::visit([](auto& e) { e.t += 86'400.0; }, data.events[i]);
  std::get<ControlEvent>(data.events[gap]).dt += 86'400.0;
  EXPECT_NO_THROW(check_events(data));
  auto filter = make_filter(FilterConfig{}, data);
  EXPECT_TRUE(run_filter(*filter, data).filtered.back().pose.allFinite());
}

}  // namespace
}  // namespace slamkit
