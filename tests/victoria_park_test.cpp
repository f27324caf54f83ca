// The Victoria Park reader: on the real dataset (skipped when it is absent) the event counts, time
// order, GPS axes and a dead-reckoning check of the whole chain (controls, AcfrCarModel with the H/L
// correction, axes, initial heading); on small synthetic folders the merging of controls and scans
// and every kind of bad input; and the options' JSON.
#include "slamkit/io/victoria_park.hpp"
#include "slamkit/io/load_dataset.hpp"

#include <gtest/gtest.h>

#include "test_data.hpp"
#include <unistd.h>
#include <zlib.h>

#include <bit>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/text_reader.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

using slamkit::test_data::write_text;

using namespace slamkit;

namespace {

namespace fs = std::filesystem;

fs::path victoria_park_dir() { return slamkit::test_data::shared_dataset("victoria_park"); }

using test_data::ScratchDir;

void write_gzip(const std::string& path, const std::string& text) {
  gzFile f = gzopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(gzwrite(f, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
  ASSERT_EQ(gzclose(f), Z_OK);
}

// One laser line: time, then 361 ranges with no return except a 0.4 m trunk `distance` m straight
// ahead.
std::string laser_line(double t, double distance = 10.0) {
  std::ostringstream line;
  line << t;
  for (int k = 0; k < 361; ++k) {
    const double a = k * kPi / 360.0 - kPi / 2.0;  // from straight ahead
    const double along = distance * std::cos(a), disc = along * along - distance * distance + 0.04;
    line << '\t' << (disc >= 0.0 ? along - std::sqrt(disc) : 81.91);
  }
  return line.str() + "\n";
}

// A small ASCII release: 4 DR rows 25 ms apart, 2 GPS fixes, scans at 0.06 s (inside a DR
// interval) and 0.075 s (at a DR row's time). CRLF and tabs like the real files.
void write_small_release(const ScratchDir& dir) {
  write_text(dir.file("DRS.txt"),
             "0.025\t 1.000\t 0.0100\r\n0.050\t 1.000\t 0.0100\r\n0.075\t 2.000\t-0.0200\r\n0.100\t 2.000\t "
             "0.0000\r\n");
  write_text(dir.file("GPS.txt"), "0.000\t  0.00\t  0.00\r\n0.090\t  0.05\t -0.08\r\n");
  write_gzip(dir.file("LASER.txt.gz"), laser_line(0.06) + laser_line(0.075));
}

template <typename F>
std::string input_error(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an InputError";
  return {};
}

// The whole dataset, loaded once for the tests that only read it.
const Dataset& full_dataset() {
  static const Dataset data = read_victoria_park(victoria_park_dir().string());
  return data;
}

// GPS of the .mat release (east, north, relative to the first fix, on the ASCII clock), denser
// than the ASCII subset, which has no fix between 25 s and 148 s.
std::vector<StampedPose> mat_gps() {
  TextReader in((victoria_park_dir() / "acfr_mat" / "aa3_gpsx.txt").string());
  std::vector<StampedPose> fixes;
  Vector2 origin = Vector2::Zero();
  while (in.next()) {
    const double t = (in.number(0, "time") - 20967.0) / 1000.0;
    const Vector2 p(in.number(1, "east"), in.number(2, "north"));
    if (fixes.empty()) origin = p;
    fixes.push_back({t, Pose2(p.x() - origin.x(), p.y() - origin.y(), 0.0)});
  }
  return fixes;
}

// Integrates the dataset's controls with `model` from the initial position with `heading`, and
// gives the position RMS error against the fixes up to t_max, each compared with the pose at its
// own time (the control that spans it applied up to that time).
double dead_reckoning_rms(const Dataset& data, const MotionModel& model, double heading,
                          const std::vector<StampedPose>& fixes, double t_max) {
  Pose2 x(data.initial_pose.x(), data.initial_pose.y(), heading);
  std::size_t next = 0;
  double sum = 0.0;
  int n = 0;
  for (const Event& event : data.events) {
    const auto* c = std::get_if<ControlEvent>(&event);
    if (c == nullptr) continue;
    const double begin = c->t - c->dt;
    for (; next < fixes.size() && fixes[next].t <= c->t; ++next) {
      if (fixes[next].t < begin || fixes[next].t > t_max) continue;
      const Pose2 at = model.predict(x, c->u, fixes[next].t - begin);
      sum += (at.head<2>() - fixes[next].pose.head<2>()).squaredNorm();
      ++n;
    }
    if (c->t > t_max) break;
    x = model.predict(x, c->u, c->dt);
  }
  return std::sqrt(sum / n);
}

class VictoriaParkData : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(victoria_park_dir() / "acfr_ascii" / "LASER.txt.gz"))
      GTEST_SKIP() << "Victoria Park dataset not found at " << victoria_park_dir()
                   << " (set SLAMKIT_DATA to the folder holding victoria_park/)";
  }
};

}  // namespace

