// The simulator's data-association conditions: clutter, missed detections, the order of a scan,
// withheld identities and their settings, and the default run they leave unchanged.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "sim_test_support.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

using namespace test_sim;
using test_data::ScratchDir;

// A count over n independent trials of probability p lies within 4 standard errors of n p.
void expect_binomial(std::size_t hits, std::size_t n, double p, const char* what) {
  ASSERT_GT(n, 1000u) << what;
  const double nd = static_cast<double>(n);
  EXPECT_NEAR(static_cast<double>(hits), nd * p, 4.0 * std::sqrt(nd * p * (1.0 - p))) << what;
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

}  // namespace
}  // namespace slamkit
