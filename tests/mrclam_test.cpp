// The MRCLAM reader: on the real Dataset6 and Dataset1 (skipped when the data is absent), the counts
// of the dataset's documentation, a well-formed event stream and a plausible dead reckoning; on small
// synthetic directories, the exact events and every way the input can be rejected.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <variant>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/eval/metrics.hpp"
#include "slamkit/io/mrclam.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "test_data.hpp"

using namespace slamkit;
namespace fs = std::filesystem;

namespace {

/// The MRCLAM folder: $SLAMKIT_DATA/mrclam, else the shared datasets beside the source tree.
fs::path mrclam_root() {
  if (const char* data = std::getenv("SLAMKIT_DATA")) return fs::path(data) / "mrclam";
  return fs::path(SLAMKIT_SOURCE_DIR) / ".." / "shared" / "datasets" / "mrclam";
}

#define REQUIRE_DATASET(dir)                                                                           \
  if (!fs::is_directory(dir))                                                                          \
  GTEST_SKIP() << "MRCLAM data not found at " << (dir).string()                                        \
               << " (set SLAMKIT_DATA to a folder holding mrclam/)"

/// The stream's invariants: time never decreases, each control starts where the previous event
/// ended, no control has a zero span, and every observation names a landmark of the truth.
void expect_well_formed(const Dataset& d, const std::set<int>& landmark_ids) {
  double now = 0.0;
  for (const Event& e : d.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      ASSERT_GT(c->dt, 0.0);
      ASSERT_NEAR(c->t - c->dt, now, 1e-9);
      ASSERT_EQ(c->u.size(), 2);
      now = c->t;
    } else {
      const auto& s = std::get<ScanEvent>(e);
      ASSERT_NEAR(s.t, now, 1e-12) << "a scan is taken at the end of the control before it";
      ASSERT_FALSE(s.observations.empty());
      for (const Observation& o : s.observations) {
        ASSERT_TRUE(landmark_ids.count(o.id)) << o.id;
        ASSERT_GT(o.z[0], 0.0);
        ASSERT_LE(std::abs(o.z[1]), d.sensor.fov / 2);
        ASSERT_LE(o.z[0], d.sensor.max_range);
      }
    }
  }
}

struct RobotCounts {
  std::size_t odometry, measurements, landmarks, robots, unknown, truth;
};

}  // namespace

// ---- The real data ------------------------------------------------------------------------------------

