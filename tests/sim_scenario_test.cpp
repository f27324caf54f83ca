// The simulator's data-association conditions (clutter, missed detections, withheld ids), open
// routes, and the named scenarios, the loop closure above all.
#include <gtest/gtest.h>

#include "test_data.hpp"
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "slamkit/core/error.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

using test_data::ScratchDir;

std::vector<ScanEvent> scans_of(const Dataset& d) {
  std::vector<ScanEvent> out;
  for (const Event& e : d.events)
    if (const auto* s = std::get_if<ScanEvent>(&e)) out.push_back(*s);
  return out;
}

std::vector<ControlEvent> controls_of(const Dataset& d) {
  std::vector<ControlEvent> out;
  for (const Event& e : d.events)
    if (const auto* c = std::get_if<ControlEvent>(&e)) out.push_back(*c);
  return out;
}

// Sweeps the sensor made, with or without a ScanEvent: one every observation period.
std::size_t sweeps_of(const Dataset& d, const SimulatorConfig& c) {
  return controls_of(d).size() /
         static_cast<std::size_t>(std::lround(c.observation_period / c.control_period));
}

// FNV-1a over the bit patterns of everything a run produces.
class Fingerprint {
 public:
  void add(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) {
      hash_ ^= (v >> (8 * i)) & 0xffU;
      hash_ *= 0x100000001b3ULL;
    }
  }
  void add(double d) {
    std::uint64_t v = 0;
    std::memcpy(&v, &d, sizeof v);
    add(v);
  }
  void add(int i) { add(static_cast<std::uint64_t>(static_cast<std::int64_t>(i))); }
  std::uint64_t value() const { return hash_; }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

std::uint64_t fingerprint(const Dataset& d) {
  Fingerprint f;
  for (const Event& e : d.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      f.add(c->t);
      f.add(c->dt);
      f.add(c->u[0]);
      f.add(c->u[1]);
    } else {
      const auto& s = std::get<ScanEvent>(e);
      f.add(s.t);
      for (const Observation& o : s.observations) {
        f.add(o.id);
        f.add(o.z[0]);
        f.add(o.z[1]);
      }
    }
  }
  for (const StampedPose& p : d.truth.poses) {
    f.add(p.t);
    f.add(p.pose.x());
    f.add(p.pose.y());
    f.add(p.pose.z());
  }
  for (const std::vector<int>& ids : d.truth.observation_ids)
    for (const int id : ids) f.add(id);
  return f.value();
}

double open_route_length(const World& w) {
  double length = 0.0;
  for (std::size_t i = 1; i < w.waypoints.size(); ++i) length += (w.waypoints[i] - w.waypoints[i - 1]).norm();
  return length;
}

// A count over n independent trials of probability p lies within 4 standard errors of n p.
void expect_binomial(std::size_t hits, std::size_t n, double p, const char* what) {
  ASSERT_GT(n, 1000u) << what;
  const double nd = static_cast<double>(n);
  EXPECT_NEAR(static_cast<double>(hits), nd * p, 4.0 * std::sqrt(nd * p * (1.0 - p))) << what;
}

void expect_input_error(const std::function<void()>& f, const std::string& file, std::size_t line,
                        const std::string& message) {
  try {
    f();
    ADD_FAILURE() << "no error; expected " << message;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file) << e.what();
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
  }
}

// ---- Defaults ---------------------------------------------------------------------------------------

// Recorded from the simulator before detection settings existed: runs made with the defaults must
// stay what they were, since results elsewhere quote seeds.
TEST(SimulatorDefaults, DefaultRunIsUnchangedBitForBit) {
  const Dataset d = simulate(default_world(), SimulatorConfig{});
  EXPECT_EQ(d.events.size(), 10920u);
  const std::vector<ScanEvent> scans = scans_of(d);
  ASSERT_FALSE(scans.empty());
  const Observation& first = scans.front().observations.front();
  EXPECT_EQ(first.id, 5);
  EXPECT_EQ(first.z[0], 0x1.f24ff7be4b7f6p+2);
  EXPECT_EQ(first.z[1], -0x1.3f9f902b8bfccp+1);
  std::size_t observations = 0;
  for (const ScanEvent& s : scans) observations += s.observations.size();
  EXPECT_EQ(observations, 18392u);
  EXPECT_EQ(fingerprint(d), 0x476c92136b0f28b0ULL);
}