// ---- The real dataset -----------------------------------------------------------------------------

TEST_F(VictoriaParkData, LoadsEveryRowScanAndFixQuickly) {
  const auto start = std::chrono::steady_clock::now();
  const Dataset data = read_victoria_park(victoria_park_dir().string());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // Every DR row ends a control; the other controls end at a scan that cut a DR interval.
  std::set<double> dr_times;
  TextReader dr((victoria_park_dir() / "acfr_ascii" / "DRS.txt").string());
  while (dr.next()) dr_times.insert(dr.number(0, "time"));
  std::set<double> scan_times;
  std::size_t scans = 0, range_scans = 0, controls = 0, controls_at_dr = 0, observations = 0;
  for (const Event& e : data.events) {
    if (const auto* s = std::get_if<ScanEvent>(&e)) {
      ++scans;
      scan_times.insert(s->t);
      observations += s->observations.size();
    }
    range_scans += std::holds_alternative<RangeScanEvent>(e) ? 1 : 0;
  }
  for (const Event& e : data.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      ++controls;
      if (dr_times.contains(c->t))
        ++controls_at_dr;
      else
        EXPECT_TRUE(scan_times.contains(c->t)) << "a control ending at " << c->t;
    }
  }
  EXPECT_EQ(dr_times.size(), 61763U);
  EXPECT_EQ(controls_at_dr, 61763U);
  EXPECT_EQ(scans, 7230U);
  EXPECT_EQ(range_scans, 7230U);
  EXPECT_EQ(data.truth.poses.size(), 948U);
  EXPECT_GT(observations, 20000U);
  std::cout << "[ victoria park ] loaded in " << seconds << " s: " << controls << " controls ("
            << controls_at_dr << " DR rows), " << scans << " scans, " << observations
            << " trees within 30 m, " << data.truth.poses.size() << " GPS fixes\n";
  RecordProperty("load_seconds", std::to_string(seconds));

  // The acfr_ascii folder itself names the same data.
  EXPECT_EQ(read_victoria_park((victoria_park_dir() / "acfr_ascii").string()).events.size(),
            data.events.size());
}

TEST_F(VictoriaParkData, EventsAreInTimeOrderAndControlsTileTheRun) {
  const Dataset& data = full_dataset();
  double t = 0.0, control_end = 0.0;
  for (const Event& e : data.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      EXPECT_NEAR(c->t - c->dt, control_end, 1e-9) << "the control ending at " << c->t;
      EXPECT_GE(c->dt, 0.0);
      // DR rows are 25 ms apart; the first row, at 0.973 s, ends a longer interval from the start.
      if (c->t > 0.973) {
        EXPECT_LE(c->dt, 0.025 + 1e-9);
      }
      EXPECT_EQ(c->u.size(), 2);
      control_end = c->t;
      EXPECT_GE(c->t, t);
      t = c->t;
    } else if (const auto* ranges = std::get_if<RangeScanEvent>(&e)) {
      EXPECT_EQ(ranges->t, t) << "raw ranges follow the trees of their scan";
    } else {
      const auto& s = std::get<ScanEvent>(e);
      EXPECT_GE(s.t, t);
      t = s.t;
      for (const Observation& o : s.observations) {
        EXPECT_LE(o.z[0], 30.0);
        EXPECT_GT(o.z[0], 1.0);
        EXPECT_LE(std::abs(o.z[1]), kPi / 2.0);
        EXPECT_EQ(o.id, kUnknownId);
      }
    }
  }
  // The first control starts at the first GPS fix, where the initial pose is, and is cut by the
  // first scan, at 0.852 s.
  const auto& first = std::get<ControlEvent>(data.events[0]);
  EXPECT_DOUBLE_EQ(first.t - first.dt, 0.0);
  EXPECT_DOUBLE_EQ(first.t, 0.852);
  EXPECT_DOUBLE_EQ(std::get<ScanEvent>(data.events[1]).t, 0.852);
}

