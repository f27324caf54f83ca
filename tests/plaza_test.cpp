// The Plaza reader: on small synthetic folders written as GTSAM writes the files, the exact events
// (controls, merge order, scans, ids, truth) and every way the input can be rejected; on the real
// Plaza1 (skipped when the data is absent), the counts of the data set's README and the range bias
// against the ground truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iostream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/io/plaza.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "test_data.hpp"

using namespace slamkit;
namespace fs = std::filesystem;

namespace {

double median(std::vector<double> values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// The stream's invariants: time never decreases, each control starts where the previous one ended
/// and has the odometry model's three entries, and every observation is one positive range to a
/// beacon of the truth.
void expect_well_formed(const Dataset& d) {
  std::set<int> beacons;
  for (const Landmark& l : d.truth.landmarks) beacons.insert(l.id);
  double now = 0.0, last_control = 0.0;
  for (const Event& e : d.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      ASSERT_GT(c->dt, 0.0);
      ASSERT_NEAR(c->t - c->dt, last_control, 1e-9);
      ASSERT_EQ(c->u.size(), 3);
      ASSERT_GE(c->t, now);
      now = last_control = c->t;
    } else {
      const auto& s = std::get<ScanEvent>(e);
      ASSERT_GE(s.t, now);
      now = s.t;
      ASSERT_FALSE(s.observations.empty());
      for (const Observation& o : s.observations) {
        ASSERT_TRUE(beacons.count(o.id)) << o.id;
        ASSERT_EQ(o.z.size(), 1);
        ASSERT_GT(o.z[0], 0.0);
        ASSERT_LE(o.z[0], d.sensor.max_range);
      }
    }
  }
}

}  // namespace

// ---- The real data ------------------------------------------------------------------------------------

TEST(PlazaData, Plaza1MatchesTheReadmeAndItsRangesCarryTheBias) {
  const fs::path dir = test_data::shared_dataset("plaza_range_only");
  SLAMKIT_REQUIRE_DATASET(dir);
  PlazaStats stats;
  const Dataset d = read_plaza(dir.string(), "Plaza1", PlazaOptions{}, stats);
  EXPECT_EQ(d.name, "plaza:Plaza1");
  EXPECT_EQ(d.motion->name(), "odometry");
  EXPECT_EQ(d.observation->name(), "range-only");
  // From the data set's README: rows per file, 4 beacons, 1,933 s.
  EXPECT_EQ(stats.odometry_rows, 9657u);
  EXPECT_EQ(stats.range_rows, 3529u);
  EXPECT_EQ(stats.beacons, 4u);
  EXPECT_NEAR(stats.duration, 1933.0, 1.0);
  EXPECT_EQ(d.time_origin_s, 3856);  // the first ground-truth row, 3856.857346 s
  EXPECT_NEAR(d.time_origin_fraction_s, 0.857346, 1e-6);
  // Found here: the ranges jump back in time twice (lines 1989 and 2867), all lie within the run, and
  // three times carry two ranges each.
  EXPECT_EQ(stats.reordered_range_rows, 2u);
  EXPECT_EQ(stats.outside_run, 0u);
  EXPECT_EQ(stats.observations, 3529u);
  EXPECT_EQ(stats.scans, 3526u);

  ASSERT_EQ(d.truth.landmarks.size(), 4u);
  std::map<int, Vector2> beacons;
  for (const Landmark& l : d.truth.landmarks) beacons[l.id] = l.position;
  EXPECT_EQ(beacons.begin()->first, 0);
  EXPECT_EQ(beacons.count(1) + beacons.count(5) + beacons.count(6), 3u);
  expect_well_formed(d);

  std::size_t controls = 0, scans = 0;
  for (const Event& e : d.events) (std::holds_alternative<ControlEvent>(e) ? controls : scans) += 1;
  EXPECT_EQ(controls, stats.odometry_rows);
  EXPECT_EQ(scans, stats.scans);
  EXPECT_EQ(d.truth.observation_ids.size(), scans);

  // The truth: one row before the first odometry row and one per row after it, starting the run.
  ASSERT_EQ(d.truth.poses.size(), 9658u);
  EXPECT_EQ(stats.truth_poses, 9658u);
  EXPECT_EQ(d.truth.poses.front().t, 0.0);
  EXPECT_EQ(d.initial_pose, d.truth.poses.front().pose);
  EXPECT_NEAR(d.initial_pose[2], wrap_angle(4.222432), 1e-9);  // README: heading 4.22 rad at (0, 0)

  // Each range minus the true distance from the truth pose nearest in time: the README's +2.8 m bias,
  // spread as the default sigma_range says.
  std::vector<double> residuals;
  for (const Event& e : d.events) {
    const auto* s = std::get_if<ScanEvent>(&e);
    if (s == nullptr) continue;
    const auto after = std::lower_bound(d.truth.poses.begin(), d.truth.poses.end(), s->t,
                                        [](const StampedPose& p, double t) { return p.t < t; });
    auto nearest = after == d.truth.poses.end() ? std::prev(after) : after;
    if (after != d.truth.poses.begin() && s->t - std::prev(after)->t < after->t - s->t) nearest = std::prev(after);
    for (const Observation& o : s->observations)
      residuals.push_back(o.z[0] - (beacons.at(o.id) - nearest->pose.head<2>()).norm());
  }
  ASSERT_EQ(residuals.size(), 3529u);
  const double bias = median(residuals);
  std::vector<double> deviations;
  for (const double r : residuals) deviations.push_back(std::abs(r - bias));
  const double spread = 1.4826 * median(deviations);
  EXPECT_NEAR(bias, 2.8, 0.1);
  EXPECT_NEAR(spread, PlazaOptions{}.measurement.sigma_range, 0.1);

  // The midpoint controls describe the motion: dead reckoning from the true start ends a few metres
  // from the truth after 1.9 km.
  Pose2 pose = d.initial_pose;
  for (const Event& e : d.events)
    if (const auto* c = std::get_if<ControlEvent>(&e)) pose = d.motion->predict(pose, c->u, c->dt);
  const double drift = (pose.head<2>() - d.truth.poses.back().pose.head<2>()).norm();
  EXPECT_LT(drift, 10.0);
  std::cout << "Plaza1: " << stats.duration << " s, " << stats.odometry_rows << " odometry rows, " << stats.range_rows
            << " ranges (" << stats.reordered_range_rows << " out of time order) in " << stats.scans
            << " scans; range minus true distance: median " << bias << " m, robust spread " << spread
            << " m; dead reckoning ends " << drift << " m from the truth\n";
}

