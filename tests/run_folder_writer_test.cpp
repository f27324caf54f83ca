// The whole run folder as every front end writes it (pipeline/run_folder): the files `slamkit run`
// leaves, read back by read_run and scored as the returned evaluation; the replay's pose error
// unaligned where the truth shares the map's frame and aligned where it has a frame of its own, and
// the recording saying which; and what run.json records of a dataset.
#include "slamkit/pipeline/run_folder.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "slamkit/core/json_options.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

class RunFolderWriter : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("slamkit_run_folder_writer_" + std::to_string(::getpid()));
    const Scenario s = scenario("default");
    data_ = simulate(s.world, s.config);
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// An EKF run over `data` recorded by `recorder`.
  static RunResult recorded_run(const Dataset& data, ReplayRecorder& recorder) {
    auto filter = make_filter(FilterConfig{}, data);
    RunOptions options;
    options.observers.push_back(&recorder);
    return run_filter(*filter, data, options);
  }

  static double largest_position_error(const nlohmann::json& recording) {
    double largest = 0.0;
    for (const nlohmann::json& frame : recording.at("frames"))
      largest = std::max(largest, std::hypot(frame.at("error")[0].get<double>(), frame.at("error")[1].get<double>()));
    return largest;
  }

  fs::path dir_;
  Dataset data_;
};

TEST_F(RunFolderWriter, WritesEveryFileOfARunAndReturnsTheEvaluationItStored) {
  ReplayRecorder recorder(data_);
  const RunResult run = recorded_run(data_, recorder);
  const Metrics metrics = write_run_folder(dir_.string(), run, data_, &recorder);
  for (const char* file : {"run.json", "trajectory.tum", "pose_covariance.txt", "map.txt", "associations.txt",
                           "truth.tum", "metrics.json", "map.svg", "landmark_std.svg", "nees.svg", "pose_error.svg",
                           "replay.json", "replay.html"})
    EXPECT_TRUE(fs::exists(dir_ / file)) << file;
  const nlohmann::json stored = read_json_file((dir_ / "metrics.json").string());
  EXPECT_EQ(stored.at("ate_rmse_m").get<double>(), *metrics.ate_rmse_m);

  // What `slamkit evaluate` does with the folder gives the same numbers.
  const Metrics again = write_evaluation(dir_.string(), read_run(dir_.string()), data_);
  EXPECT_NEAR(*again.ate_rmse_m, *metrics.ate_rmse_m, 1e-9);
  EXPECT_FALSE(read_json_file((dir_ / "replay.json").string()).at("meta").at("error_aligned").get<bool>());

  // Without a truth trajectory there is no truth.tum, not a stale one.
  Dataset no_truth = data_;
  no_truth.truth.poses.clear();
  write_evaluation(dir_.string(), run, no_truth);
  EXPECT_FALSE(fs::exists(dir_ / "truth.tum"));
}

TEST_F(RunFolderWriter, ReplayOfATruthInAFrameOfItsOwnIsAlignedAndSaysSo) {
  // The same run against its truth moved to another frame, of positions only, as GPS is: unaligned,
  // its error would be the 100 m of the move; aligned, it is the run's own error.
  ReplayRecorder recorder(data_);
  const RunResult run = recorded_run(data_, recorder);
  const nlohmann::json in_map_frame = replay_recording(recorder, run, data_, evaluate_run(run, data_.truth));
  EXPECT_FALSE(in_map_frame.at("meta").at("error_aligned").get<bool>());

  Dataset gps = data_;
  const Eigen::Rotation2Dd turn(std::numbers::pi / 6);
  for (StampedPose& p : gps.truth.poses) {
    p.pose.head<2>() = turn * p.pose.head<2>() + Vector2(80.0, -60.0);
    p.pose.z() = 0.0;
  }
  for (Landmark& l : gps.truth.landmarks) l.position = turn * l.position + Vector2(80.0, -60.0);
  gps.truth.poses_have_heading = false;
  ReplayRecorder gps_recorder(gps);
  const RunResult gps_run = recorded_run(gps, gps_recorder);
  const nlohmann::json aligned = replay_recording(gps_recorder, gps_run, gps, evaluate_run(gps_run, gps.truth));
  EXPECT_TRUE(aligned.at("meta").at("error_aligned").get<bool>());
  const double own_error = largest_position_error(in_map_frame);
  EXPECT_LT(own_error, 2.0);
  EXPECT_LT(largest_position_error(aligned), 2.0 * own_error);
}

TEST(DatasetProvenance, RecordsASimulatorLogsParametersAndAnExactTimeOrigin) {
  const fs::path dir = fs::temp_directory_path() / ("slamkit_provenance_" + std::to_string(::getpid()));
  const Scenario s = scenario("default");
  const Dataset log = simulate(s.world, s.config);
  write_sim_log(dir.string(), log, s.config, s.world);
  nlohmann::json provenance = {{"front_end", "test"}};
  add_dataset_provenance(provenance, "sim:" + dir.string(), log);
  EXPECT_EQ(provenance.at("simulator"), read_json_file((dir / "params.json").string()));
  EXPECT_FALSE(provenance.contains("time_origin_s"));
  EXPECT_EQ(provenance.at("front_end"), "test");
  fs::remove_all(dir);

  Dataset shifted;
  shifted.time_origin_s = 1248272262;
  shifted.time_origin_fraction_s = 0.000001;
  nlohmann::json origin = nlohmann::json::object();
  add_dataset_provenance(origin, "mrclam:/data:1", shifted);
  EXPECT_EQ(origin.at("time_origin_s"), "1248272262.000001000");
}

}  // namespace
}  // namespace slamkit