TEST_F(VictoriaParkData, GpsIsTruthWithEastAsXAndNorthAsY) {
  const Dataset& data = full_dataset();
  const std::vector<StampedPose>& gps = data.truth.poses;
  ASSERT_EQ(gps.size(), 948U);
  EXPECT_FALSE(data.truth.poses_have_heading);
  EXPECT_DOUBLE_EQ(gps.front().t, 0.0);
  EXPECT_EQ(gps.front().pose, Pose2::Zero());
  // GPS.txt: "1.001  0.05  -0.08" (north, east) and last "1545.022  -11.32  -18.53".
  EXPECT_DOUBLE_EQ(gps[1].t, 1.001);
  EXPECT_DOUBLE_EQ(gps[1].pose.x(), -0.08);
  EXPECT_DOUBLE_EQ(gps[1].pose.y(), 0.05);
  EXPECT_DOUBLE_EQ(gps.back().t, 1545.022);
  EXPECT_DOUBLE_EQ(gps.back().pose.x(), -18.53);
  EXPECT_DOUBLE_EQ(gps.back().pose.y(), -11.32);
}

TEST_F(VictoriaParkData, PlatformIsTheLaserPoseWithTheAcfrCar) {
  const Dataset& data = full_dataset();
  EXPECT_EQ(data.motion->name(), "acfr-car");
  EXPECT_EQ(data.observation->name(), "range-bearing");
  const Pose2 x(1, 2, 0.3);
  // No sensor offset: the state is the laser.
  EXPECT_LT((data.observation->invert(x, Vector2(5.0, 0.0))->position -
             Vector2(1 + 5 * std::cos(0.3), 2 + 5 * std::sin(0.3)))
                .norm(),
            1e-12);
  EXPECT_DOUBLE_EQ(data.sensor.max_range, 30.0);
  EXPECT_DOUBLE_EQ(data.sensor.fov, kPi);
  EXPECT_TRUE(data.initial_pose.isApprox(Pose2(0, 0, deg2rad(36.0))));
}

// The controls integrated with the model from the first fix follow GPS for the first 79 s (100 s on
// the logger clock) within a few metres, and only with the H/L correction: this checks the model,
// the correction, the axes and the control timing together.
TEST_F(VictoriaParkData, DeadReckoningFollowsGpsAtTheStart) {
  if (!fs::exists(victoria_park_dir() / "acfr_mat" / "aa3_gpsx.txt"))
    GTEST_SKIP() << "the .mat release's GPS is not at " << victoria_park_dir() / "acfr_mat";
  const Dataset& data = full_dataset();
  const std::vector<StampedPose> gps = mat_gps();
  const double t_max = (100000.0 - 20967.0) / 1000.0;
  const auto best_over_headings = [&](const MotionModel& model) {
    double best = std::numeric_limits<double>::infinity(), heading = 0.0;
    for (double deg = 30.0; deg <= 46.0; deg += 0.2) {
      const double rms = dead_reckoning_rms(data, model, deg2rad(deg), gps, t_max);
      if (rms < best) {
        best = rms;
        heading = deg;
      }
    }
    return std::pair{best, heading};
  };
  const auto [rms, heading] = best_over_headings(*data.motion);
  const double rms_default = dead_reckoning_rms(data, *data.motion, data.initial_pose.z(), gps, t_max);
  AcfrCarModel::Params uncorrected;
  uncorrected.encoder_offset = 0.0;
  const auto [rms_uncorrected, heading_uncorrected] = best_over_headings(AcfrCarModel(uncorrected));
  std::cout << "[ dead reckoning to t = " << t_max << " s ] RMS " << rms << " m at the best heading "
            << heading << " deg, " << rms_default << " m at the default heading, " << rms_uncorrected
            << " m without the H/L correction (best heading " << heading_uncorrected << " deg)\n";
  EXPECT_LT(rms, 4.0);
  EXPECT_LT(rms_default, 4.0);
  EXPECT_GT(rms_uncorrected, 10.0);
  // Over the first 25 s the ASCII GPS is dense too, and the car drives nearly straight.
  EXPECT_LT(dead_reckoning_rms(data, *data.motion, data.initial_pose.z(), data.truth.poses, 25.0), 1.5);
}