TEST(PlazaOptions, ShippedConfigHoldsTheDefaults) {
  const std::string path = std::string(SLAMKIT_SOURCE_DIR) + "/config/plaza.json";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  EXPECT_EQ(to_json(plaza_options_from_json(nlohmann::json::parse(in), path)), to_json(PlazaOptions{}));
}

TEST(PlazaOptions, JsonRoundTripAndErrors) {
  PlazaOptions o;
  o.motion.alpha_trans_trans = 0.02;
  o.measurement.sigma_range = 0.8;
  o.sensor.fov = deg2rad(90);
  const PlazaOptions back = plaza_options_from_json(to_json(o), "test");
  EXPECT_EQ(back.motion.alpha_trans_trans, 0.02);
  EXPECT_EQ(back.measurement.sigma_range, 0.8);
  EXPECT_DOUBLE_EQ(back.sensor.fov, deg2rad(90));
  EXPECT_EQ(to_json(o)["fov_deg"], 90.0);

  const auto message = [](const nlohmann::json& j) {
    try {
      plaza_options_from_json(j, "opts.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({{"sigma_bearing_deg", 1.0}}).find("opts.json: unknown key 'sigma_bearing_deg'"),
            std::string::npos);
  EXPECT_NE(message({{"sigma_range_m", "1.2"}}).find("'sigma_range_m' must be a number"), std::string::npos);
  EXPECT_NE(message({{"sigma_range_m", 0.0}}).find("'sigma_range_m' must be > 0"), std::string::npos);
  EXPECT_NE(message({{"alpha_rot_rot", -0.1}}).find("'alpha_rot_rot' must be >= 0"), std::string::npos);
  EXPECT_NE(message({{"min_variance", 0.0}}).find("'min_variance' must be > 0"), std::string::npos);
  EXPECT_NE(message({{"max_range_m", -1.0}}).find("'max_range_m' must be > 0"), std::string::npos);
  EXPECT_NE(message({{"fov_deg", 400}}).find("'fov_deg' must be > 0 and <= 360"), std::string::npos);
  EXPECT_NE(message(nlohmann::json::array()).find("expected the Plaza options as a JSON object"), std::string::npos);
}

// ---- Synthetic folders --------------------------------------------------------------------------------

namespace {

/// A number as GTSAM's text files write it: %.16e, padded, then a tab.
std::string field(double v) {
  char text[40];
  std::snprintf(text, sizeof text, "  %.16e\t", v);
  return text;
}

std::string row(std::initializer_list<double> values) {
  std::string line;
  for (const double v : values) line += field(v);
  return line + "\r\n";
}

/// A fresh folder per test holding a small, well-formed Plaza1 that tests then spoil. t0 = 3856.5 s;
/// the truth runs to 0.8 s, the odometry to 0.6 s.
class PlazaFiles : public testing::Test {
 protected:
  void SetUp() override {
    write("Plaza1_GT.txt",
          "3856.500000 0.000000 0.000000 4.222432\n"
          "3856.700000 0.200000 0.000000 4.322432\n"
          "3856.900000 0.400000 0.100000 4.122432\n"
          "3857.100000 0.500000 0.100000 4.122432\n"
          "3857.300000 0.600000 0.100000 4.122432\n");
    write("Plaza1_TL.txt",
          "0 -46.623234 11.025549\n1 11.036124 -6.958689\n6 22.053129 23.848482\n5 -17.664893 59.009181\n");
    write("Plaza1_DR.txt", row({3856.7, 0.2, 0.1}) + row({3856.9, 0.3, -0.2}) + row({3857.1, 0.1, 0.0}));
    write("Plaza1_TD.txt", row({3856.8, 2, 5, 10.0})      // between the first two controls
                               + row({3856.9, 2, 0, 20.0})   // at the second control's time: after it
                               + row({3856.6, 2, 1, 30.0})   // earlier than the row before: sorted
                               + row({3856.9, 2, 1, 21.0})   // the same time as the second row: one scan
                               + row({3856.4, 2, 0, 5.0})    // before t0
                               + row({3857.2, 2, 6, 5.0}));  // after the last odometry row
  }

  std::string path(const std::string& name) const { return scratch_.file(name); }
  void write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
  }
  Dataset read(PlazaStats& stats) const {
    return read_plaza(scratch_.path().string(), "Plaza1", PlazaOptions{}, stats);
  }

  /// Reading Plaza1 must throw an InputError at `line` of `file`; returns its message.
  std::string input_error(const std::string& file, std::size_t line) const {
    return test_data::input_error_at([&] { read_plaza(scratch_.path().string()); }, path(file), line);
  }

  test_data::ScratchDir scratch_;
};

}  // namespace

TEST_F(PlazaFiles, EventsMergeInTimeOrderWithControlsFirst) {
  PlazaStats stats;
  const Dataset d = read(stats);
  EXPECT_EQ(d.name, "plaza:Plaza1");
  EXPECT_EQ(d.spec, "plaza:" + scratch_.path().string() + ":Plaza1");
  EXPECT_DOUBLE_EQ(stats.time_origin, 3856.5);
  EXPECT_EQ(d.time_origin_s, 3856);
  EXPECT_EQ(d.time_origin_fraction_s, 0.5);
  EXPECT_NEAR(stats.duration, 0.6, 1e-9);
  EXPECT_EQ(stats.odometry_rows, 3u);
  EXPECT_EQ(stats.range_rows, 6u);
  EXPECT_EQ(stats.reordered_range_rows, 2u);  // 3856.6 after 3856.9, 3856.4 after 3856.9
  EXPECT_EQ(stats.outside_run, 2u);
  EXPECT_EQ(stats.observations, 4u);
  EXPECT_EQ(stats.scans, 3u);
  EXPECT_EQ(stats.beacons, 4u);

  // scan 0.1 | control (0, 0.2] | scan 0.3 | control (0.2, 0.4] | scan 0.4 (two ranges) | control (0.4, 0.6]
  ASSERT_EQ(d.events.size(), 6u);
  const auto expect_scan = [&](std::size_t i, double t, const std::vector<std::pair<int, double>>& ranges) {
    SCOPED_TRACE("event " + std::to_string(i));
    ASSERT_TRUE(std::holds_alternative<ScanEvent>(d.events[i]));
    const auto& s = std::get<ScanEvent>(d.events[i]);
    EXPECT_NEAR(s.t, t, 1e-9);
    ASSERT_EQ(s.observations.size(), ranges.size());
    for (std::size_t k = 0; k < ranges.size(); ++k) {
      EXPECT_EQ(s.observations[k].id, ranges[k].first);
      ASSERT_EQ(s.observations[k].z.size(), 1);
      EXPECT_EQ(s.observations[k].z[0], ranges[k].second);
    }
  };
  const auto expect_control = [&](std::size_t i, double t, double dt, double distance, double turn) {
    SCOPED_TRACE("event " + std::to_string(i));
    ASSERT_TRUE(std::holds_alternative<ControlEvent>(d.events[i]));
    const auto& c = std::get<ControlEvent>(d.events[i]);
    EXPECT_NEAR(c.t, t, 1e-9);
    EXPECT_NEAR(c.dt, dt, 1e-9);
    ASSERT_EQ(c.u.size(), 3);
    EXPECT_EQ(c.u[0], turn / 2);  // the midpoint approximation: half the turn, the distance, the rest
    EXPECT_EQ(c.u[1], distance);
    EXPECT_EQ(c.u[2], turn / 2);
  };
  expect_scan(0, 0.1, {{1, 30.0}});
  expect_control(1, 0.2, 0.2, 0.2, 0.1);
  expect_scan(2, 0.3, {{5, 10.0}});
  expect_control(3, 0.4, 0.2, 0.3, -0.2);
  expect_scan(4, 0.4, {{0, 20.0}, {1, 21.0}});
  expect_control(5, 0.6, 0.2, 0.1, 0.0);
  expect_well_formed(d);
  EXPECT_EQ(d.motion->name(), "odometry");
  EXPECT_EQ(d.observation->name(), "range-only");
  EXPECT_EQ(d.observation->dim(), 1);
  EXPECT_EQ(d.sensor.max_range, PlazaOptions{}.sensor.max_range);

  // The ids are the truth's observation ids; the truth is cut to the run and starts it.
  EXPECT_EQ(d.truth.observation_ids, (std::vector<std::vector<int>>{{1}, {5}, {0, 1}}));
  ASSERT_EQ(d.truth.poses.size(), 4u);
  EXPECT_EQ(d.truth.poses[0].t, 0.0);
  EXPECT_NEAR(d.truth.poses[3].t, 0.6, 1e-9);
  EXPECT_TRUE(d.truth.poses_have_heading);
  EXPECT_EQ(d.truth.poses[1].pose, Pose2(0.2, 0.0, wrap_angle(4.322432)));
  EXPECT_EQ(d.initial_pose, Pose2(0.0, 0.0, wrap_angle(4.222432)));
  ASSERT_EQ(d.truth.landmarks.size(), 4u);
  EXPECT_EQ(d.truth.landmarks[2].id, 6);
  EXPECT_EQ(d.truth.landmarks[2].position, Vector2(22.053129, 23.848482));
  EXPECT_EQ(d.truth.landmarks[3].id, 5);
}

TEST_F(PlazaFiles, OptionsReachTheModels) {
  PlazaOptions o;
  o.measurement.sigma_range = 0.5;
  o.sensor.max_range = 40.0;
  const Dataset d = read_plaza(scratch_.path().string(), "plaza1", o);
  EXPECT_EQ(d.name, "plaza:Plaza1");
  EXPECT_EQ(d.observation->noise()(0, 0), 0.25);
  EXPECT_EQ(d.sensor.max_range, 40.0);
}

TEST_F(PlazaFiles, FieldsThatAreNotNumbersAreNamed) {
  write("Plaza1_DR.txt", row({3856.7, 0.2, 0.1}) + "  3.8569e+003\tabc\t0.0\t\r\n");
  EXPECT_NE(input_error("Plaza1_DR.txt", 2)
                .find("Plaza1_DR.txt:2: expected a finite number for the distance, found 'abc'"),
            std::string::npos);
  SetUp();
  write("Plaza1_TD.txt", row({3856.8, 2, 5, 10.0}) + "  3.8569e+003\t2\t5\tnan\t\r\n");
  EXPECT_NE(input_error("Plaza1_TD.txt", 2).find("expected a finite number for the range, found 'nan'"),
            std::string::npos);
  SetUp();
  write("Plaza1_GT.txt", "3856.5 0.0 0.0 4.2\n3856.7 x 0.0 4.2\n");
  EXPECT_NE(input_error("Plaza1_GT.txt", 2).find("expected a finite number for x, found 'x'"), std::string::npos);
  SetUp();
  write("Plaza1_TL.txt", "0 -46.6 11.0\none 11.0 -7.0\n");
  EXPECT_NE(input_error("Plaza1_TL.txt", 2).find("expected a finite number for the beacon id, found 'one'"),
            std::string::npos);
  SetUp();
  write("Plaza1_TD.txt", row({3856.8, 2, 5, 10.0}) + row({3856.9, 2, 0.5, 10.0}));
  EXPECT_NE(input_error("Plaza1_TD.txt", 2).find("expected a beacon id, a whole number from 0"), std::string::npos);
  SetUp();
  write("Plaza1_TD.txt", row({3856.8, 2, 5, 10.0}) + row({3856.9, 2, 5, -1.0}));
  EXPECT_NE(input_error("Plaza1_TD.txt", 2).find("expected a range > 0, found -1"), std::string::npos);
  SetUp();
  write("Plaza1_GT.txt", "3856.5 0.0 3e6 4.2\n");
  EXPECT_NE(input_error("Plaza1_GT.txt", 1).find("expected y within +-2e6 m"), std::string::npos);
  SetUp();
  write("Plaza1_DR.txt", row({1e13, 0.2, 0.1}));
  EXPECT_NE(input_error("Plaza1_DR.txt", 1).find("expected a time in seconds within +-1e+12"), std::string::npos);
}

TEST_F(PlazaFiles, WrongFieldCountsAreNamed) {
  write("Plaza1_TD.txt", row({3856.8, 2, 5, 10.0}) + row({3856.8, 2, 5, 10.0}) + row({3856.9, 5, 10.0}));
  EXPECT_NE(input_error("Plaza1_TD.txt", 3)
                .find("Plaza1_TD.txt:3: expected 4 fields (<time> <sender> <beacon> <range>), found 3"),
            std::string::npos);
  SetUp();
  write("Plaza1_DR.txt", row({3856.7, 0.2, 0.1, 0.0}));
  EXPECT_NE(input_error("Plaza1_DR.txt", 1).find("expected 3 fields (<time> <distance> <heading change>), found 4"),
            std::string::npos);
  SetUp();
  write("Plaza1_GT.txt", "3856.5 0.0 0.0\n");
  EXPECT_NE(input_error("Plaza1_GT.txt", 1).find("expected 4 fields (<time> <x> <y> <heading>)"), std::string::npos);
  SetUp();
  write("Plaza1_TL.txt", "# beacon x y\n0 -46.6 11.0 0.0\n");
  EXPECT_NE(input_error("Plaza1_TL.txt", 2).find("expected 3 fields (<beacon> <x> <y>)"), std::string::npos);
}

TEST_F(PlazaFiles, OdometryAndTruthTimesGoingBackwardsAreRejected) {
  write("Plaza1_DR.txt", row({3856.7, 0.2, 0.1}) + row({3856.9, 0.3, -0.2}) + row({3856.8, 0.1, 0.0}));
  EXPECT_NE(input_error("Plaza1_DR.txt", 3).find("expected times to increase"), std::string::npos);
  SetUp();
  write("Plaza1_DR.txt", row({3856.7, 0.2, 0.1}) + row({3856.7, 0.3, -0.2}));
  EXPECT_NE(input_error("Plaza1_DR.txt", 2).find("is not after the 3856.7 s of the row before"), std::string::npos);
  SetUp();
  write("Plaza1_DR.txt", row({3856.5, 0.2, 0.1}));
  EXPECT_NE(input_error("Plaza1_DR.txt", 1).find("is not after the 3856.5 s of the first ground-truth row"),
            std::string::npos);
  SetUp();
  write("Plaza1_GT.txt", "3856.5 0.0 0.0 4.2\n3856.7 0.2 0.0 4.2\n3856.6 0.2 0.0 4.2\n");
  EXPECT_NE(input_error("Plaza1_GT.txt", 3)
                .find("time 3856.6 s is earlier than the 3856.7 s of the row before; expected times never to decrease"),
            std::string::npos);
}

TEST_F(PlazaFiles, ABeaconTheBeaconFileLacksIsRejected) {
  write("Plaza1_TD.txt", row({3856.8, 2, 5, 10.0}) + row({3856.9, 2, 7, 10.0}));
  EXPECT_NE(input_error("Plaza1_TD.txt", 2)
                .find("beacon 7 is not in Plaza1_TL.txt; expected one of its beacons: 0, 1, 6, 5"),
            std::string::npos);
  SetUp();
  write("Plaza1_TL.txt", "0 -46.6 11.0\n1 11.0 -7.0\n0 22.0 23.8\n");
  EXPECT_NE(input_error("Plaza1_TL.txt", 3).find("duplicate beacon 0 (first on line 1)"), std::string::npos);
}

TEST_F(PlazaFiles, MissingFilesAreNamed) {
  for (const char* name : {"Plaza1_GT.txt", "Plaza1_TL.txt", "Plaza1_DR.txt", "Plaza1_TD.txt"}) {
    SCOPED_TRACE(name);
    SetUp();
    fs::remove(path(name));
    EXPECT_NE(input_error(name, 0).find("missing file; expected"), std::string::npos);
  }
  // GTSAM ships only the odometry and the ranges as text: the message says where the truth is.
  fs::remove(path("Plaza1_GT.txt"));
  EXPECT_NE(input_error("Plaza1_GT.txt", 0).find("the GT variable of Plaza1_.mat"), std::string::npos);
}

TEST_F(PlazaFiles, EmptyFilesAreRefused) {
  const std::pair<const char*, const char*> expected[] = {
      {"Plaza1_GT.txt", "no poses; expected <time> <x> <y> <heading>"},
      {"Plaza1_TL.txt", "no beacons; expected <beacon> <x> <y>"},
      {"Plaza1_DR.txt", "no odometry; expected <time> <distance>"},
      {"Plaza1_TD.txt", "no ranges; expected <time> <sender>"}};
  for (const auto& [name, message] : expected) {
    SCOPED_TRACE(name);
    SetUp();
    write(name, "\r\n");
    EXPECT_NE(input_error(name, 0).find(message), std::string::npos) << message;
  }
}

// Ranges that all fall outside the run would leave dead reckoning, reported like a SLAM result.
TEST_F(PlazaFiles, RangesAllOutsideTheRunAreRefused) {
  write("Plaza1_TD.txt", row({3856.4, 2, 0, 5.0}) + row({3857.2, 2, 6, 5.0}));
  EXPECT_NE(input_error("Plaza1_TD.txt", 0).find("no range within the run (all 2 rows"), std::string::npos);
}

TEST_F(PlazaFiles, RunNamesOfAnotherFormAndMissingFoldersAreRefused) {
  for (const char* run : {"Plaza", "Plaza0", "Plaza01", "Plaza-1", "Plaza1x", "Gesling1", ""}) {
    try {
      read_plaza(scratch_.path().string(), run);
      ADD_FAILURE() << "run '" << run << "' accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("no Plaza run '") + run + "'; expected PlazaN"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_EQ(plaza_run_name("PLAZA2"), "Plaza2");
  EXPECT_EQ(plaza_run_name("Plaza12"), "Plaza12");
  EXPECT_FALSE(plaza_run_name("Plaza+1"));
  // A run whose files are absent is a missing file, a missing folder a missing directory.
  test_data::input_error_at([&] { read_plaza(scratch_.path().string(), "plaza2"); }, path("Plaza2_GT.txt"), 0);
  try {
    read_plaza(path("nowhere"));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path("nowhere"));
    EXPECT_NE(std::string(e.what()).find("not a directory; expected a Plaza folder holding Plaza1_DR.txt"),
              std::string::npos);
  }
}
