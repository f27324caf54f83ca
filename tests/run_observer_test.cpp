// The runner's observers: they see every scan in order; a stop request ends the run after the
// current event with a partial result that the run folder keeps as such, and so does a filter whose
// estimate stops being finite; and the replay recorder's frames hold what the filter did with each
// observation.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <limits>
#include <map>

#include "slamkit/core/base64.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/replay.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/building.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"
#include "wrapped_motion_model.hpp"

namespace slamkit {
namespace {

Dataset default_dataset() {
  const Scenario s = scenario("default");
  return simulate(s.world, s.config);
}

std::size_t count_scans(const Dataset& d) {
  std::size_t n = 0;
  for (const Event& e : d.events) n += std::holds_alternative<ScanEvent>(e);
  return n;
}

class StopAfter : public RunObserver {
 public:
  StopAfter(std::size_t scans, std::atomic<bool>& stop) : scans_(scans), stop_(stop) {}
  void on_scan(const SlamFilter&, const ScanEvent& scan, std::size_t done, std::size_t total) override {
    EXPECT_GT(scan.t, last_t_);
    EXPECT_LE(done, total);
    last_t_ = scan.t;
    if (++seen_ == scans_) stop_.store(true);
  }
  std::size_t seen_ = 0;

 private:
  std::size_t scans_;
  std::atomic<bool>& stop_;
  double last_t_ = -1.0;
};

TEST(RunObserver, StopGivesAPartialResultThatTheRunFolderKeeps) {
  const Dataset data = default_dataset();
  auto filter = make_filter(FilterConfig{}, data);
  std::atomic<bool> stop{false};
  StopAfter observer(25, stop);
  RunOptions options;
  options.observers.push_back(&observer);
  options.stop = &stop;
  RunResult run = run_filter(*filter, data, options);
  EXPECT_TRUE(run.partial);
  EXPECT_EQ(run.scans, 25u);
  EXPECT_EQ(observer.seen_, 25u);
  EXPECT_LT(run.filtered.back().t, data.truth.poses.back().t);
  EXPECT_LE(run.dead_reckoning.back().t, run.filtered.back().t);

  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "slamkit_partial_run_test";
  write_run(dir.string(), run);
  const RunResult back = read_run(dir.string());
  EXPECT_TRUE(back.partial);
  EXPECT_EQ(back.scans, 25u);
  std::filesystem::remove_all(dir);

  // Without a stop request the same observers see the whole run.
  auto whole_filter = make_filter(FilterConfig{}, data);
  std::atomic<bool> never{false};
  StopAfter counter(0, never);
  options.observers = {&counter};
  options.stop = &never;
  const RunResult whole = run_filter(*whole_filter, data, options);
  EXPECT_FALSE(whole.partial);
  EXPECT_EQ(counter.seen_, count_scans(data));
}

// The dataset's motion model until its `healthy`-th prediction, NaN from then on: a filter fed it
// diverges part-way through the run.
class NanAfter final : public test_data::WrappedMotionModel {
 public:
  NanAfter(std::shared_ptr<const MotionModel> model, std::size_t healthy)
      : WrappedMotionModel(std::move(model)), left_(healthy) {}
  Pose2 predict(const Pose2& x, const Control& u, double dt) const override {
    if (left_ == 0) return Pose2::Constant(std::numeric_limits<double>::quiet_NaN());
    --left_;
    return model_->predict(x, u, dt);
  }