TEST_F(VictoriaParkData, TimeWindowKeepsOnlyItsEventsAndFixes) {
  VictoriaParkOptions options;
  options.start_time = 150.0;
  options.end_time = 200.0;
  const Dataset data = read_victoria_park(victoria_park_dir().string(), options);
  ASSERT_FALSE(data.events.empty());
  ASSERT_FALSE(data.truth.poses.empty());
  for (const Event& e : data.events) {
    const double t = event_time(e);
    EXPECT_GE(t, 150.0);
    EXPECT_LE(t, 200.0);
  }
  for (const StampedPose& p : data.truth.poses) {
    EXPECT_GE(p.t, 150.0);
    EXPECT_LE(p.t, 200.0);
  }
  const auto& first = std::get<ControlEvent>(data.events.front());
  EXPECT_DOUBLE_EQ(first.t - first.dt, 150.0);
}

// ---- Small synthetic releases ---------------------------------------------------------------------

TEST(VictoriaParkReader, MergesControlsAndScansAndCutsControlsAtScans) {
  ScratchDir dir;
  write_small_release(dir);
  const Dataset data = read_victoria_park(dir.path().string());
  // control 0.025 (from 0), control 0.05, control 0.06 (cut), scan 0.06 (trees, then ranges),
  // control 0.075, scan 0.075 (trees, then ranges), control 0.1.
  ASSERT_EQ(data.events.size(), 9U);
  const double control_ends[] = {0.025, 0.05, 0.06, 0.075, 0.1};
  const double dts[] = {0.025, 0.025, 0.01, 0.015, 0.025};
  const double speeds[] = {1.0, 1.0, 2.0, 2.0, 2.0};
  const std::size_t control_at[] = {0, 1, 2, 5, 8};
  for (int i = 0; i < 5; ++i) {
    const auto& c = std::get<ControlEvent>(data.events[control_at[i]]);
    EXPECT_DOUBLE_EQ(c.t, control_ends[i]);
    EXPECT_NEAR(c.dt, dts[i], 1e-12);
    EXPECT_DOUBLE_EQ(c.u[0], speeds[i]);
  }
  // The cut control carries the values of the row that ends its interval.
  EXPECT_DOUBLE_EQ(std::get<ControlEvent>(data.events[2]).u[1], -0.02);
  for (const std::size_t i : {3U, 6U}) {
    const auto& scan = std::get<ScanEvent>(data.events[i]);
    ASSERT_EQ(scan.observations.size(), 1U);
    EXPECT_NEAR(scan.observations[0].z[0], 10.0, 0.1);
    EXPECT_NEAR(scan.observations[0].z[1], 0.0, 1e-9);
    // The same line as raw ranges: 361 beams across the half-plane ahead, 0.5 degrees apart.
    const auto& ranges = std::get<RangeScanEvent>(data.events[i + 1]);
    EXPECT_DOUBLE_EQ(ranges.t, scan.t);
    ASSERT_EQ(ranges.ranges.size(), 361U);
    EXPECT_DOUBLE_EQ(ranges.bearing(0), -kPi / 2.0);
    EXPECT_NEAR(ranges.bearing(360), kPi / 2.0, 1e-12);
    EXPECT_EQ(ranges.max_range, 75.0);
  }
  ASSERT_EQ(data.truth.poses.size(), 2U);
  EXPECT_DOUBLE_EQ(data.truth.poses[1].pose.x(), -0.08);
  EXPECT_DOUBLE_EQ(data.truth.poses[1].pose.y(), 0.05);
}

TEST(VictoriaParkReader, MaxRangeDropsFartherTrees) {
  ScratchDir dir;
  write_small_release(dir);
  write_gzip(dir.file("LASER.txt.gz"), laser_line(0.06) + laser_line(0.075, 8.0));
  VictoriaParkOptions options;
  options.max_range = 9.0;
  const Dataset data = read_victoria_park(dir.path().string(), options);
  EXPECT_TRUE(std::get<ScanEvent>(data.events[3]).observations.empty());
  ASSERT_EQ(std::get<ScanEvent>(data.events[6]).observations.size(), 1U);
  EXPECT_NEAR(std::get<ScanEvent>(data.events[6]).observations[0].z[0], 8.0, 0.1);
  EXPECT_DOUBLE_EQ(data.sensor.max_range, 9.0);
}

