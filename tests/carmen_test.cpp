// The CARMEN reader and writer: known answers on small logs written here (geometry, sensor offset,
// times, controls), ROBOTLASER1, gzip, the reference beside a log, the clock rules, every rejected
// input with its file and line, the write/read round trip, the made odometry's determinism and noise
// statistics, the settings; and the Radish corrected logs when the shared datasets are present.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <variant>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/eval/metrics.hpp"
#include "slamkit/io/carmen.hpp"
#include "test_data.hpp"

using namespace slamkit;
namespace fs = std::filesystem;

namespace {

/// A FLASER line: ranges, laser pose, robot pose, time.
std::string carmen_flaser(const std::vector<double>& ranges, const Pose2& laser, const Pose2& robot,
                          const std::string& t) {
  std::string line = "FLASER " + std::to_string(ranges.size());
  for (const double r : ranges) line += fmt::format(" {}", r);
  return line + fmt::format(" {} {} {} {} {} {} {} pippo {}\n", laser.x(), laser.y(), laser.z(), robot.x(),
                            robot.y(), robot.z(), t, t);
}

/// A log of FLASER lines at the given robot poses and times (laser at the robot), 4 ranges each.
std::string carmen_path_log(const std::vector<Pose2>& poses, const std::vector<std::string>& times) {
  std::string log = "# message formats defined: PARAM ODOM FLASER\n";
  for (std::size_t k = 0; k < poses.size(); ++k)
    log += carmen_flaser({1.0, 2.0, 3.0, 4.0}, poses[k], poses[k], times[k]);
  return log;
}

void carmen_write_gz(const std::string& path, const std::string& text) {
  gzFile f = gzopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(gzwrite(f, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
  ASSERT_EQ(gzclose(f), Z_OK);
}

std::vector<const ControlEvent*> carmen_controls(const Dataset& d) {
  std::vector<const ControlEvent*> out;
  for (const Event& e : d.events)
    if (const auto* c = std::get_if<ControlEvent>(&e)) out.push_back(c);
  return out;
}

std::vector<const RangeScanEvent*> carmen_scans(const Dataset& d) {
  std::vector<const RangeScanEvent*> out;
  for (const Event& e : d.events)
    if (const auto* s = std::get_if<RangeScanEvent>(&e)) out.push_back(s);
  return out;
}

void carmen_expect_same_events(const Dataset& a, const Dataset& b, double tol) {
  ASSERT_EQ(a.events.size(), b.events.size());
  for (std::size_t i = 0; i < a.events.size(); ++i) {
    ASSERT_EQ(a.events[i].index(), b.events[i].index()) << i;
    EXPECT_NEAR(event_time(a.events[i]), event_time(b.events[i]), tol) << i;
    if (const auto* c = std::get_if<ControlEvent>(&a.events[i])) {
      const auto& d = std::get<ControlEvent>(b.events[i]);
      EXPECT_NEAR(c->dt, d.dt, tol) << i;
      ASSERT_EQ(c->u.size(), d.u.size());
      EXPECT_LE((c->u - d.u).cwiseAbs().maxCoeff(), tol) << i << ": " << c->u.transpose() << " vs " << d.u.transpose();
    } else {
      const auto& s = std::get<RangeScanEvent>(a.events[i]);
      const auto& r = std::get<RangeScanEvent>(b.events[i]);
      EXPECT_LE((s.sensor_offset - r.sensor_offset).cwiseAbs().maxCoeff(), tol) << i;
      EXPECT_NEAR(s.angle_min, r.angle_min, tol) << i;
      EXPECT_NEAR(s.angle_increment, r.angle_increment, tol) << i;
      EXPECT_NEAR(s.max_range, r.max_range, tol) << i;
      ASSERT_EQ(s.ranges.size(), r.ranges.size());
      for (std::size_t k = 0; k < s.ranges.size(); ++k) EXPECT_NEAR(s.ranges[k], r.ranges[k], tol) << i << " " << k;
    }
  }
}

/// Dead reckoning of a dataset at its scans, and the position RMSE after SE(2) alignment onto its truth.
double carmen_dead_reckoning_ate(const Dataset& d) {
  const OdometryModel model;
  Pose2 pose = d.initial_pose;
  std::vector<Vector2> estimate, truth;
  for (const Event& e : d.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      pose = model.predict(pose, c->u, c->dt);
    } else {
      estimate.push_back(pose.head<2>());
      truth.push_back(d.truth.poses.at(estimate.size() - 1).pose.head<2>());
    }
  }
  const eval::Se2Transform align = eval::align_se2(estimate, truth);
  double sum = 0.0;
  for (std::size_t i = 0; i < estimate.size(); ++i) sum += (align.apply(estimate[i]) - truth[i]).squaredNorm();
  return std::sqrt(sum / static_cast<double>(estimate.size()));
}

}  // namespace

// ---- Known answers ----------------------------------------------------------------------------------------

TEST(CarmenReader, TwoFlaserLinesGiveTwoControlsAndTwoScans) {
  test_data::ScratchDir dir;
  const std::string path = dir.file("two.log");
  // The laser 0.2 m ahead of a robot facing +y; 85 m and 79.998 m are no returns (max range 80).
  test_data::write_text(path, "# two scans\nPARAM robot_frontlaser_offset 0.2 nohost 0\n" +
                                  carmen_flaser({1.0, 2.5, 85.0, 79.998}, Pose2(1, 2.2, kPi / 2), Pose2(1, 2, kPi / 2),
                                                "10.25") +
                                  "NEFF 30\nODOM 1 2 1.5707963 0 0 0 10.3 pippo 10.3\n" +
                                  carmen_flaser({3.0, 0.0, 1.0, 2.0}, Pose2(1, 3.2, kPi / 2), Pose2(1, 3, kPi / 2),
                                                "12.75"));
  CarmenStats stats;
  const Dataset d = read_carmen(path, {}, &stats);
  EXPECT_EQ(d.spec, "carmen:" + path);
  EXPECT_EQ(d.name, "carmen:two");
  ASSERT_EQ(d.events.size(), 4u);
  const auto controls = carmen_controls(d);
  const auto scans = carmen_scans(d);
  ASSERT_EQ(controls.size(), 2u);
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_TRUE(std::holds_alternative<ControlEvent>(d.events[0]));
  EXPECT_TRUE(std::holds_alternative<RangeScanEvent>(d.events[1]));
  // The first control is from the initial pose, the first laser line's own: no motion.
  EXPECT_DOUBLE_EQ(controls[0]->t, 10.25);
  EXPECT_DOUBLE_EQ(controls[0]->dt, 0.0);
  EXPECT_LT(controls[0]->u.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_DOUBLE_EQ(controls[1]->t, 12.75);
  EXPECT_DOUBLE_EQ(controls[1]->dt, 2.5);
  EXPECT_NEAR(controls[1]->u[0], 0.0, 1e-12);
  EXPECT_NEAR(controls[1]->u[1], 1.0, 1e-12);
  EXPECT_NEAR(controls[1]->u[2], 0.0, 1e-12);
  EXPECT_TRUE(d.initial_pose.isApprox(Pose2(1, 2, kPi / 2)));
  EXPECT_DOUBLE_EQ(scans[0]->t, 10.25);
  EXPECT_DOUBLE_EQ(scans[1]->t, 12.75);
  // Four beams (an even count): 45 degrees apart from the robot's right, the last short of its left.
  EXPECT_DOUBLE_EQ(scans[0]->angle_min, -kPi / 2);
  EXPECT_DOUBLE_EQ(scans[0]->angle_increment, kPi / 4);
  EXPECT_DOUBLE_EQ(scans[0]->bearing(3), kPi / 4);
  EXPECT_LT((scans[0]->sensor_offset - Pose2(0.2, 0, 0)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_DOUBLE_EQ(scans[0]->max_range, 80.0);
  EXPECT_EQ(scans[0]->ranges, (std::vector<float>{1.0F, 2.5F, 85.0F, 80.0F}));
  EXPECT_EQ(scans[1]->ranges, (std::vector<float>{3.0F, 0.0F, 1.0F, 2.0F}));
  EXPECT_EQ(stats.laser_lines, 2u);
  EXPECT_EQ(stats.scans, 2u);
  EXPECT_EQ(stats.odom_lines, 1u);
  EXPECT_EQ(stats.skipped_lines, 1u);  // NEFF
  EXPECT_EQ(stats.no_returns, 2u);
  EXPECT_EQ(stats.out_of_order, 0u);
  EXPECT_FALSE(stats.times_from_scan_order);
  EXPECT_TRUE(d.truth.poses.empty());
  EXPECT_EQ(d.observation, nullptr);
  ASSERT_NE(d.motion, nullptr);
  EXPECT_EQ(d.motion->name(), "odometry");
  EXPECT_EQ(d.time_origin_s, 0);
}

TEST(CarmenReader, OddBeamCountsEndOnBothSidesAndTheFovParamIsHonoured) {
  test_data::ScratchDir dir;
  const std::string path = dir.file("fov.log");
  const std::string five = carmen_flaser({1, 1, 1, 1, 1}, Pose2::Zero(), Pose2::Zero(), "1");
  test_data::write_text(path, five + "PARAM laser_front_laser_fov 100 1 host 1\n" + five +
                                  "PARAM laser_front_laser_fov 1.5 1 host 1\n" + five);
  const Dataset d = read_carmen(path);
  const auto scans = carmen_scans(d);  // ties: numbered, all kept
  ASSERT_EQ(scans.size(), 3u);
  EXPECT_DOUBLE_EQ(scans[0]->angle_min, -kPi / 2);
  EXPECT_DOUBLE_EQ(scans[0]->bearing(4), kPi / 2);
  EXPECT_DOUBLE_EQ(scans[1]->angle_min, -deg2rad(50));  // degrees, as CARMEN's ini files write it
  EXPECT_DOUBLE_EQ(scans[1]->bearing(4), deg2rad(50));
  EXPECT_DOUBLE_EQ(scans[2]->angle_increment, 0.375);  // radians
}

TEST(CarmenReader, RobotLaserStatesItsGeometryAndWinsOverFlaser) {
  test_data::ScratchDir dir;
  const std::string path = dir.file("robot.log");
  // Robot at (2, 1) facing 90 deg; laser 0.3 m ahead and 0.1 m left of it, turned by 0.2 rad.
  const std::string robotlaser =
      "ROBOTLASER1 0 -1.0 2.0 0.5 20.0 0.01 0 5 1 2 3 19.999 25 2 0.4 0.6 "
      "1.9 1.3 1.7707963267948966 2 1 1.5707963267948966 0.1 0 0.5 0.3 0 100.5 host 100.6\n";
  test_data::write_text(path, carmen_flaser({1, 1, 1, 1}, Pose2::Zero(), Pose2::Zero(), "100.5") + robotlaser);
  CarmenStats stats;
  const Dataset d = read_carmen(path, {}, &stats);
  const auto scans = carmen_scans(d);
  ASSERT_EQ(scans.size(), 1u);
  const RangeScanEvent& s = *scans[0];
  EXPECT_DOUBLE_EQ(s.angle_min, -1.0);
  EXPECT_DOUBLE_EQ(s.angle_increment, 0.5);
  EXPECT_DOUBLE_EQ(s.max_range, 20.0);
  EXPECT_EQ(s.ranges, (std::vector<float>{1, 2, 3, 20, 25}));
  EXPECT_LT((s.sensor_offset - Pose2(0.3, 0.1, 0.2)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_TRUE(d.initial_pose.isApprox(Pose2(2, 1, kPi / 2)));
  EXPECT_EQ(stats.laser_lines, 1u);
  EXPECT_EQ(stats.skipped_lines, 1u);  // the FLASER line
  EXPECT_EQ(stats.no_returns, 2u);
}

TEST(CarmenReader, ReadsGzipAsPlain) {
  test_data::ScratchDir dir;
  const std::string text = carmen_path_log({Pose2(0, 0, 0), Pose2(1, 0, 0.5)}, {"1.0", "2.0"});
  test_data::write_text(dir.file("a.log"), text);
  carmen_write_gz(dir.file("b.log.gz"), text);
  const Dataset plain = read_carmen(dir.file("a.log"));
  const Dataset gz = read_carmen(dir.file("b.log.gz"));
  EXPECT_EQ(gz.name, "carmen:b");
  carmen_expect_same_events(plain, gz, 0.0);
}

TEST(CarmenReader, ReferenceBesideTheLogIsTheTruth) {
  test_data::ScratchDir dir;
  const std::vector<std::string> times = {"1.0", "2.0", "3.0"};
  test_data::write_text(dir.file("run.log"), carmen_path_log({Pose2(0, 0, 0), Pose2(1, 0, 0), Pose2(2, 0, 0)}, times));
  carmen_write_gz(dir.file("run.reference.log.gz"),
                  carmen_path_log({Pose2(0, 0, 0), Pose2(1.1, 0.1, 0.05), Pose2(2.2, 0.3, 0.1)}, times));
  CarmenStats stats;
  Dataset d = read_carmen(dir.file("run.log"), {}, &stats);
  EXPECT_EQ(stats.reference_path, dir.file("run.reference.log.gz"));
  ASSERT_EQ(d.truth.poses.size(), 3u);
  EXPECT_DOUBLE_EQ(d.truth.poses[2].t, 3.0);
  EXPECT_TRUE(d.truth.poses[2].pose.isApprox(Pose2(2.2, 0.3, 0.1)));
  EXPECT_NEAR(carmen_controls(d)[2]->u[1], 1.0, 1e-12) << "the odometry stays the log's";

  // A reference of ODOM lines only, plain, taken before the .gz one.
  test_data::write_text(dir.file("run.reference.log"), "ODOM 5 5 0 0 0 0 1.5 h 1.5\nODOM 6 5 0 0 0 0 2.5 h 2.5\n");
  d = read_carmen(dir.file("run.log"), {}, &stats);
  ASSERT_EQ(d.truth.poses.size(), 2u);
  EXPECT_DOUBLE_EQ(d.truth.poses[1].t, 2.5);
  EXPECT_EQ(stats.reference_path, dir.file("run.reference.log"));

  // With the log's own poses as the reference, the file beside it is not read.
  CarmenOptions reference;
  reference.poses_are_reference = true;
  d = read_carmen(dir.file("run.log"), reference, &stats);
  EXPECT_TRUE(stats.reference_path.empty());
  ASSERT_EQ(d.truth.poses.size(), 3u);
  EXPECT_TRUE(d.truth.poses[1].pose.isApprox(Pose2(1, 0, 0)));
}

// ---- Clock ------------------------------------------------------------------------------------------------

TEST(CarmenClock, UnixTimesStartAtZeroWithTheExactOrigin) {
  test_data::ScratchDir dir;
  test_data::write_text(dir.file("unix.log"), carmen_path_log({Pose2(0, 0, 0), Pose2(1, 0, 0)},
                                                                {"1134863807.658747", "1134863809.158748"}));
  const Dataset d = read_carmen(dir.file("unix.log"));
  EXPECT_EQ(d.time_origin_s, 1134863807);
  EXPECT_DOUBLE_EQ(d.time_origin_fraction_s, 0.658747);
  const auto scans = carmen_scans(d);
  EXPECT_EQ(scans[0]->t, 0.0);
  EXPECT_NEAR(scans[1]->t, 1.500001, 1e-12);
}

TEST(CarmenClock, EarlierLaserLinesAreDroppedAndCounted) {
  test_data::ScratchDir dir;
  const std::string path = dir.file("back.log");
  test_data::write_text(path, carmen_path_log({Pose2(0, 0, 0), Pose2(1, 0, 0), Pose2(9, 9, 0), Pose2(2, 0, 0)},
                                              {"10", "12", "11", "13"}));
  CarmenStats stats;
  const Dataset d = read_carmen(path, {}, &stats);
  EXPECT_EQ(stats.out_of_order, 1u);
  EXPECT_EQ(stats.laser_lines, 4u);
  EXPECT_EQ(stats.scans, 3u);
  const auto scans = carmen_scans(d);
  ASSERT_EQ(scans.size(), 3u);
  EXPECT_EQ(scans[2]->t, 13.0);
  const auto controls = carmen_controls(d);
  EXPECT_NEAR(controls[2]->u[1], 1.0, 1e-12) << "from the last kept line's pose, not the dropped one's";
  EXPECT_EQ(controls[2]->dt, 1.0);
}

TEST(CarmenClock, TiedTimesNumberTheScans) {
  test_data::ScratchDir dir;
  const std::string path = dir.file("tied.log");
  // CSAIL's clock: six significant digits, so most scans share a time.
  const std::vector<Pose2> poses = {Pose2(0, 0, 0), Pose2(1, 0, 0), Pose2(2, 0, 0)};
  test_data::write_text(path, carmen_path_log(poses, {"1.13486e+09", "1.13486e+09", "1.13487e+09"}));
  test_data::write_text(dir.file("tied.reference.log"), carmen_path_log(poses, {"0", "0", "0"}));
  CarmenStats stats;
  const Dataset d = read_carmen(path, {}, &stats);
  EXPECT_TRUE(stats.times_from_scan_order);
  EXPECT_EQ(d.time_origin_s, 0);
  const auto scans = carmen_scans(d);
  ASSERT_EQ(scans.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(scans[k]->t, static_cast<double>(k));
  ASSERT_EQ(d.truth.poses.size(), 3u);
  EXPECT_EQ(d.truth.poses[2].t, 2.0);
  // A numbered log's reference must pair with it line for line.
  test_data::write_text(dir.file("tied.reference.log"), carmen_path_log({poses[0], poses[1]}, {"0", "0"}));
  const std::string message =
      test_data::input_error_at([&] { read_carmen(path); }, dir.file("tied.reference.log"), 0);
  EXPECT_NE(message.find("expected 3"), std::string::npos) << message;
}

// ---- Bad input ----------------------------------------------------------------------------------------------

namespace {

/// Reads a log whose third line is `bad`, after a comment and a good line; returns the error's message.
std::string carmen_error_on_line_3(const std::string& bad) {
  test_data::ScratchDir dir;
  const std::string path = dir.file("bad.log");
  test_data::write_text(path, "# header\n" + carmen_flaser({1, 2}, Pose2::Zero(), Pose2::Zero(), "1") + bad + "\n");
  return test_data::input_error_at([&] { read_carmen(path); }, path, 3);
}

}  // namespace

TEST(CarmenErrors, TruncatedLine) {
  const std::string m = carmen_error_on_line_3("FLASER 2 1 2 0 0 0 0 0 0 5");
  EXPECT_NE(m.find("expected 13 fields"), std::string::npos) << m;
  EXPECT_NE(m.find("found 11"), std::string::npos) << m;
  EXPECT_NE(carmen_error_on_line_3("ODOM 1 2 0 0 0").find("expected 10 fields"), std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("ROBOTLASER1 0 -1 2 0.5 20 0 0 2 1 2").find("expected at least"), std::string::npos);
}

TEST(CarmenErrors, NanOrInfiniteRange) {
  EXPECT_NE(carmen_error_on_line_3("FLASER 2 1 nan 0 0 0 0 0 0 5 pippo 5").find("finite number for a range"),
            std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("FLASER 2 inf 1 0 0 0 0 0 0 5 pippo 5").find("found 'inf'"), std::string::npos);
}

TEST(CarmenErrors, RangeCountThatDoesNotMatch) {
  const std::string m = carmen_error_on_line_3("FLASER 3 1 2 0 0 0 0 0 0 5 pippo 5");
  EXPECT_NE(m.find("FLASER with 3 ranges"), std::string::npos) << m;
  EXPECT_NE(carmen_error_on_line_3("FLASER 99 1 2 0 0 0 0 0 0 5 pippo 5").find("the range count from 1"),
            std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("FLASER 0 0 0 0 0 0 0 5 pippo 5").find("the range count"), std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("FLASER 2.5 1 2 0 0 0 0 0 0 5 pippo 5").find("an integer"), std::string::npos);
}

TEST(CarmenErrors, NegativeRange) {
  const std::string m = carmen_error_on_line_3("FLASER 2 1 -0.5 0 0 0 0 0 0 5 pippo 5");
  EXPECT_NE(m.find("range 2 of 2 from 0"), std::string::npos) << m;
}

TEST(CarmenErrors, OtherFieldsAndLogs) {
  EXPECT_NE(carmen_error_on_line_3("FLASER 2 1 2 0 0 0 0 0 0 x pippo 5").find("the timestamp"), std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("FLASER 2 1 2 1e9 0 0 0 0 0 5 pippo 5").find("the laser x"), std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("FLASER 2 1 2 0 0 0 0 0 0 5 pippo x").find("the logger timestamp"),
            std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("FLASER 2 1 2 0 0 0 0 0 0 1e13 pippo 5").find("within"), std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("PARAM laser_front_laser_fov 400").find("laser_front_laser_fov"),
            std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("ROBOTLASER1 0 -1 2 0.5 0 0 0 2 1 2 0 0 0 0 0 0 0 0 0 0 0 0 5 h 5")
                .find("max range"),
            std::string::npos);
  EXPECT_NE(carmen_error_on_line_3("ROBOTLASER1 0 -1 2 4 20 0 0 3 1 2 3 0 0 0 0 0 0 0 0 0 0 0 0 5 h 5")
                .find("span at most 2 pi"),
            std::string::npos);

  test_data::ScratchDir dir;
  const std::string none = dir.file("none.log");
  test_data::write_text(none, "# nothing\nODOM 0 0 0 0 0 0 1 h 1\nNEFF 3\n");
  const std::string m = test_data::input_error_at([&] { read_carmen(none); }, none, 0);
  EXPECT_NE(m.find("no laser lines (of 1 ODOM and 1 other lines)"), std::string::npos) << m;
  test_data::input_error_at([&] { read_carmen(dir.file("missing.log")); }, dir.file("missing.log"), 0);
}

TEST(CarmenErrors, UnknownKindsAreCountedNotRefused) {
  test_data::ScratchDir dir;
  const std::string path = dir.file("kinds.log");
  test_data::write_text(path, "RLASER 1 2 3\nTRUEPOS 1 2\n0.5 0.7\n" +
                                  carmen_flaser({1, 2}, Pose2::Zero(), Pose2::Zero(), "1"));
  CarmenStats stats;
  read_carmen(path, {}, &stats);
  EXPECT_EQ(stats.skipped_lines, 3u);
}

// ---- Writing ------------------------------------------------------------------------------------------------

TEST(CarmenWriter, RoundTripGivesTheEventsAndTruthBack) {
  test_data::ScratchDir dir;
  std::vector<Pose2> poses;
  std::vector<std::string> times;
  for (int k = 0; k < 40; ++k) {
    poses.emplace_back(0.5 * k, std::sin(0.3 * k), wrap_angle(0.2 * k));
    times.push_back(fmt::format("{}", 0.7 * k + 3.0));
  }
  test_data::write_text(dir.file("in.log"), carmen_path_log(poses, times));
  CarmenOptions reference;
  reference.poses_are_reference = true;
  const Dataset d = read_carmen(dir.file("in.log"), reference);
  ASSERT_EQ(d.truth.poses.size(), 40u);

  write_carmen(dir.file("out.log"), d);
  ASSERT_TRUE(fs::exists(dir.file("out.reference.log")));
  CarmenStats stats;
  const Dataset back = read_carmen(dir.file("out.log"), {}, &stats);
  EXPECT_EQ(stats.reference_path, dir.file("out.reference.log"));
  carmen_expect_same_events(d, back, 1e-6);
  EXPECT_LT((d.initial_pose - back.initial_pose).cwiseAbs().maxCoeff(), 1e-9);
  ASSERT_EQ(back.truth.poses.size(), d.truth.poses.size());
  for (std::size_t k = 0; k < d.truth.poses.size(); ++k) {
    EXPECT_NEAR(back.truth.poses[k].t, d.truth.poses[k].t, 1e-6);
    EXPECT_LT((back.truth.poses[k].pose - d.truth.poses[k].pose).cwiseAbs().maxCoeff(), 1e-6);
  }

  // Without truth the stale reference goes, so none is read back.
  Dataset no_truth = d;
  no_truth.truth.poses.clear();
  write_carmen(dir.file("out.log"), no_truth);
  EXPECT_FALSE(fs::exists(dir.file("out.reference.log")));
  EXPECT_TRUE(read_carmen(dir.file("out.log")).truth.poses.empty());
}

TEST(CarmenWriter, RoundTripKeepsScanGeometryAndUnixTimes) {
  Dataset d;
  d.name = "built";
  d.initial_pose = Pose2(3, -2, 0.4);
  d.time_origin_s = 1134863807;
  d.time_origin_fraction_s = 0.658747;
  for (int k = 0; k < 5; ++k) {
    const double t = 0.25 * k;
    Control u = Control::Zero(3);
    if (k > 0) u << 0.1 * k, 0.3 + 0.1 * k, -0.05 * k;
    d.events.emplace_back(ControlEvent{t, k == 0 ? 0.0 : 0.25, u});
    RangeScanEvent s;
    s.t = t;
    s.sensor_offset = Pose2(0.12, -0.05, 0.02);
    s.angle_min = -2.0;
    s.angle_increment = 4.0 / 299;
    s.max_range = 30.0;
    for (int b = 0; b < 300; ++b) s.ranges.push_back(b % 7 == 0 ? 30.0F : 0.5F + 0.013F * static_cast<float>(b));
    d.events.emplace_back(std::move(s));
  }
  test_data::ScratchDir dir;
  write_carmen(dir.file("built.log"), d);
  const Dataset back = read_carmen(dir.file("built.log"));
  carmen_expect_same_events(d, back, 1e-6);
  EXPECT_EQ(back.time_origin_s, d.time_origin_s);
  EXPECT_NEAR(back.time_origin_fraction_s, d.time_origin_fraction_s, 1e-12);
  EXPECT_NE(test_data::read_text(dir.file("built.log")).find("# CARMEN log of built, written by slamkit"),
            std::string::npos);
}

TEST(CarmenWriter, RefusesWhatALogCannotHold) {
  test_data::ScratchDir dir;
  Dataset landmarks;
  landmarks.events.emplace_back(ScanEvent{0.0, {}});
  EXPECT_THROW(write_carmen(dir.file("x.log"), landmarks), std::invalid_argument);
  Dataset velocity;
  velocity.events.emplace_back(ControlEvent{0.0, 0.0, Control::Zero(2)});
  EXPECT_THROW(write_carmen(dir.file("x.log"), velocity), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir.file("x.log")));
}

// ---- Made odometry ------------------------------------------------------------------------------------------

TEST(CarmenMadeOdometry, SameSeedSameOdometryOtherSeedOther) {
  std::vector<Pose2> reference;
  for (int k = 0; k < 100; ++k) reference.emplace_back(0.5 * k, 0.1 * k, wrap_angle(0.05 * k));
  MadeOdometry noise;
  const std::vector<Pose2> a = make_odometry(reference, noise);
  const std::vector<Pose2> b = make_odometry(reference, noise);
  noise.seed = 2;
  const std::vector<Pose2> c = make_odometry(reference, noise);
  ASSERT_EQ(a.size(), reference.size());
  EXPECT_EQ(a, b);
  EXPECT_EQ(a.front(), reference.front());
  EXPECT_GT((a.back() - c.back()).head<2>().norm(), 1e-3);
  EXPECT_GT((a.back() - reference.back()).head<2>().norm(), 1e-3);
}

TEST(CarmenMadeOdometry, IncrementErrorsFollowTheStatedModel) {
  // Increments of every size, turning both ways, chained into a long reference trajectory.
  constexpr int kSteps = 20000;
  std::vector<Pose2> reference = {Pose2(1, 2, 0.3)};
  const OdometryModel model;
  for (int k = 0; k < kSteps; ++k) {
    Control u(3);
    u << 0.6 * std::sin(0.37 * k), 0.2 + 0.4 * (1 + std::sin(0.11 * k)), 0.4 * std::cos(0.23 * k);
    reference.push_back(model.predict(reference.back(), u, 0.0));
  }
  MadeOdometry noise{11, 0.05, 0.02, 0.01, 0.03, 0.02, 0.005};
  const std::vector<Pose2> made = make_odometry(reference, noise);

  // Each increment's error in units of its stated standard deviation: independent standard normals.
  std::vector<Eigen::Vector3d> z;
  for (int k = 1; k <= kSteps; ++k) {
    const Control truth = OdometryModel::between(reference[k - 1], reference[k]);
    const Control odometry = OdometryModel::between(made[k - 1], made[k]);
    const double r1 = truth[0], tr = truth[1], r2 = truth[2];
    const auto rot_sd = [&](double r) { return std::hypot(0.03 * r, 0.02 * tr, 0.005); };
    const double trans_sd = std::sqrt(std::pow(0.05 * tr, 2) + 0.0004 * (r1 * r1 + r2 * r2) + 0.0001);
    z.emplace_back(wrap_angle(odometry[0] - r1) / rot_sd(r1), (odometry[1] - tr) / trans_sd,
                   wrap_angle(odometry[2] - r2) / rot_sd(r2));
    // The filter's alphas state the same variances.
    const ControlCovariance m = OdometryModel(odometry_params(noise)).control_noise(truth, 0.0);
    ASSERT_NEAR(m(1, 1), trans_sd * trans_sd, 1e-12);
  }
  // With n = 20000 the mean's standard error is 0.0071, the variance's 0.010, a correlation's 0.0071
  // and the share beyond 2 sd's 0.0015; each bound is over 4 of them, and a standard deviation 5% off
  // moves the variance by 0.1.
  const double n = kSteps;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& v : z) mean += v / n;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  Eigen::Vector3d beyond_two = Eigen::Vector3d::Zero();
  for (const auto& v : z) {
    covariance += (v - mean) * (v - mean).transpose() / n;
    beyond_two += (v.array().abs() > 2.0).cast<double>().matrix() / n;
  }
  for (int j = 0; j < 3; ++j) {
    EXPECT_LT(std::abs(mean[j]), 0.03) << j;
    EXPECT_NEAR(covariance(j, j), 1.0, 0.045) << j;
    EXPECT_NEAR(beyond_two[j], 0.0455, 0.0065) << j;
    for (int i = 0; i < j; ++i) EXPECT_LT(std::abs(covariance(i, j)), 0.03) << i << j;
  }
}

TEST(CarmenMadeOdometry, OdometryParamsStateTheNoise) {
  const OdometryModel::Params p = odometry_params(MadeOdometry{1, 0.05, 0.01, 0.0, 0.005, 0.005, 0.0});
  EXPECT_DOUBLE_EQ(p.alpha_rot_rot, 2.5e-5);
  EXPECT_DOUBLE_EQ(p.alpha_rot_trans, 2.5e-5);
  EXPECT_DOUBLE_EQ(p.alpha_trans_trans, 0.0025);
  EXPECT_DOUBLE_EQ(p.alpha_trans_rot, 1e-4);
  EXPECT_EQ(p.min_variance, OdometryModel::Params{}.min_variance);
  EXPECT_DOUBLE_EQ(odometry_params(MadeOdometry{1, 0, 0, 0.02, 0, 0, 0.01}).min_variance, 4e-4);
}

// ---- Settings -------------------------------------------------------------------------------------------------

TEST(CarmenSettings, JsonRoundTripAndErrors) {
  CarmenOptions o;
  o.poses_are_reference = true;
  o.made_odometry.seed = 7;
  o.made_odometry.rotation_constant = 0.001;
  o.motion.alpha_trans_rot = 0.02;
  o.max_range = 50.0;
  const CarmenOptions back = carmen_options_from_json(to_json(o), "s.json");
  EXPECT_EQ(to_json(back), to_json(o));
  EXPECT_EQ(back.made_odometry.seed, 7u);
  EXPECT_TRUE(back.poses_are_reference);

  const auto error = [](const nlohmann::json& j) {
    try {
      carmen_options_from_json(j, "s.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error({{"max_range", 5}}).find("did you mean"), std::string::npos);
  EXPECT_NE(error({{"max_range_m", -1}}).find("'max_range_m' must be > 0"), std::string::npos);
  EXPECT_NE(error({{"made_odometry", {{"seed", -1}}}}).find("'seed'"), std::string::npos);
  EXPECT_NE(error({{"motion", {{"alpha_rot_rot", "x"}}}}).find("a number"), std::string::npos);
  EXPECT_NE(error({{"poses_are_reference", 1}}).find("true or false"), std::string::npos);
}

TEST(CarmenSettings, RadishConfigStatesItsMadeNoiseToTheFilter) {
  const std::string path = std::string(SLAMKIT_SOURCE_DIR) + "/config/radish.json";
  const CarmenOptions o = carmen_options_from_json(test_data::read_json(path), path);
  EXPECT_TRUE(o.poses_are_reference);
  const OdometryModel::Params stated = odometry_params(o.made_odometry);
  EXPECT_DOUBLE_EQ(o.motion.alpha_rot_rot, stated.alpha_rot_rot);
  EXPECT_DOUBLE_EQ(o.motion.alpha_rot_trans, stated.alpha_rot_trans);
  EXPECT_DOUBLE_EQ(o.motion.alpha_trans_trans, stated.alpha_trans_trans);
  EXPECT_DOUBLE_EQ(o.motion.alpha_trans_rot, stated.alpha_trans_rot);
  EXPECT_DOUBLE_EQ(o.motion.min_variance, stated.min_variance);
  EXPECT_EQ(to_json(o)["made_odometry"], to_json(CarmenOptions{})["made_odometry"]) << "the defaults are Radish's";
}

// ---- The Radish logs ------------------------------------------------------------------------------------------

TEST(CarmenData, IntelCorrected) {
  const fs::path file = test_data::shared_dataset("radish_corrected") / "intel-corrected.log.gz";
  SLAMKIT_REQUIRE_DATASET(file);
  CarmenOptions options;
  options.poses_are_reference = true;
  CarmenStats stats;
  const Dataset d = read_carmen(file.string(), options, &stats);
  EXPECT_EQ(stats.laser_lines, 910u);
  EXPECT_EQ(stats.odom_lines, 14541u);
  EXPECT_EQ(stats.skipped_lines, 910u);  // NEFF
  EXPECT_EQ(stats.out_of_order, 4u);     // lines 5647, 10805, 11190 and 12936, 0.05-0.86 s back
  EXPECT_EQ(stats.scans, 906u);
  EXPECT_FALSE(stats.times_from_scan_order);
  EXPECT_EQ(stats.no_returns, 4168u);  // readings of 81.83 m
  const auto scans = carmen_scans(d);
  ASSERT_EQ(scans.size(), 906u);
  for (const RangeScanEvent* s : scans) {
    ASSERT_EQ(s->ranges.size(), 180u);
    ASSERT_DOUBLE_EQ(s->angle_increment, kPi / 180);
    ASSERT_DOUBLE_EQ(s->angle_min, -kPi / 2);
    ASSERT_EQ(s->sensor_offset, Pose2::Zero());
  }
  EXPECT_DOUBLE_EQ(scans.front()->t, 32.9068);
  EXPECT_DOUBLE_EQ(scans.back()->t, 2683.77);
  ASSERT_EQ(d.truth.poses.size(), 906u);
  EXPECT_TRUE(d.initial_pose.isApprox(Pose2(0.600266, -0.0320327, -0.354665)));
  EXPECT_EQ(d.initial_pose, d.truth.poses.front().pose);
  // The made odometry's dead reckoning with the defaults, seed 1 (the header's table).
  EXPECT_NEAR(carmen_dead_reckoning_ate(d), 2.59, 0.005);
}

TEST(CarmenData, AcesAndCsailWithTheRadishSettings) {
  const fs::path folder = test_data::shared_dataset("radish_corrected");
  SLAMKIT_REQUIRE_DATASET(folder / "aces-corrected.log.gz");
  const std::string config = std::string(SLAMKIT_SOURCE_DIR) + "/config/radish.json";
  const CarmenOptions options = carmen_options_from_json(test_data::read_json(config), config);
  CarmenStats stats;
  const Dataset aces = read_carmen((folder / "aces-corrected.log.gz").string(), options, &stats);
  EXPECT_EQ(stats.scans, 440u);
  EXPECT_EQ(stats.no_returns, 620u);  // readings of 50.00 m
  EXPECT_NEAR(carmen_dead_reckoning_ate(aces), 2.32, 0.005);

  const Dataset csail = read_carmen((folder / "csail-corrected.log.gz").string(), options, &stats);
  EXPECT_TRUE(stats.times_from_scan_order);  // 1.13486e+09 on 365 lines
  EXPECT_EQ(stats.scans, 406u);
  EXPECT_EQ(stats.no_returns, 3907u);  // readings of 81.91 m
  const auto scans = carmen_scans(csail);
  ASSERT_EQ(scans.front()->ranges.size(), 361u);
  // Its PARAM laser_front_laser_fov, 3.14159, is pi to six digits.
  EXPECT_DOUBLE_EQ(scans.front()->angle_increment, 3.14159 / 360);
  EXPECT_NEAR(scans.front()->bearing(360), kPi / 2, 2e-6);
  EXPECT_EQ(scans.back()->t, 405.0);
  EXPECT_NEAR(carmen_dead_reckoning_ate(csail), 1.39, 0.005);
}