// ---- Clutter ----------------------------------------------------------------------------------------

// Without landmarks every observation is clutter and a sweep without a ScanEvent counted zero.
std::vector<double> clutter_per_sweep(const World& empty, const SimulatorConfig& c) {
  const Dataset d = simulate(empty, c);
  std::vector<double> counts(sweeps_of(d, c), 0.0);
  const double period = c.observation_period;
  for (const ScanEvent& s : scans_of(d)) {
    for (const Observation& o : s.observations) EXPECT_EQ(o.id, kUnknownId);
    counts.at(static_cast<std::size_t>(std::lround(s.t / period)) - 1) =
        static_cast<double>(s.observations.size());
  }
  return counts;
}

TEST(Clutter, CountPerScanIsPoissonWithTheConfiguredMean) {
  const World empty{{}, default_world().waypoints};
  for (const double rate : {0.3, 2.5, 800.0}) {
    SimulatorConfig c;
    c.clutter_rate = rate;
    c.loops = rate > 100.0 ? 1 : 4;
    const std::vector<double> counts = clutter_per_sweep(empty, c);
    const double n = static_cast<double>(counts.size());
    double mean = 0.0, var = 0.0;
    for (const double k : counts) mean += k;
    mean /= n;
    for (const double k : counts) var += (k - mean) * (k - mean);
    var /= n - 1.0;
    EXPECT_NEAR(mean, rate, 4.0 * std::sqrt(rate / n)) << "rate " << rate;
    // A Poisson count's variance equals its mean; the sample variance's variance is (r + 2 r^2) / n.
    EXPECT_NEAR(var, rate, 4.0 * std::sqrt((rate + 2.0 * rate * rate) / n)) << "rate " << rate;
  }
}

TEST(Clutter, IsUniformOverTheVisibleSector) {
  const World empty{{}, default_world().waypoints};
  SimulatorConfig c;
  c.clutter_rate = 3.0;
  c.fov = deg2rad(90.0);
  c.max_range = 20.0;
  const Dataset d = simulate(empty, c);
  std::size_t n = 0, inner = 0, left = 0, outer_quarter = 0;
  for (const ScanEvent& s : scans_of(d)) {
    for (const Observation& o : s.observations) {
      ++n;
      ASSERT_GT(o.z[0], 0.0);
      ASSERT_LE(o.z[0], c.max_range);
      ASSERT_LE(std::abs(o.z[1]), c.fov / 2.0);
      // Half the sector's area lies within max_range / sqrt(2); uniform in area, not in range.
      if (o.z[0] < c.max_range / std::sqrt(2.0)) ++inner;
      if (o.z[1] > 0.0) ++left;
      if (std::abs(o.z[1]) > c.fov / 4.0) ++outer_quarter;
    }
  }
  expect_binomial(inner, n, 0.5, "inside max_range / sqrt 2");
  expect_binomial(left, n, 0.5, "left of the heading");
  expect_binomial(outer_quarter, n, 0.5, "in the outer half of the field of view");
}

TEST(Clutter, HasUnknownIdsInEventsAndTruthAndLeavesTheOtherNoiseAlone) {
  const World w = default_world();
  SimulatorConfig c;
  c.clutter_rate = 2.0;
  const Dataset plain = simulate(w, SimulatorConfig{});
  const Dataset d = simulate(w, c);
  const std::vector<ScanEvent> scans = scans_of(d), plain_scans = scans_of(plain);
  ASSERT_EQ(d.truth.observation_ids.size(), scans.size());
  std::size_t clutter = 0, plain_index = 0;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    ASSERT_EQ(d.truth.observation_ids[i].size(), scans[i].observations.size());
    std::vector<std::pair<int, double>> real;
    for (std::size_t j = 0; j < scans[i].observations.size(); ++j) {
      const Observation& o = scans[i].observations[j];
      EXPECT_EQ(o.id, d.truth.observation_ids[i][j]);
      if (o.id == kUnknownId)
        ++clutter;
      else
        real.emplace_back(o.id, o.z[0]);
    }
    // The real detections are those of the run without clutter, with the same noise.
    if (real.empty()) continue;
    while (plain_index < plain_scans.size() && plain_scans[plain_index].t < scans[i].t) ++plain_index;
    ASSERT_LT(plain_index, plain_scans.size());
    ASSERT_EQ(plain_scans[plain_index].t, scans[i].t);
    std::vector<std::pair<int, double>> expected;
    for (const Observation& o : plain_scans[plain_index].observations) expected.emplace_back(o.id, o.z[0]);
    std::sort(real.begin(), real.end());
    EXPECT_EQ(real, expected) << "scan at " << scans[i].t;
  }
  EXPECT_GT(clutter, 1000u);
  ASSERT_EQ(controls_of(d).size(), controls_of(plain).size());
  for (std::size_t i = 0; i < controls_of(d).size(); i += 97)
    EXPECT_EQ(controls_of(d)[i].u, controls_of(plain)[i].u);
}