TEST(MrclamData, Dataset6AllRobotsMatchTheDocumentedCounts) {
  const fs::path dir = mrclam_root() / "MRCLAM_Dataset6";
  REQUIRE_DATASET(dir);
  // From the dataset's README: rows per file, and measurement rows split into landmark, robot and
  // unknown-barcode rows.
  const RobotCounts expected[] = {{61785, 1942, 1534, 407, 1, 49241},
                                  {65005, 4031, 3239, 792, 0, 59705},
                                  {61158, 5627, 4348, 1277, 2, 56977},
                                  {52916, 2399, 2023, 373, 3, 61714},
                                  {60567, 5378, 4239, 1139, 0, 57467}};
  for (int robot = 1; robot <= 5; ++robot) {
    SCOPED_TRACE("robot " + std::to_string(robot));
    const RobotCounts& c = expected[robot - 1];
    MrclamStats stats;
    const Dataset d = read_mrclam(dir.string(), robot, MrclamOptions{}, stats);
    EXPECT_EQ(d.name, "mrclam:MRCLAM_Dataset6/Robot" + std::to_string(robot));
    EXPECT_EQ(stats.odometry_rows, c.odometry);
    EXPECT_EQ(stats.measurement_rows, c.measurements);
    EXPECT_EQ(stats.robot_measurements, c.robots);
    EXPECT_EQ(stats.unknown_barcodes, c.unknown);
    EXPECT_EQ(stats.observations + stats.outside_run,
              stats.measurement_rows - stats.robot_measurements - stats.unknown_barcodes);
    EXPECT_EQ(stats.observations, c.landmarks);  // every landmark row lies within the run
    EXPECT_GT(stats.duration, 880.0);
    EXPECT_LT(stats.duration, 890.0);

    ASSERT_EQ(d.truth.landmarks.size(), 15u);
    std::set<int> ids;
    for (const Landmark& l : d.truth.landmarks) ids.insert(l.id);
    EXPECT_EQ(*ids.begin(), 6);
    EXPECT_EQ(*ids.rbegin(), 20);
    expect_well_formed(d, ids);

    std::size_t scans = 0, observations = 0, controls = 0;
    for (const Event& e : d.events) {
      if (const auto* s = std::get_if<ScanEvent>(&e)) {
        ++scans;
        observations += s->observations.size();
      } else {
        ++controls;
      }
    }
    EXPECT_EQ(scans, stats.scans);
    EXPECT_EQ(observations, stats.observations);
    // One control per odometry interval, plus one more per scan that cuts an interval.
    EXPECT_GE(controls, c.odometry - 1 - stats.superseded_odometry_rows);
    EXPECT_LE(controls, c.odometry - 1 - stats.superseded_odometry_rows + scans);

    // The truth shares the events' time base, is cut to the run, and starts the run.
    ASSERT_TRUE(stats.initial_pose_from_truth);
    ASSERT_FALSE(d.truth.poses.empty());
    EXPECT_GE(d.truth.poses.front().t, 0.0);
    EXPECT_LT(d.truth.poses.front().t, 0.1);
    EXPECT_LE(d.truth.poses.back().t, stats.duration);
    EXPECT_LT((d.truth.poses.front().pose.head<2>() - d.initial_pose.head<2>()).norm(), 0.01);

    const auto pairs = eval::match_by_time(dead_reckoning(d), d.truth.poses, 0.5);
    const eval::AteResult ate = eval::absolute_trajectory_error(pairs);
    EXPECT_TRUE(std::isfinite(ate.rmse));
    EXPECT_GT(ate.rmse, 0.1);  // commanded velocities are not that good
    EXPECT_LT(ate.rmse, 5.0);  // but they do describe the motion: the room is 15 m x 8 m
    std::cout << "Dataset6 robot " << robot << ": " << stats.duration << " s, " << stats.odometry_rows
              << " odometry rows (" << stats.superseded_odometry_rows << " superseded), " << stats.scans
              << " scans, " << stats.observations << " observations, dropped " << stats.robot_measurements
              << " robot and " << stats.unknown_barcodes << " unknown-barcode rows; dead-reckoning ATE "
              << ate.rmse << " m over " << ate.matched << " truth poses\n";
  }
}

TEST(MrclamData, Dataset1WithoutRobotTruthHasLandmarksOnly) {
  const fs::path dir = mrclam_root() / "MRCLAM_Dataset1";
  REQUIRE_DATASET(dir);
  MrclamStats stats;
  const Dataset d = read_mrclam(dir.string(), 3, MrclamOptions{}, stats);
  EXPECT_EQ(stats.odometry_rows, 97351u);
  EXPECT_EQ(stats.measurement_rows, 8742u);
  EXPECT_EQ(stats.robot_measurements, 1969u);
  EXPECT_EQ(stats.unknown_barcodes, 2u);
  EXPECT_EQ(stats.observations + stats.outside_run, 6771u);
  EXPECT_TRUE(d.truth.poses.empty());
  EXPECT_FALSE(stats.initial_pose_from_truth);
  EXPECT_EQ(d.initial_pose, Pose2::Zero());
  EXPECT_EQ(d.truth.landmarks.size(), 15u);
  std::set<int> ids;
  for (const Landmark& l : d.truth.landmarks) ids.insert(l.id);
  expect_well_formed(d, ids);
}

TEST(MrclamData, ShippedConfigHoldsTheDefaults) {
  const std::string path = std::string(SLAMKIT_SOURCE_DIR) + "/config/mrclam.json";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  EXPECT_EQ(to_json(mrclam_options_from_json(nlohmann::json::parse(in), path)), to_json(MrclamOptions{}));
}