// An empty file, or scans without a single tree, used to run as dead reckoning with exit code 0,
// reported like a SLAM result.
TEST(VictoriaParkReader, RefusesEmptyFilesAndDataWithoutObservations) {
  for (const char* name : {"DRS.txt", "GPS.txt", "LASER.txt.gz"}) {
    ScratchDir dir;
    write_small_release(dir);
    write_text(dir.file(name), "");
    const std::string message = test_data::input_error_at([&] { read_victoria_park(dir.path().string()); },
                                                          dir.file(name), 0);
    EXPECT_NE(message.find(": no "), std::string::npos) << message;
  }
  {  // a gzip stream of nothing but a comment
    ScratchDir dir;
    write_small_release(dir);
    write_gzip(dir.file("LASER.txt.gz"), "# no scans\n");
    const std::string message = test_data::input_error_at([&] { read_victoria_park(dir.path().string()); },
                                                          dir.file("LASER.txt.gz"), 0);
    EXPECT_NE(message.find("no laser scans"), std::string::npos) << message;
  }
  ScratchDir dir;
  write_small_release(dir);
  VictoriaParkOptions options;
  options.max_range = 9.0;  // beyond the only trunk's 10 m
  std::string message = test_data::input_error_at([&] { read_victoria_park(dir.path().string(), options); },
                                                  dir.file("LASER.txt.gz"), 0);
  EXPECT_NE(message.find("no tree within max_range_m (9 m) in any of its 2 scans"), std::string::npos) << message;
  options.max_range = 30.0;
  options.end_time = 0.05;  // before the first scan
  message = test_data::input_error_at([&] { read_victoria_park(dir.path().string(), options); },
                                      dir.file("LASER.txt.gz"), 0);
  EXPECT_NE(message.find("and end_time_s (0.05 s)"), std::string::npos) << message;
}

TEST(VictoriaParkReader, MissingFolderOrFileNamesIt) {
  ScratchDir dir;
  EXPECT_NE(input_error([&] { read_victoria_park(dir.file("nowhere")); }).find("nowhere"), std::string::npos);
  EXPECT_NE(input_error([&] { read_victoria_park(dir.path().string()); }).find("acfr_ascii"),
            std::string::npos);
  write_small_release(dir);
  fs::remove(dir.file("GPS.txt"));
  const std::string message = input_error([&] { read_victoria_park(dir.path().string()); });
  EXPECT_NE(message.find("GPS.txt: missing file"), std::string::npos) << message;
}

TEST(VictoriaParkReader, MalformedLinesNameFileLineAndWhatWasExpected) {
  {
    ScratchDir dir;
    write_small_release(dir);
    write_text(dir.file("DRS.txt"), "0.025\t1.0\t0.01\r\n0.050\t1.0\r\n");
    const std::string message = input_error([&] { read_victoria_park(dir.path().string()); });
    EXPECT_NE(message.find("DRS.txt:2: expected 3 fields"), std::string::npos) << message;
  }
  {
    ScratchDir dir;
    write_small_release(dir);
    write_text(dir.file("GPS.txt"), "0.000\tnan\t0.00\r\n");
    const std::string message = input_error([&] { read_victoria_park(dir.path().string()); });
    EXPECT_NE(message.find("GPS.txt:1: expected a finite number"), std::string::npos) << message;
  }
  {
    ScratchDir dir;
    write_small_release(dir);
    write_text(dir.file("DRS.txt"), "0.050\t1.0\t0.01\r\n0.025\t1.0\t0.01\r\n");
    const std::string message = input_error([&] { read_victoria_park(dir.path().string()); });
    EXPECT_NE(message.find("DRS.txt:2: expected the time to increase"), std::string::npos) << message;
  }
  {
    ScratchDir dir;
    write_small_release(dir);
    std::string line = laser_line(0.06);
    line.erase(line.rfind('\t'));  // 361 numbers
    write_gzip(dir.file("LASER.txt.gz"), laser_line(0.05) + line + "\n");
    const std::string message = input_error([&] { read_victoria_park(dir.path().string()); });
    EXPECT_NE(message.find("LASER.txt.gz:2: expected 362 fields"), std::string::npos) << message;
  }
  {
    ScratchDir dir;
    write_small_release(dir);
    std::string line = laser_line(0.06);
    line.replace(line.find('\t'), 1, "\t-1.0\t").erase(line.rfind('\t'));
    write_gzip(dir.file("LASER.txt.gz"), line + "\n");
    const std::string message = input_error([&] { read_victoria_park(dir.path().string()); });
    EXPECT_NE(message.find("LASER.txt.gz:1: expected a range >= 0 m"), std::string::npos) << message;
  }
}