// ---- Missed detections ------------------------------------------------------------------------------

TEST(Detection, RateMatchesTheProbabilityAndKeepsASubsetOfTheDetections) {
  const World w = default_world();
  SimulatorConfig c;
  c.detection_probability = 0.7;
  const Dataset all = simulate(w, SimulatorConfig{});
  const Dataset some = simulate(w, c);
  std::map<double, std::vector<Observation>> by_time;
  std::size_t offered = 0, detected = 0;
  for (const ScanEvent& s : scans_of(all)) {
    offered += s.observations.size();
    by_time[s.t] = s.observations;
  }
  for (const ScanEvent& s : scans_of(some)) {
    detected += s.observations.size();
    // In map order as before, and each detection exactly as the sensor measured it with Pd = 1.
    const std::vector<Observation>& full = by_time.at(s.t);
    auto next = full.begin();
    for (const Observation& o : s.observations) {
      next = std::find_if(next, full.end(), [&](const Observation& f) { return f.id == o.id; });
      ASSERT_NE(next, full.end()) << "landmark " << o.id << " at " << s.t;
      EXPECT_EQ(next->z, o.z);
      ++next;
    }
  }
  expect_binomial(detected, offered, 0.7, "detections");
  ASSERT_EQ(controls_of(some).size(), controls_of(all).size());
  EXPECT_EQ(controls_of(some).back().u, controls_of(all).back().u);
}

// ---- Order and identities ---------------------------------------------------------------------------

TEST(ScanOrder, ShuffleIsDeterministicAndMixesClutterIn) {
  const World w = default_world();
  SimulatorConfig c;
  c.clutter_rate = 1.0;
  const Dataset a = simulate(w, c);
  EXPECT_EQ(fingerprint(a), fingerprint(simulate(w, c)));
  c.seed = 2;
  EXPECT_NE(fingerprint(a), fingerprint(simulate(w, c)));

  // A clutter observation is last in its scan about 1 / (scan size) of the time, not always.
  std::size_t clutter = 0, clutter_last = 0;
  double expected_last = 0.0;
  for (const std::vector<int>& ids : a.truth.observation_ids) {
    for (std::size_t j = 0; j < ids.size(); ++j) {
      if (ids[j] != kUnknownId) continue;
      ++clutter;
      expected_last += 1.0 / static_cast<double>(ids.size());
      if (j + 1 == ids.size()) ++clutter_last;
    }
  }
  ASSERT_GT(clutter, 1000u);
  EXPECT_NEAR(static_cast<double>(clutter_last), expected_last, 4.0 * std::sqrt(expected_last));
}

TEST(ScanOrder, WithoutIdsMapOrderDoesNotShow) {
  SimulatorConfig c;
  c.provide_ids = false;
  const Dataset d = simulate(default_world(), c);
  std::size_t sorted = 0, scans = 0;
  for (const std::vector<int>& ids : d.truth.observation_ids) {
    if (ids.size() < 4) continue;
    ++scans;
    if (std::is_sorted(ids.begin(), ids.end())) ++sorted;
  }
  ASSERT_GT(scans, 1000u);
  // Four or more in random order come out sorted at most 1 time in 24.
  EXPECT_LT(static_cast<double>(sorted), static_cast<double>(scans) / 24.0 * 1.5);
}