// ---- Synthetic directories ------------------------------------------------------------------------------

namespace {

constexpr const char* kHeader = "# synthetic MRCLAM file\r\n# for the tests\r\n";

/// A fresh directory per test, filled with a small well-formed dataset that tests then spoil.
class MrclamFiles : public testing::Test {
 protected:
  void SetUp() override {
    const testing::TestInfo* info = testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("slamkit_mrclam_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // Subjects 1-2 robots (barcodes 5, 14), 6-7 landmarks (barcodes 63, 81).
    write("Barcodes.dat", "  1 \t   5 \r\n  2 \t  14 \r\n  6 \t  63 \r\n  7 \t  81 \r\n");
    write("Landmark_Groundtruth.dat", "  6 \t 1.0 \t 2.0 \t 0.0001 \t 0.0002 \r\n  7 \t -1.5 \t 0.5 \t 0.0001 \t 0.0001 \r\n");
    // The command at 100.000 is superseded by the one at the same time; the others hold 0.5 s each.
    write("Robot1_Odometry.dat",
          "1000000100.000 \t  0.0 \t 0.0 \r\n"
          "1000000100.000 \t  0.1 \t 0.0 \r\n"
          "1000000100.500 \t  0.1 \t 0.2 \r\n"
          "1000000101.000 \t  0.0 \t 0.0 \r\n");
    write("Robot1_Measurement.dat",
          "1000000099.900 \t 63 \t 2.0 \t 0.1 \r\n"     // before the run
          "1000000100.200 \t 63 \t 2.1 \t 0.2 \r\n"     // one frame ...
          "1000000100.201 \t 14 \t 3.0 \t 0.0 \r\n"     // ... seeing a robot ...
          "1000000100.202 \t 81 \t 2.5 \t -0.3 \r\n"    // ... and a second landmark
          "1000000100.500 \t 43 \t 1.0 \t 0.0 \r\n"     // a false detection
          "1000000100.500 \t 81 \t 2.4 \t -0.25 \r\n"   // at an odometry row's time
          "1000000101.500 \t 63 \t 2.0 \t 0.1 \r\n");   // after the run
    write_gz("Robot1_Groundtruth.dat.gz",
             "1000000099.000 \t 0.0 \t 0.0 \t 3.0 \r\n"
             "1000000100.000 \t 0.5 \t 0.25 \t -3.0 \r\n"
             "1000000100.500 \t 0.6 \t 0.25 \t -3.0 \r\n"
             "1000000102.000 \t 0.7 \t 0.25 \t -3.0 \r\n");
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  void write(const std::string& name, const std::string& rows) const {
    std::ofstream(path(name), std::ios::binary) << kHeader << rows;
  }
  void write_gz(const std::string& name, const std::string& rows) const {
    const std::string text = kHeader + rows;
    gzFile f = gzopen(path(name).c_str(), "wb");
    ASSERT_NE(f, nullptr);
    ASSERT_EQ(gzwrite(f, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
    ASSERT_EQ(gzclose(f), Z_OK);
  }
  /// Robot 1, its commands taking effect at their rows' times.
  Dataset read(MrclamStats& stats) const {
    MrclamOptions prompt;
    prompt.command_delay = 0.0;
    return read_mrclam(dir_.string(), 1, prompt, stats);
  }

  /// Reading robot 1 must throw an InputError at `line` of `file`; returns its message.
  std::string input_error(const std::string& file, std::size_t line, int robot = 1) const {
    return test_data::input_error_at([&] { read_mrclam(dir_.string(), robot); }, path(file), line);
  }

  fs::path dir_;
};

}  // namespace

TEST_F(MrclamFiles, EventsSplitHeldCommandsAtScans) {
  MrclamStats stats;
  const Dataset d = read(stats);
  EXPECT_DOUBLE_EQ(stats.time_origin, 1000000100.0);
  EXPECT_NEAR(stats.duration, 1.0, 1e-9);
  EXPECT_EQ(stats.odometry_rows, 4u);
  EXPECT_EQ(stats.superseded_odometry_rows, 1u);
  EXPECT_EQ(stats.measurement_rows, 7u);
  EXPECT_EQ(stats.robot_measurements, 1u);
  EXPECT_EQ(stats.unknown_barcodes, 1u);
  EXPECT_EQ(stats.outside_run, 2u);
  EXPECT_EQ(stats.observations, 3u);
  EXPECT_EQ(stats.scans, 2u);

  // control (0, 0.2] v=0.1 | scan at 0.2 | control (0.2, 0.5] v=0.1 | scan at 0.5 | control (0.5, 1]
  ASSERT_EQ(d.events.size(), 5u);
  const auto& c1 = std::get<ControlEvent>(d.events[0]);
  EXPECT_NEAR(c1.t, 0.2, 1e-9);
  EXPECT_NEAR(c1.dt, 0.2, 1e-9);
  EXPECT_EQ(c1.u[0], 0.1);
  const auto& s1 = std::get<ScanEvent>(d.events[1]);
  EXPECT_NEAR(s1.t, 0.2, 1e-9);
  ASSERT_EQ(s1.observations.size(), 2u);
  EXPECT_EQ(s1.observations[0].id, 6);
  EXPECT_EQ(s1.observations[1].id, 7);
  EXPECT_EQ(s1.observations[1].z, Vector2(2.5, -0.3));
  const auto& c2 = std::get<ControlEvent>(d.events[2]);
  EXPECT_NEAR(c2.t, 0.5, 1e-9);
  EXPECT_NEAR(c2.dt, 0.3, 1e-9);
  EXPECT_EQ(c2.u[0], 0.1);
  EXPECT_EQ(c2.u[1], 0.0);
  EXPECT_NEAR(std::get<ScanEvent>(d.events[3]).t, 0.5, 1e-9);
  const auto& c3 = std::get<ControlEvent>(d.events[4]);
  EXPECT_NEAR(c3.dt, 0.5, 1e-9);
  EXPECT_EQ(c3.u[1], 0.2);
  EXPECT_EQ(d.motion->name(), "velocity");
  EXPECT_EQ(d.observation->name(), "range-bearing");

  // The gzip-compressed truth, cut to the run [0, 1] s, and its pose at t = 0.
  ASSERT_EQ(d.truth.poses.size(), 2u);
  EXPECT_EQ(d.truth.poses[0].t, 0.0);
  EXPECT_NEAR(d.truth.poses[1].t, 0.5, 1e-9);
  EXPECT_TRUE(stats.initial_pose_from_truth);
  EXPECT_EQ(d.initial_pose, Pose2(0.5, 0.25, -3.0));
  ASSERT_EQ(d.truth.landmarks.size(), 2u);
  EXPECT_EQ(d.truth.landmarks[1].position, Vector2(-1.5, 0.5));
}

// A robot that acts on a command 0.2 s after its row: the commands move later (the robot standing
// still until the first takes effect), the scans and the truth stay, and the run ends 0.2 s after the
// last row.
TEST_F(MrclamFiles, CommandsTakeEffectAfterTheDelay) {
  MrclamOptions late;
  late.command_delay = 0.2;
  MrclamStats stats;
  const Dataset d = read_mrclam(dir_.string(), 1, late, stats);
  EXPECT_DOUBLE_EQ(stats.time_origin, 1000000100.0);
  EXPECT_NEAR(stats.duration, 1.2, 1e-9);
  // still (0, 0.2] | scan at 0.2 | control (0.2, 0.5] v=0.1 | scan at 0.5 | control (0.5, 0.7] v=0.1 |
  // control (0.7, 1.2]
  ASSERT_EQ(d.events.size(), 6u);
  const auto& still = std::get<ControlEvent>(d.events[0]);
  EXPECT_NEAR(still.t, 0.2, 1e-9);
  EXPECT_NEAR(still.dt, 0.2, 1e-9);
  EXPECT_EQ(still.u, Control::Zero(2));
  EXPECT_NEAR(std::get<ScanEvent>(d.events[1]).t, 0.2, 1e-9);
  const auto& c1 = std::get<ControlEvent>(d.events[2]);
  EXPECT_NEAR(c1.t, 0.5, 1e-9);
  EXPECT_NEAR(c1.dt, 0.3, 1e-9);
  EXPECT_EQ(c1.u[0], 0.1);
  EXPECT_NEAR(std::get<ScanEvent>(d.events[3]).t, 0.5, 1e-9);
  const auto& c2 = std::get<ControlEvent>(d.events[4]);
  EXPECT_NEAR(c2.dt, 0.2, 1e-9);
  EXPECT_EQ(c2.u[1], 0.0);
  const auto& c3 = std::get<ControlEvent>(d.events[5]);
  EXPECT_NEAR(c3.t, 1.2, 1e-9);
  EXPECT_EQ(c3.u[1], 0.2);
  EXPECT_EQ(d.initial_pose, Pose2(0.5, 0.25, -3.0));

  const auto message = [](double delay) {
    try {
      mrclam_options_from_json({{"command_delay_s", delay}}, "opts.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(-0.1).find("'command_delay_s' must be >= 0 and <= 10 (s)"), std::string::npos) << message(-0.1);
  EXPECT_NE(message(11.0).find("'command_delay_s'"), std::string::npos);
}

TEST_F(MrclamFiles, InitialPoseIsInterpolatedTheShortWayRound) {
  // The truth crosses +-pi between its samples either side of t = 0.
  fs::remove(path("Robot1_Groundtruth.dat.gz"));
  write("Robot1_Groundtruth.dat",
        "1000000099.000 \t 0.0 \t 0.0 \t 3.0 \r\n"
        "1000000101.000 \t 2.0 \t 1.0 \t -3.0 \r\n");
  MrclamStats stats;
  const Dataset d = read(stats);
  EXPECT_NEAR(d.initial_pose[0], 1.0, 1e-6);
  EXPECT_NEAR(d.initial_pose[1], 0.5, 1e-6);
  EXPECT_NEAR(std::abs(d.initial_pose[2]), kPi, 1e-6);
}

TEST_F(MrclamFiles, PlainFileIsPreferredToItsCompressedForm) {
  write_gz("Robot1_Odometry.dat.gz", "1000000100.000 \t 0.0 \t 0.0 \r\n1000000100.000 \t 0.0 \t 0.0 \r\nbad\r\n");
  MrclamStats stats;
  read(stats);
  EXPECT_EQ(stats.odometry_rows, 4u);
  fs::remove(path("Robot1_Odometry.dat"));
  EXPECT_NE(input_error("Robot1_Odometry.dat.gz", 5).find("expected 3 fields"), std::string::npos);
}

TEST_F(MrclamFiles, WithoutTruthTheRunStartsAtTheOrigin) {
  fs::remove(path("Robot1_Groundtruth.dat.gz"));
  fs::remove(path("Landmark_Groundtruth.dat"));
  MrclamStats stats;
  const Dataset d = read(stats);
  EXPECT_TRUE(d.truth.empty());
  EXPECT_FALSE(stats.initial_pose_from_truth);
  EXPECT_EQ(d.initial_pose, Pose2::Zero());
}

TEST_F(MrclamFiles, BadLinesAreNamed) {
  write("Robot1_Odometry.dat", "1000000100.000 \t 0.1 \t 0.0 \r\n1000000100.500 \t 0.1 \r\n");
  const std::string message = input_error("Robot1_Odometry.dat", 4);
  EXPECT_NE(message.find("Robot1_Odometry.dat:4: expected 3 fields"), std::string::npos) << message;
}

TEST_F(MrclamFiles, NanIsRejected) {
  write("Robot1_Measurement.dat", "1000000100.200 \t 63 \t 2.1 \t 0.2 \r\n1000000100.400 \t 63 \t nan \t 0.2 \r\n");
  EXPECT_NE(input_error("Robot1_Measurement.dat", 4).find("finite number for the range, found 'nan'"),
            std::string::npos);
  write("Robot1_Odometry.dat", "1000000100.000 \t 0.1 \t 0.0 \r\n1000000100.500 \t NaN \t 0.0 \r\n");
  EXPECT_NE(input_error("Robot1_Odometry.dat", 4).find("finite number for v, found 'NaN'"), std::string::npos);
  write("Robot1_Odometry.dat", "1000000100.000 \t 0.1 \t 0.0 \r\n1000000100.x \t 0.1 \t 0.0 \r\n");
  EXPECT_NE(input_error("Robot1_Odometry.dat", 4).find("for the time, found '1000000100.x'"), std::string::npos);
}

TEST_F(MrclamFiles, TimeGoingBackwardsIsRejected) {
  write("Robot1_Measurement.dat", "1000000100.400 \t 63 \t 2.1 \t 0.2 \r\n1000000100.300 \t 63 \t 2.0 \t 0.2 \r\n");
  EXPECT_NE(input_error("Robot1_Measurement.dat", 4).find("earlier than"), std::string::npos);
}

// Times near the ends of a long (9e18 s) used to overflow the difference of whole seconds.
TEST_F(MrclamFiles, TimesBeyondAnyClockAreRejected) {
  write("Robot1_Odometry.dat", "-9000000000000000000.5 \t 0.1 \t 0.0 \r\n9000000000000000000.5 \t 0.1 \t 0.0 \r\n");
  EXPECT_NE(input_error("Robot1_Odometry.dat", 3).find("expected a Unix time in seconds within +-1e+12"),
            std::string::npos);
  write("Robot1_Odometry.dat", "1000000100.000 \t 0.1 \t 0.0 \r\n1e300 \t 0.1 \t 0.0 \r\n");
  EXPECT_NE(input_error("Robot1_Odometry.dat", 4).find("found '1e300'"), std::string::npos);
}

TEST_F(MrclamFiles, MalformedBarcodesAndLandmarksAreRejected) {
  write("Barcodes.dat", "  1 \t 5 \r\n  2 \t 5 \r\n");
  EXPECT_NE(input_error("Barcodes.dat", 4).find("barcode 5 is given to two subjects"), std::string::npos);
  write("Barcodes.dat", "  1 \t 5 \r\n  6 \t 63 \r\n");
  write("Landmark_Groundtruth.dat", "  3 \t 1.0 \t 2.0 \t 0.0 \t 0.0 \r\n");
  EXPECT_NE(input_error("Landmark_Groundtruth.dat", 3).find("landmark subject number"), std::string::npos);
}

// A robot that measured no landmark within its run would be dead reckoning, reported like a SLAM
// result; an empty truth file where one is given is a broken copy, not a dataset without truth.
TEST_F(MrclamFiles, DataWithoutObservationsAndEmptyTruthFilesAreRefused) {
  write("Robot1_Measurement.dat",
        "1000000099.900 \t 63 \t 2.0 \t 0.1 \r\n"    // before the run
        "1000000100.201 \t 14 \t 3.0 \t 0.0 \r\n"    // a robot
        "1000000100.500 \t 43 \t 1.0 \t 0.0 \r\n");  // a false detection
  EXPECT_NE(input_error("Robot1_Measurement.dat", 0)
                .find("no landmark measurement within the run (of 3 rows: 1 of robots, 1 with unknown barcodes, 1 "
                      "outside the odometry's time span)"),
            std::string::npos);
  SetUp();
  write("Landmark_Groundtruth.dat", "");
  EXPECT_NE(input_error("Landmark_Groundtruth.dat", 0).find("no landmarks"), std::string::npos);
  SetUp();
  write_gz("Robot1_Groundtruth.dat.gz", "");
  EXPECT_NE(input_error("Robot1_Groundtruth.dat.gz", 0).find("no poses"), std::string::npos);
}

TEST_F(MrclamFiles, PositionsBeyondTheCoordinateBoundAreRefused) {
  write("Landmark_Groundtruth.dat", "  6 \t 1e300 \t 2.0 \t 0.0001 \t 0.0002 \r\n");
  EXPECT_NE(input_error("Landmark_Groundtruth.dat", 3).find("expected x within +-2e6 m, found 1e+300"),
            std::string::npos);
  SetUp();
  write_gz("Robot1_Groundtruth.dat.gz", "1000000100.000 \t 0.5 \t 3e6 \t -3.0 \r\n");
  EXPECT_NE(input_error("Robot1_Groundtruth.dat.gz", 3).find("expected y within +-2e6 m"), std::string::npos);
}

TEST_F(MrclamFiles, MissingFilesAreNamed) {
  fs::remove(path("Barcodes.dat"));
  EXPECT_NE(input_error("Barcodes.dat", 0).find("missing file"), std::string::npos);
  SetUp();
  fs::remove(path("Robot1_Measurement.dat"));
  input_error("Robot1_Measurement.dat", 0);
}

TEST_F(MrclamFiles, TruncatedGzipIsRejected) {
  const std::string gz = path("Robot1_Groundtruth.dat.gz");
  const auto size = fs::file_size(gz);
  fs::resize_file(gz, size - 12);  // cuts the trailer and the end of the data
  EXPECT_NE(input_error("Robot1_Groundtruth.dat.gz", 6).find("truncated file"), std::string::npos);
}

TEST_F(MrclamFiles, RobotNumberOutOfRangeIsRejected) {
  for (const int robot : {0, 6}) {
    try {
      read_mrclam(dir_.string(), robot);
      ADD_FAILURE() << "robot " << robot << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("robot number must be 1 to 5, found " + std::to_string(robot)),
                std::string::npos);
    }
  }
  EXPECT_THROW(read_mrclam(path("no_such_dir"), 1), InputError);
}

TEST(MrclamPaths, RobotPathNamesDirectoryAndRobot) {
  const MrclamRobot r = parse_mrclam_robot_path("/data/mrclam/MRCLAM_Dataset6/Robot3/");
  EXPECT_EQ(r.dataset_dir, "/data/mrclam/MRCLAM_Dataset6");
  EXPECT_EQ(r.robot, 3);
  EXPECT_EQ(parse_mrclam_robot_path("Robot5").dataset_dir, ".");
  for (const char* bad : {"/data/Robot6", "/data/Robot", "/data/Robot1x", "/data/robot1", "/data/Robot-1"})
    EXPECT_THROW(parse_mrclam_robot_path(bad), InputError) << bad;
}

TEST(MrclamOptions, JsonRoundTripAndErrors) {
  MrclamOptions o;
  o.motion.q_v = 3e-4;
  o.measurement.sigma_bearing = deg2rad(1.5);
  o.sensor.fov = deg2rad(60);
  const MrclamOptions back = mrclam_options_from_json(to_json(o), "test");
  EXPECT_EQ(back.motion.q_v, 3e-4);
  EXPECT_DOUBLE_EQ(back.measurement.sigma_bearing, deg2rad(1.5));
  EXPECT_EQ(to_json(o)["fov_deg"], 60.0);

  const auto message = [](const nlohmann::json& j) {
    try {
      mrclam_options_from_json(j, "opts.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({{"sigma_rnage_m", 0.1}}).find("opts.json: unknown key 'sigma_rnage_m'"), std::string::npos);
  EXPECT_NE(message({{"sigma_range_m", "0.1"}}).find("'sigma_range_m' must be a number"), std::string::npos);
  EXPECT_NE(message({{"sigma_range_m", 0.0}}).find("'sigma_range_m' must be > 0"), std::string::npos);
  EXPECT_NE(message({{"fov_deg", 400}}).find("'fov_deg' must be > 0 and <= 360"), std::string::npos);
  EXPECT_NE(message(nlohmann::json::array()).find("JSON object"), std::string::npos);
}