 private:
  mutable std::size_t left_;
};

class DivergedRun : public ::testing::TestWithParam<FilterKind> {};

// Without the stop, the NaN pose gates out every observation and, without identities, each one would
// start a landmark for the rest of the run.
TEST_P(DivergedRun, StopsAtTheLastFiniteEstimateAndTheRunFolderSaysWhen) {
  const Dataset data = default_dataset();
  FilterConfig config;
  config.filter = GetParam();
  config.particles = 10;
  config.threads = 1;  // the model's countdown is not thread-safe
  config.association.method = AssociationMethod::kNearestNeighbour;
  // The EKF predicts once per control, FastSLAM once per particle per control: the model turns NaN
  // at the 2001st control either way.
  const std::size_t predictions_per_control = GetParam() == FilterKind::kEkf ? 1 : 10;
  // The filter's model only: the run's dead reckoning keeps the dataset's.
  Dataset broken = data;
  broken.motion = std::make_shared<NanAfter>(data.motion, 2000 * predictions_per_control);
  auto filter = make_filter(config, broken);
  const RunResult run = run_filter(*filter, data);

  ASSERT_TRUE(run.diverged_at_s.has_value());
  EXPECT_TRUE(run.partial);
  double control_2001 = 0.0;
  std::size_t controls = 0;
  for (const Event& e : data.events)
    if (const auto* c = std::get_if<ControlEvent>(&e); c != nullptr && ++controls == 2001) control_2001 = c->t;
  EXPECT_EQ(*run.diverged_at_s, control_2001);
  EXPECT_EQ(run.steps, 2000u);
  for (const StampedPose& p : run.filtered) ASSERT_TRUE(p.pose.allFinite()) << "t " << p.t;
  for (const StampedPose& p : run.trajectory) ASSERT_TRUE(p.pose.allFinite()) << "t " << p.t;
  EXPECT_LT(run.filtered.back().t, *run.diverged_at_s);
  EXPECT_GT(run.map.size(), 5u);
  for (const Landmark& lm : run.map) ASSERT_TRUE(lm.position.allFinite() && lm.covariance.allFinite());

  // A folder of each instance's own: the instances run side by side under ctest.
  const test_data::ScratchDir dir;
  write_run(dir.file("run"), run);
  const RunResult back = read_run(dir.file("run"));
  EXPECT_TRUE(back.partial);
  EXPECT_EQ(back.diverged_at_s, run.diverged_at_s);
  EXPECT_EQ(back.divergence, "its pose estimate was no longer finite");
}

INSTANTIATE_TEST_SUITE_P(Filters, DivergedRun, ::testing::Values(FilterKind::kEkf, FilterKind::kFastSlam2),
                         [](const auto& info) { return to_string(info.param); });

TEST(ReplayRecorder, FramesHoldTheMapAndEachObservationsDecision) {
  const Dataset data = default_dataset();
  FilterConfig config;
  config.filter = FilterKind::kFastSlam2;
  config.particles = 30;
  config.association.method = AssociationMethod::kNearestNeighbour;
  auto filter = make_filter(config, data);
  ReplayOptions replay_options;
  replay_options.max_frames = 40;
  replay_options.max_particles = 10;
  ReplayRecorder recorder(data, replay_options);
  RunOptions options;
  options.observers.push_back(&recorder);
  const RunResult run = run_filter(*filter, data, options);
  const nlohmann::json replay = recorder.to_json(run.filter);

  const std::size_t scans = count_scans(data);
  const std::size_t stride = replay.at("meta").at("stride");
  EXPECT_EQ(stride, (scans + 39) / 40);
  const nlohmann::json& frames = replay.at("frames");
  // Every stride-th scan, and the last one.
  EXPECT_EQ(frames.size(), (scans + stride - 1) / stride + ((scans - 1) % stride != 0));
  for (std::size_t f = 0; f + 1 < frames.size(); ++f) {
    const std::size_t k = f * stride;
    ASSERT_EQ(frames[f].at("t").get<double>(), std::round(run.scan_times[k] * 1000.0) / 1000.0);
    const nlohmann::json& rays = frames[f].at("rays");
    ASSERT_EQ(rays.size(), 3 * run.associations[k].size());
    for (std::size_t i = 0; i < run.associations[k].size(); ++i) {
      const int code = rays[3 * i + 2];
      const int recorded = static_cast<int>(run.associations[k][i].decision);
      // A wrong update (3) is an update the truth disagrees with.
      EXPECT_TRUE(code == recorded || (code == 3 && recorded == 0)) << "frame " << f << " ray " << i;
    }
    EXPECT_EQ(frames[f].at("landmarks").size() % 6, 0u);
    EXPECT_EQ(frames[f].at("particles").size(), 2 * 10u);
    EXPECT_EQ(frames[f].at("error").size(), 3u);
  }
  EXPECT_EQ(frames.back().at("landmarks").size(), 6 * run.map.size());
  // The true path, thinned to every k-th sample for k = n / 4000 (at least 1).
  const std::size_t truth_step = std::max<std::size_t>(1, data.truth.poses.size() / 4000);
  EXPECT_EQ(replay.at("truth").size(), (data.truth.poses.size() + truth_step - 1) / truth_step);
  EXPECT_TRUE(replay.at("meta").at("wrong_known").get<bool>());
  for (const nlohmann::json& frame : frames) EXPECT_FALSE(frame.contains("hypotheses")) << "every landmark starts at once";
}

// A radio's beacons start from several ranges: until then a frame holds where each may lie, seven
// numbers per hypothesis, the weights of one beacon's summing to one.
TEST(ReplayRecorder, FramesHoldTheHypothesesOfLandmarksWaitingToStart) {
  Scenario s = scenario("default");
  s.config.sensor = SensorKind::kRangeOnly;
  s.config.loops = 1;
  const Dataset data = simulate(s.world, s.config);
  FilterConfig config;
  config.ekf_variant = EkfVariant::kFirstEstimates;
  config.landmark_init = LandmarkInit::kRing;
  auto filter = make_filter(config, data);
  ReplayRecorder recorder(data, {.max_frames = 100});
  RunOptions options;
  options.observers.push_back(&recorder);
  const RunResult run = run_filter(*filter, data, options);
  const nlohmann::json replay = recorder.to_json(run.filter);
  std::size_t with_hypotheses = 0;
  for (const nlohmann::json& frame : replay.at("frames")) {
    if (!frame.contains("hypotheses")) continue;
    ++with_hypotheses;
    const nlohmann::json& held = frame.at("hypotheses");
    ASSERT_EQ(held.size() % 7, 0u);
    std::map<int, double> weight;
    for (std::size_t i = 0; i < held.size(); i += 7) weight[held[i].get<int>()] += held[i + 6].get<double>();
    for (const auto& [id, total] : weight) EXPECT_NEAR(total, 1.0, 0.01) << "landmark " << id;
  }
  EXPECT_GT(with_hypotheses, 10u);
}

// A grid filter's frames come at its laser scans: the scan's beam ends around the pose, and in a
// bounded number of frames (always the last) a picture of the best particle's grid as it grows.
TEST(ReplayRecorder, GridFiltersFramesHoldBeamEndsAndPicturesOfTheGrowingMap) {
  BuildingSimConfig building;
  building.loops = 1;
  const Dataset data = simulate_building(office_floor_plan(), building);
  FilterConfig config;
  config.filter = FilterKind::kGridFastSlam;
  config.particles = 4;
  auto filter = make_filter(config, data);
  ReplayOptions replay_options;
  replay_options.max_frames = 50;
  replay_options.max_grid_images = 5;
  replay_options.grid_image_side = 100;
  ReplayRecorder recorder(data, replay_options, true);
  RunOptions options;
  options.observers.push_back(&recorder);
  const RunResult run = run_filter(*filter, data, options);
  const nlohmann::json replay = recorder.to_json(run.filter);

  const nlohmann::json& frames = replay.at("frames");
  EXPECT_EQ(replay.at("meta").at("scans").get<std::size_t>(), run.scans);
  ASSERT_GE(frames.size(), 40u);
  std::vector<std::size_t> pictured;
  double previous_area = 0.0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const nlohmann::json& frame = frames[f];
    EXPECT_TRUE(frame.at("landmarks").empty());
    EXPECT_EQ(frame.at("particles").size(), 2 * 4u);
    const nlohmann::json& ends = frame.at("beam_ends");
    ASSERT_GE(ends.size(), 2 * 50u) << "frame " << f;
    ASSERT_LE(ends.size(), 2 * replay_options.max_beam_ends);
    // Every return ends within the laser's range of the pose.
    const double x = frame.at("pose")[0], y = frame.at("pose")[1];
    for (std::size_t i = 0; i < ends.size(); i += 2)
      EXPECT_LE(std::hypot(ends[i].get<double>() - x, ends[i + 1].get<double>() - y), building.max_range);
    if (!frame.contains("grid")) continue;
    pictured.push_back(f);
    const nlohmann::json& grid = frame.at("grid");
    const std::string png = grid.at("png");
    EXPECT_EQ(png.substr(0, 8), base64("\x89PNG\r\n\x1a\n").substr(0, 8));
    const double area = grid.at("w").get<double>() * grid.at("h").get<double>();
    EXPECT_GE(area, previous_area) << "the map only grows";
    previous_area = area;
  }
  EXPECT_LE(pictured.size(), replay_options.max_grid_images + 1);
  EXPECT_GE(pictured.size(), replay_options.max_grid_images - 1);
  EXPECT_EQ(pictured.front(), 0u);
  EXPECT_EQ(pictured.back(), frames.size() - 1) << "the last frame shows the final map";
  // The final picture covers the run's map.
  const nlohmann::json& last = frames.back().at("grid");
  EXPECT_NEAR(last.at("x").get<double>(), run.grid.origin.x(), 1e-3);
  EXPECT_GE(last.at("w").get<double>(), run.grid.width * run.grid.resolution - 1e-3);
}

}  // namespace
}  // namespace slamkit