TEST(Identities, WithheldFromTheEventsButKeptInTheTruthAndOnDisk) {
  const World w = default_world();
  SimulatorConfig c;
  c.provide_ids = false;
  const Dataset with_ids = simulate(w, SimulatorConfig{});
  const Dataset d = simulate(w, c);
  const std::vector<ScanEvent> scans = scans_of(d), scans_with_ids = scans_of(with_ids);
  ASSERT_EQ(scans.size(), scans_with_ids.size());
  ASSERT_EQ(d.truth.observation_ids.size(), scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    // The same measurements, in another order, with the ids only in the truth.
    std::vector<std::tuple<int, double, double>> hidden, shown;
    for (std::size_t j = 0; j < scans[i].observations.size(); ++j) {
      const Observation& o = scans[i].observations[j];
      EXPECT_EQ(o.id, kUnknownId);
      hidden.emplace_back(d.truth.observation_ids[i][j], o.z[0], o.z[1]);
    }
    for (const Observation& o : scans_with_ids[i].observations) shown.emplace_back(o.id, o.z[0], o.z[1]);
    std::sort(hidden.begin(), hidden.end());
    ASSERT_EQ(hidden, shown) << "scan " << i;
  }

  const ScratchDir scratch;
  write_sim_log(scratch.path().string(), d, c, w);
  std::ifstream events(scratch.file("events.txt"));
  std::size_t obs_lines = 0;
  for (std::string line; std::getline(events, line);) {
    if (line.rfind("obs ", 0) != 0) continue;
    ++obs_lines;
    ASSERT_NE(line.find(" -1 "), std::string::npos) << line;
  }
  EXPECT_GT(obs_lines, 10000u);
  const Dataset r = read_sim_log(scratch.path().string());
  EXPECT_EQ(r.truth.observation_ids, d.truth.observation_ids);
  for (const ScanEvent& s : scans_of(r))
    for (const Observation& o : s.observations) ASSERT_EQ(o.id, kUnknownId);
}

// ---- Config -----------------------------------------------------------------------------------------

TEST(DetectionConfig, KeysRoundTripThroughJsonAndParams) {
  SimulatorConfig c;
  c.clutter_rate = 1.5;
  c.detection_probability = 0.85;
  c.provide_ids = false;
  const nlohmann::json j = to_json(c);
  EXPECT_EQ(j.at("clutter_rate_per_scan").get<double>(), 1.5);
  EXPECT_EQ(j.at("detection_probability").get<double>(), 0.85);
  EXPECT_EQ(j.at("provide_ids").get<bool>(), false);

  // Through params.json, as a log stores it.
  const ScratchDir scratch;
  const World w = default_world();
  c.loops = 1;
  write_sim_log(scratch.path().string(), simulate(w, c), c, w);
  std::ifstream in(scratch.file("params.json"));
  const SimulatorConfig r =
      simulator_config_from_json(nlohmann::json::parse(in).at("simulator"), "params.json");
  EXPECT_EQ(r.clutter_rate, c.clutter_rate);
  EXPECT_EQ(r.detection_probability, c.detection_probability);
  EXPECT_EQ(r.provide_ids, c.provide_ids);

  // Configs written before these keys existed read as the ideal detector.
  const SimulatorConfig old = simulator_config_from_json({{"speed_mps", 3.0}}, "old.json");
  EXPECT_EQ(old.clutter_rate, 0.0);
  EXPECT_EQ(old.detection_probability, 1.0);
  EXPECT_TRUE(old.provide_ids);
}

TEST(DetectionConfig, BadValuesAreRejected) {
  const std::vector<nlohmann::json> bad = {
      {{"clutter_rate_per_scan", -0.1}}, {{"clutter_rate_per_scan", "many"}},
      {{"detection_probability", 0.0}},  {{"detection_probability", 1.01}},
      {{"detection_probability", -0.5}}, {{"provide_ids", 1}},
      {{"provide_ids", "true"}},
  };
  for (const nlohmann::json& j : bad) {
    try {
      simulator_config_from_json(j, "cfg.json");
      ADD_FAILURE() << "no error for " << j.dump();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(j.items().begin().key()), std::string::npos) << e.what();
    }
  }
  SimulatorConfig nan_rate;
  nan_rate.clutter_rate = std::nan("");
  EXPECT_THROW(simulate(default_world(), nan_rate), InputError);
  SimulatorConfig never;
  never.detection_probability = 0.0;
  EXPECT_THROW(simulate(default_world(), never), InputError);
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
    expect_input_error([&] { read_world(path); }, path, line, message);
  }
}

// ---- Scenarios --------------------------------------------------------------------------------------

TEST(Scenario, NamesGiveTheirWorldsAndSettings) {
  EXPECT_EQ(scenario_names(),
            (std::vector<std::string>{"default", "loop-closure", "cluttered", "loop-closure-cluttered", "sparse",
                                      "sparse-cluttered"}));
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