TEST(VictoriaParkReader, TruncatedLaserFileIsAnError) {
  ScratchDir dir;
  write_small_release(dir);
  std::string text;
  for (int i = 0; i < 40; ++i) text += laser_line(0.06 + 0.2 * i);
  write_gzip(dir.file("full.gz"), text);
  const auto size = fs::file_size(dir.file("full.gz"));
  fs::copy_file(dir.file("full.gz"), dir.file("LASER.txt.gz"), fs::copy_options::overwrite_existing);
  fs::resize_file(dir.file("LASER.txt.gz"), size / 2);
  const std::string message = input_error([&] { read_victoria_park(dir.path().string()); });
  EXPECT_NE(message.find("LASER.txt.gz:"), std::string::npos) << message;
  EXPECT_NE(message.find("truncated"), std::string::npos) << message;
  // Only the trailer missing (the checksum and length): still an error, not a quiet success.
  fs::copy_file(dir.file("full.gz"), dir.file("LASER.txt.gz"), fs::copy_options::overwrite_existing);
  fs::resize_file(dir.file("LASER.txt.gz"), size - 4);
  EXPECT_NE(input_error([&] { read_victoria_park(dir.path().string()); }).find("LASER.txt.gz:"),
            std::string::npos);
}

// ---- TextReader -------------------------------------------------------------------------------

TEST(TextReader, ReadsGzipAndPlainFilesAndLongLines) {
  ScratchDir dir;
  std::string long_line;
  for (int i = 0; i < 5000; ++i) long_line += std::to_string(i) + "\t";
  const std::string text = "# a comment\r\n\r\n1.5\t 2,3  # trailing\r\n" + long_line + "\n4 5";
  write_gzip(dir.file("a.gz"), text);
  write_text(dir.file("a.txt"), text);
  for (const char* name : {"a.gz", "a.txt"}) {  // plain text is read as it is
    TextReader in(dir.file(name));
    ASSERT_TRUE(in.next());
    EXPECT_EQ(in.line_number(), 3U);
    ASSERT_EQ(in.size(), 3U);
    EXPECT_EQ(in.field(2), "3");
    EXPECT_DOUBLE_EQ(in.number(0, "x"), 1.5);
    ASSERT_TRUE(in.next());
    ASSERT_EQ(in.size(), 5000U);
    EXPECT_EQ(in.field(4999), "4999");
    ASSERT_TRUE(in.next());  // the last line has no newline
    EXPECT_EQ(in.line_number(), 5U);
    EXPECT_EQ(in.field(1), "5");
    EXPECT_FALSE(in.next());
  }
}

TEST(TextReader, GzipErrorsNameFileAndLine) {
  ScratchDir dir;
  EXPECT_NE(input_error([&] { TextReader in(dir.file("missing.gz")); }).find("missing.gz: cannot open"),
            std::string::npos);
  write_gzip(dir.file("b.gz"), "1 2\n3 x\n");
  TextReader in(dir.file("b.gz"));
  ASSERT_TRUE(in.next());
  ASSERT_TRUE(in.next());
  const std::string message = input_error([&] { in.number(1, "the speed"); });
  EXPECT_NE(message.find("b.gz:2: expected a finite number for the speed, found 'x'"), std::string::npos)
      << message;
  EXPECT_NE(input_error([&] { in.expect_fields(3, "three things"); }).find("b.gz:2: expected 3 fields"),
            std::string::npos);
}

// The reader fills a fixed-size block buffer: lines that straddle two blocks, and a line longer than
// the buffer itself, must come out whole and numbered right.
TEST(TextReader, LinesAcrossAndBeyondTheReadBuffer) {
  ScratchDir dir;
  std::string text;
  std::vector<std::string> lines;
  for (int i = 0; i < 20000; ++i) lines.push_back(std::to_string(i) + " " + std::to_string(i * 7) + ".25");
  lines.insert(lines.begin() + 12345, std::string(300000, '9'));
  for (const std::string& line : lines) text += line + "\n";
  write_gzip(dir.file("c.gz"), text);
  TextReader in(dir.file("c.gz"));
  for (std::size_t k = 0; k < lines.size(); ++k) {
    ASSERT_TRUE(in.next()) << "line " << k + 1;
    ASSERT_EQ(in.line_number(), k + 1);
    if (k == 12345) {
      ASSERT_EQ(in.size(), 1U);
      EXPECT_EQ(in.field(0).size(), 300000U);
      continue;
    }
    const int i = static_cast<int>(k < 12345 ? k : k - 1);
    ASSERT_EQ(in.size(), 2U) << "line " << k + 1;
    EXPECT_EQ(in.integer(0, "i"), i);
    EXPECT_EQ(in.number(1, "x"), i * 7 + 0.25);
  }
  EXPECT_FALSE(in.next());
}

// A line had no cap: 100 MB of one line cost 1.2 GB before its error, longer ones ended in
// std::bad_alloc. The cap is found before more than twice it is held, plain or compressed, and a
// line of exactly the cap is still read.
TEST(TextReader, RefusesALineLongerThanTheCap) {
  ScratchDir dir;
  const std::string text = "1 2\n" + std::string(8 * kMaxLineBytes, '7') + "\n3 4\n";
  write_gzip(dir.file("long.gz"), text);
  write_text(dir.file("long.txt"), text);
  write_gzip(dir.file("unended.gz"), "1 2\n" + std::string(kMaxLineBytes + 1, '7'));
  for (const char* name : {"long.gz", "long.txt", "unended.gz"}) {
    TextReader in(dir.file(name));
    ASSERT_TRUE(in.next());
    const std::string message = test_data::input_error_at([&] { in.next(); }, dir.file(name), 2);
    EXPECT_NE(message.find("line longer than 1048576 bytes"), std::string::npos) << message;
  }
  write_gzip(dir.file("cap.gz"), std::string(kMaxLineBytes, '7') + "\n8\n");
  TextReader in(dir.file("cap.gz"));
  ASSERT_TRUE(in.next());
  EXPECT_EQ(in.field(0).size(), kMaxLineBytes);
  ASSERT_TRUE(in.next());
  EXPECT_EQ(in.field(0), "8");
}

// parse_double's fast path for plain decimals must give exactly the double std::from_chars gives,
// and leave every other form (exponents, long mantissas, odd shapes) to it.
TEST(ParseDouble, EqualsFromCharsBitForBit) {
  const auto reference = [](std::string_view s, double& out) {
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
  };
  std::vector<std::string> inputs = {"0",   "-0",   "0.0",  "-0.000", "1.",   ".5",    "-.5",  "1e3",  "1.5E-7",
                                     "+2.5", "nan",  "inf",  "-inf",   "",     "-",     ".",    "1.2.3", "12a",
                                     "1 ",  "0x10", "--1",  "81.91",  "0.83", "999999999999999.", "1e400",
                                     "123456789012345", "1234567890123456", "0.1234567890123456789"};
  std::mt19937_64 rng(7);
  for (int n = 0; n < 200000; ++n) {
    const int digits = 1 + static_cast<int>(rng() % 18);
    std::string s = rng() % 2 ? "-" : "";
    const int point = static_cast<int>(rng() % (digits + 1));
    for (int d = 0; d < digits; ++d) {
      if (d == point && d > 0) s += '.';
      s += static_cast<char>('0' + rng() % 10);
    }
    inputs.push_back(s);
  }
  for (const std::string& s : inputs) {
    double expected = 0.0, got = 0.0;
    const bool expected_ok = reference(s, expected);
    ASSERT_EQ(parse_double(s, got), expected_ok) << "'" << s << "'";
    if (expected_ok) ASSERT_EQ(std::bit_cast<std::uint64_t>(got), std::bit_cast<std::uint64_t>(expected)) << s;
  }
}

// ---- Options --------------------------------------------------------------------------------------

TEST(VictoriaParkOptions, ReadsJsonInDegreesAndNamesUnknownKeys) {
  const VictoriaParkOptions o = victoria_park_options_from_json(
      nlohmann::json::parse(R"({"max_range_m": 25, "sigma_bearing_deg": 2, "initial_heading_deg": 38,
                                "end_time_s": 300, "tree_detector": {"occlusion_angle_deg": 1.5,
                                "clutter_lookahead": 2}, "car": {"encoder_offset_m": 0}})"),
      "opts.json");
  EXPECT_DOUBLE_EQ(o.max_range, 25.0);
  EXPECT_DOUBLE_EQ(o.sigma_bearing, deg2rad(2.0));
  EXPECT_DOUBLE_EQ(o.initial_heading, deg2rad(38.0));
  EXPECT_DOUBLE_EQ(o.end_time, 300.0);
  EXPECT_DOUBLE_EQ(o.detector.occlusion_angle, deg2rad(1.5));
  EXPECT_EQ(o.detector.clutter_lookahead, 2);
  EXPECT_DOUBLE_EQ(o.car.encoder_offset, 0.0);
  EXPECT_DOUBLE_EQ(o.car.wheelbase, 2.83);  // untouched keys keep their defaults

  const auto error = [](const char* json) {
    return input_error([&] { victoria_park_options_from_json(nlohmann::json::parse(json), "opts.json"); });
  };
  EXPECT_NE(error(R"({"max_rnage_m": 25})").find("opts.json: unknown key 'max_rnage_m'"), std::string::npos);
  EXPECT_NE(error(R"({"tree_detector": {"width": 1}})").find("unknown key 'width' in 'tree_detector'"),
            std::string::npos);
  EXPECT_NE(error(R"({"car": {"sigma_speed_mps": 1}})").find("unknown key 'sigma_speed_mps' in 'car'"),
            std::string::npos);
  EXPECT_NE(error(R"({"sigma_range_m": "1"})").find("'sigma_range_m' must be a number"), std::string::npos);
  EXPECT_NE(error(R"({"sigma_range_m": -1})").find("'sigma_range_m' must be >= 0"), std::string::npos);
  EXPECT_NE(error(R"({"start_time_s": 10, "end_time_s": 5})").find("'end_time_s'"), std::string::npos);
  EXPECT_NE(error(R"({"tree_detector": {"clutter_lookahead": 1.5}})")
                .find("'clutter_lookahead' must be an integer"),
            std::string::npos);
  EXPECT_NE(error(R"([1, 2])").find("expected the Victoria Park options as a JSON object"),
            std::string::npos);
}

// The shipped file holds the reader's defaults and, for the filters, the built-in recommendation
// that a run without --data-config gets.
TEST(VictoriaParkOptions, ShippedConfigHoldsTheDefaults) {
  const fs::path path = fs::path(SLAMKIT_SOURCE_DIR) / "config" / "victoria-park.json";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  nlohmann::json shipped = nlohmann::json::parse(in);
  EXPECT_EQ(recommended_settings("victoria-park:x", shipped, path.string()),
            recommended_settings("victoria-park:x", nullptr, ""));
  shipped.erase("recommended");
  const VictoriaParkOptions o = victoria_park_options_from_json(shipped, path.string());
  const VictoriaParkOptions d;
  const auto near = [](double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(b)); };
  for (const auto& [a, b] : {std::pair{o.max_range, d.max_range},
                             {o.sigma_range, d.sigma_range},
                             {o.sigma_bearing, d.sigma_bearing},
                             {o.initial_heading, d.initial_heading},
                             {o.start_time, d.start_time},
                             {o.car.wheelbase, d.car.wheelbase},
                             {o.car.encoder_offset, d.car.encoder_offset},
                             {o.car.laser_forward, d.car.laser_forward},
                             {o.car.laser_left, d.car.laser_left},
                             {o.car.sigma_speed, d.car.sigma_speed},
                             {o.car.sigma_steer, d.car.sigma_steer},
                             {o.detector.max_beam_range, d.detector.max_beam_range},
                             {o.detector.segment_range_jump, d.detector.segment_range_jump},
                             {o.detector.segment_angle_gap, d.detector.segment_angle_gap},
                             {o.detector.clutter_distance, d.detector.clutter_distance},
                             {o.detector.occlusion_angle, d.detector.occlusion_angle},
                             {o.detector.max_extent, d.detector.max_extent},
                             {o.detector.min_range, d.detector.min_range},
                             {o.detector.edge_margin, d.detector.edge_margin},
                             {o.detector.max_depth_ratio, d.detector.max_depth_ratio}})
    EXPECT_TRUE(near(a, b)) << a << " vs " << b;
  EXPECT_EQ(o.detector.clutter_lookahead, d.detector.clutter_lookahead);
  EXPECT_TRUE(std::isinf(o.end_time));
}
