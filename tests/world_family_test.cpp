// The world families (random_world, world_family): the held-out test bed of data association, so
// what makes it a fair one is pinned down here: a seed fixes a world and a log, the worlds differ,
// the vehicle can drive every route and comes back past its start, the density is the family's, and
// the second lap re-observes the first, so that loops closed and spurious landmarks mean what they say.
#include <gtest/gtest.h>

#include "sim_test_support.hpp"
#include "test_data.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace slamkit {
namespace {

using test_data::input_error_at;
using test_data::ScratchDir;
using test_sim::fingerprint;
using test_sim::scans_of;
using test_sim::sweeps_of;

double segment_distance(const Vector2& p, const Vector2& a, const Vector2& b) {
  const Vector2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

// Corner i of a closed route and the leg from it to the next.
Vector2 corner(const World& w, std::size_t i) { return w.waypoints[i % w.waypoints.size()]; }

double distance_to_route(const World& w, const Vector2& p) {
  double d = 1e300;
  for (std::size_t i = 0; i < w.waypoints.size(); ++i) d = std::min(d, segment_distance(p, corner(w, i), corner(w, i + 1)));
  return d;
}

double lap_length(const World& w) {
  double length = 0.0;
  for (std::size_t i = 0; i < w.waypoints.size(); ++i) length += (corner(w, i + 1) - corner(w, i)).norm();
  return length;
}

double cross(const Vector2& a, const Vector2& b) { return a.x() * b.y() - a.y() * b.x(); }

// Whether the open segments ab and cd cross (a proper intersection).
bool cross_each_other(const Vector2& a, const Vector2& b, const Vector2& c, const Vector2& d) {
  const double d1 = cross(b - a, c - a), d2 = cross(b - a, d - a), d3 = cross(d - c, a - c), d4 = cross(d - c, b - c);
  return d1 * d2 < 0.0 && d3 * d4 < 0.0;
}

constexpr std::uint64_t kSeeds = 30;

TEST(WorldFamily, SameSeedsGiveTheSameWorldAndLogBitForBit) {
  const WorldFamily family = world_family("sparse-cluttered");
  const Scenario a = family.member(17), b = family.member(17);
  EXPECT_EQ(a.world.waypoints, b.world.waypoints);
  ASSERT_EQ(a.world.landmarks.size(), b.world.landmarks.size());
  for (std::size_t i = 0; i < a.world.landmarks.size(); ++i)
    EXPECT_EQ(a.world.landmarks[i].position, b.world.landmarks[i].position);
  ASSERT_TRUE(a.world.origin.has_value());
  EXPECT_EQ(a.world.origin->family, "sparse-cluttered");
  EXPECT_EQ(a.world.origin->seed, 17U);

  SimulatorConfig config = a.config;
  config.seed = 3;
  const Dataset first = simulate(a.world, config), second = simulate(b.world, config);
  EXPECT_EQ(fingerprint(first), fingerprint(second));
  // The noise seed changes the log, not the world.
  config.seed = 4;
  const Dataset other = simulate(a.world, config);
  EXPECT_NE(fingerprint(other), fingerprint(first));
  EXPECT_EQ(other.truth.landmarks.size(), first.truth.landmarks.size());
}

TEST(WorldFamily, WorldsDifferBetweenSeedsInSizeShapeAndDirection) {
  const WorldFamily family = world_family("sparse");
  std::set<std::size_t> corner_counts;
  std::set<bool> counter_clockwise;
  std::vector<double> laps;
  bool concave = false;
  for (std::uint64_t seed = 1; seed <= kSeeds; ++seed) {
    const World w = family.member(seed).world;
    corner_counts.insert(w.waypoints.size());
    laps.push_back(lap_length(w));
    double area = 0.0;
    for (std::size_t i = 0; i < w.waypoints.size(); ++i) area += cross(corner(w, i), corner(w, i + 1));
    counter_clockwise.insert(area > 0.0);
    // A corner turning against the route's direction of travel makes the polygon concave.
    for (std::size_t i = 0; i < w.waypoints.size(); ++i)
      if (cross(corner(w, i + 1) - corner(w, i), corner(w, i + 2) - corner(w, i + 1)) * area < 0.0) concave = true;
    if (seed > 1) EXPECT_NE(w.waypoints, family.member(seed - 1).world.waypoints) << seed;
  }
  EXPECT_GE(corner_counts.size(), 3U);
  EXPECT_EQ(counter_clockwise.size(), 2U);
  EXPECT_TRUE(concave);
  EXPECT_LT(*std::min_element(laps.begin(), laps.end()), 550.0);
  EXPECT_GT(*std::max_element(laps.begin(), laps.end()), 850.0);
}

TEST(WorldFamily, RoutesKeepTheRulesTheVehicleNeeds) {
  const RandomWorldOptions rules;
  for (std::uint64_t seed = 1; seed <= kSeeds; ++seed) {
    const World w = world_family("sparse").member(seed).world;
    const std::size_t n = w.waypoints.size();
    ASSERT_GE(n, static_cast<std::size_t>(rules.min_corners));
    ASSERT_LE(n, static_cast<std::size_t>(rules.max_corners));
    EXPECT_TRUE(w.closed);
    EXPECT_GE(lap_length(w), rules.min_lap_m - 1e-6);
    EXPECT_LE(lap_length(w), rules.max_lap_m + 1e-6);
    // The start is the middle of the last leg, at the origin, facing the first waypoint along +x.
    ASSERT_TRUE(w.start.has_value());
    EXPECT_EQ(*w.start, Pose2::Zero());
    EXPECT_NEAR(w.waypoints.front().y(), 0.0, 1e-9) << seed;
    EXPECT_NEAR(w.waypoints.back().y(), 0.0, 1e-9) << seed;
    EXPECT_NEAR(w.waypoints.front().x(), -w.waypoints.back().x(), 1e-9) << seed;
    EXPECT_GT(w.waypoints.front().x(), 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const Vector2 in = corner(w, i + n) - corner(w, i + n - 1), out = corner(w, i + 1) - corner(w, i);
      EXPECT_GE(out.norm(), rules.min_leg_m - 1e-9) << seed;
      EXPECT_LE(std::abs(wrap_angle(std::atan2(out.y(), out.x()) - std::atan2(in.y(), in.x()))),
                rules.max_turn + 1e-12)
          << seed;
      for (std::size_t j = i + 2; j < n; ++j) {
        if (i == 0 && j == n - 1) continue;  // these share the first corner
        EXPECT_FALSE(cross_each_other(corner(w, i), corner(w, i + 1), corner(w, j), corner(w, j + 1))) << seed;
        for (const Vector2& end : {corner(w, j), corner(w, j + 1)})
          EXPECT_GE(segment_distance(end, corner(w, i), corner(w, i + 1)), rules.min_leg_gap_m - 1e-9) << seed;
      }
    }
  }
}

// One lap of every route: the simulator throws on a corner the vehicle cannot reach; it also stays
// near the route and passes its start on the way back to the first corner.
TEST(WorldFamily, TheVehicleDrivesEveryRouteAndComesBackPastItsStart) {
  for (std::uint64_t seed = 1; seed <= kSeeds; ++seed) {
    Scenario s = world_family("sparse").member(seed);
    s.config.loops = 1;
    Dataset d;
    ASSERT_NO_THROW(d = simulate(s.world, s.config)) << seed;
    double farthest = 0.0, closest_late = 1e300;
    const double end_t = d.truth.poses.back().t;
    for (const StampedPose& p : d.truth.poses) {
      farthest = std::max(farthest, distance_to_route(s.world, p.pose.head<2>()));
      if (p.t > 0.8 * end_t) closest_late = std::min(closest_late, p.pose.head<2>().norm());
    }
    EXPECT_LT(farthest, 12.0) << seed;  // a corner cut or overshot at the turning radius
    EXPECT_LT(closest_late, 5.0) << seed;  // still settling on the first leg after the last corner
    // It ends at the first waypoint, a lap and the half leg from the start to it on.
    EXPECT_LT((d.truth.poses.back().pose.head<2>() - s.world.waypoints.front()).norm(), s.config.waypoint_tolerance);
    EXPECT_NEAR(end_t * s.config.speed, lap_length(s.world) + s.world.waypoints.front().x(), 0.05 * lap_length(s.world))
        << seed;
  }
}

TEST(WorldFamily, LandmarksHaveTheFamilysDensityBandAndSpacing) {
  const RandomWorldOptions rules;
  for (const auto& [name, per_km] : std::map<std::string, double>{{"sparse", 55.0}, {"dense", 165.0}}) {
    const WorldFamily family = world_family(name);
    EXPECT_EQ(family.world.landmarks_per_km, per_km);
    for (std::uint64_t seed = 1; seed <= kSeeds; ++seed) {
      const World w = family.member(seed).world;
      EXPECT_EQ(static_cast<double>(w.landmarks.size()), std::round(per_km * lap_length(w) / 1000.0)) << name << seed;
      for (std::size_t i = 0; i < w.landmarks.size(); ++i) {
        const Landmark& l = w.landmarks[i];
        EXPECT_EQ(l.id, static_cast<int>(i));
        const double d = distance_to_route(w, l.position);
        EXPECT_GE(d, rules.band_inner - 1e-9) << name << seed;
        EXPECT_LE(d, rules.band_outer + 1e-9) << name << seed;
        for (std::size_t j = 0; j < i; ++j)
          EXPECT_GE((w.landmarks[j].position - l.position).norm(), rules.min_spacing) << name << seed;
      }
    }
  }
}

// What the sensor sees per sweep over a lap of each world: sparse like the sparse world (1.42 per
// sweep, none in 22% of sweeps), with stretches of seconds with nothing in view in every world;
// dense three times as many, hardly ever none.
TEST(WorldFamily, SparseWorldsShowALandmarkOrTwoAtATimeAndDenseOnesAFew) {
  for (const auto& [name, low, high, empty_low, empty_high] :
       {std::tuple{"sparse", 1.2, 1.7, 0.12, 0.35}, std::tuple{"dense", 3.5, 5.0, 0.0, 0.05}}) {
    double observations = 0.0, sweeps = 0.0, empty = 0.0;
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      Scenario s = world_family(name).member(seed);
      s.config.loops = 1;
      const Dataset d = simulate(s.world, s.config);
      double last_t = 0.0, longest_blind_s = 0.0;
      const std::vector<ScanEvent> scans = scans_of(d);
      for (const ScanEvent& scan : scans) {
        observations += static_cast<double>(scan.observations.size());
        longest_blind_s = std::max(longest_blind_s, scan.t - last_t);
        last_t = scan.t;
      }
      sweeps += static_cast<double>(sweeps_of(d, s.config));
      empty += static_cast<double>(sweeps_of(d, s.config) - scans.size());
      if (std::string(name) == "sparse") EXPECT_GE(longest_blind_s, 5.0) << seed;
    }
    EXPECT_GT(observations / sweeps, low) << name;
    EXPECT_LT(observations / sweeps, high) << name;
    EXPECT_GE(empty / sweeps, empty_low) << name;
    EXPECT_LE(empty / sweeps, empty_high) << name;
  }
}

TEST(WorldFamily, ClutteredFamiliesShareTheWorldsAndHaveTheClutteredDetection) {
  for (const char* base : {"sparse", "dense"}) {
    const WorldFamily clean = world_family(base), cluttered = world_family(std::string(base) + "-cluttered");
    EXPECT_EQ(clean.config.clutter_rate, 0.0);
    EXPECT_EQ(clean.config.detection_probability, 1.0);
    EXPECT_EQ(cluttered.config.clutter_rate, 1.0);
    EXPECT_EQ(cluttered.config.detection_probability, 0.9);
    EXPECT_FALSE(cluttered.config.provide_ids);
    for (const WorldFamily* f : {&clean, &cluttered}) {
      // The sparse scenario's geometry: the reference simulator's vehicle and sensor, looking ahead.
      EXPECT_NEAR(rad2deg(f->config.fov), 180.0, 1e-9);
      EXPECT_EQ(f->config.max_range, 30.0);
      EXPECT_EQ(f->config.sigma_range, 0.1);
      EXPECT_NEAR(rad2deg(f->config.sigma_bearing), 1.0, 1e-12);
      EXPECT_EQ(f->config.loops, 2);
      EXPECT_EQ(f->config.fov, scenario("sparse").config.fov);
    }
    const World a = clean.member(9).world, b = cluttered.member(9).world;
    EXPECT_EQ(a.waypoints, b.waypoints);
    ASSERT_EQ(a.landmarks.size(), b.landmarks.size());
    for (std::size_t i = 0; i < a.landmarks.size(); ++i) EXPECT_EQ(a.landmarks[i].position, b.landmarks[i].position);
  }
  // The density draws from its own stream: sparse and dense worlds of a seed share their route.
  EXPECT_EQ(world_family("sparse").member(4).world.waypoints, world_family("dense").member(4).world.waypoints);
}

// The association metrics on these worlds, scored on two made-up runs over the truth's own
// identities: one that pairs every observation with the landmark its first sighting started (a
// perfect association) and one that starts a landmark again at each return. Loops closed must
// tell them apart, which needs returns: the second lap's re-observations of the first lap's
// landmarks, after a lap of drift.
TEST(WorldFamily, EveryWorldReturnsToItsLandmarksSoLoopClosureIsMeasured) {
  const EvaluationOptions options;
  for (const char* name : {"sparse", "sparse-cluttered"}) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      const Scenario s = world_family(name).member(seed);
      const Dataset d = simulate(s.world, s.config);
      RunResult perfect, forgetful;
      for (RunResult* run : {&perfect, &forgetful}) {
        run->association = "nn";
        run->filtered = d.truth.poses;
        run->pose_covariances.assign(d.truth.poses.size(), Matrix3::Identity());
      }
      std::map<int, double> last_seen;
      std::map<int, int> forgetful_id;  // the latest landmark the forgetful run started for a true one
      int started = 0;
      std::size_t observations = 0;
      const std::vector<ScanEvent> scans = scans_of(d);
      for (std::size_t k = 0; k < scans.size(); ++k) {
        const double t = scans[k].t;
        perfect.scan_times.push_back(t);
        forgetful.scan_times.push_back(t);
        perfect.associations.emplace_back();
        forgetful.associations.emplace_back();
        for (const int id : d.truth.observation_ids[k]) {
          if (id == kUnknownId) {
            perfect.associations.back().push_back({AssociationDecision::kDiscard, kUnknownId});
            forgetful.associations.back().push_back({AssociationDecision::kDiscard, kUnknownId});
            continue;
          }
          ++observations;
          const auto last = last_seen.find(id);
          const bool first = last == last_seen.end();
          perfect.associations.back().push_back({first ? AssociationDecision::kNew : AssociationDecision::kUpdate, id});
          const bool again = first || t - last->second > options.revisit_gap_s;
          if (again) forgetful_id[id] = started++;
          forgetful.associations.back().push_back(
              {again ? AssociationDecision::kNew : AssociationDecision::kUpdate, forgetful_id[id]});
          last_seen[id] = t;
        }
      }
      for (const Landmark& l : d.truth.landmarks)
        if (last_seen.count(l.id)) perfect.map.push_back(l);
      for (int id = 0; id < started; ++id) forgetful.map.push_back(Landmark{id, Vector2::Zero(), Matrix2::Zero()});
      const AssociationMetrics good = evaluate_run(perfect, d.truth, options).association.value();
      const AssociationMetrics bad = evaluate_run(forgetful, d.truth, options).association.value();
      EXPECT_GT(static_cast<double>(good.return_observations), 0.35 * static_cast<double>(observations)) << name << seed;
      EXPECT_EQ(good.loop_closure_fraction().value(), 1.0) << name << seed;
      EXPECT_EQ(good.spurious_landmarks, 0U) << name << seed;
      EXPECT_LT(bad.loop_closure_fraction().value(), 0.2) << name << seed;
      EXPECT_GT(bad.spurious_landmarks, 0.8 * static_cast<double>(last_seen.size())) << name << seed;
    }
  }
}

TEST(WorldFamily, UnknownNamesAreRejectedWithTheClosestKnownOne) {
  EXPECT_EQ(world_family_names(), (std::vector<std::string>{"sparse", "sparse-cluttered", "dense", "dense-cluttered"}));
  for (const std::string& name : world_family_names()) EXPECT_EQ(world_family(name).name, name);
  const auto message = [](const std::string& name) {
    try {
      world_family(name);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string slip = message("sparse-clutered");
  EXPECT_NE(slip.find("unknown world family 'sparse-clutered' (did you mean 'sparse-cluttered'?)"), std::string::npos)
      << slip;
  EXPECT_NE(slip.find("expected one of: sparse, sparse-cluttered, dense, dense-cluttered"), std::string::npos) << slip;
  EXPECT_NE(message("Dense").find("did you mean 'dense'?"), std::string::npos);
  const std::string far = message("victoria-park");
  EXPECT_EQ(far.find("did you mean"), std::string::npos) << far;
  EXPECT_NE(far.find("expected one of"), std::string::npos) << far;
}

TEST(WorldFamily, ImpossibleOptionsAreErrorsNotHangs) {
  RandomWorldOptions o;
  o.min_corners = 3;
  EXPECT_THROW(random_world(o, 1), InputError);
  o = RandomWorldOptions{};
  o.band_outer = o.band_inner;
  EXPECT_THROW(random_world(o, 1), InputError);
  // Turns this gentle cannot close a loop of five to eight corners.
  o = RandomWorldOptions{};
  o.max_turn = deg2rad(20.0);
  EXPECT_THROW(random_world(o, 1), InputError);
  // Far more landmarks than the band holds at their spacing.
  o = RandomWorldOptions{};
  o.landmarks_per_km = 3000.0;
  EXPECT_THROW(random_world(o, 1), InputError);
}

TEST(WorldFamily, TheOriginRoundTripsThroughWorldFilesAndIsRecordedInTheLog) {
  const ScratchDir scratch;
  Scenario s = world_family("dense-cluttered").member(12345678901234567890ULL);
  write_world(scratch.file("w.txt"), s.world);
  const World r = read_world(scratch.file("w.txt"));
  ASSERT_TRUE(r.origin.has_value());
  EXPECT_EQ(r.origin->family, "dense-cluttered");
  EXPECT_EQ(r.origin->seed, 12345678901234567890ULL);
  World unreadable = r;
  unreadable.origin->family = "two words";
  EXPECT_THROW(write_world(scratch.file("w2.txt"), unreadable), std::invalid_argument);

  s.config.loops = 1;
  const std::string log = scratch.file("log");
  write_sim_log(log, simulate(s.world, s.config), s.config, s.world);
  const nlohmann::json params = nlohmann::json::parse(std::ifstream(log + "/params.json"));
  EXPECT_EQ(params.at("world").at("family"), "dense-cluttered");
  EXPECT_EQ(params.at("world").at("world_seed").get<std::uint64_t>(), 12345678901234567890ULL);
  EXPECT_NO_THROW(read_sim_log(log));
  nlohmann::json bad = params;
  bad["world"]["world_seed"] = -1;
  std::ofstream(log + "/params.json") << bad.dump();
  EXPECT_NE(input_error_at([&] { read_sim_log(log); }, log + "/params.json", 0).find("\"world\""), std::string::npos);
}

TEST(WorldFamily, BadFamilyLinesAreNamed) {
  const ScratchDir scratch;
  const std::string path = scratch.file("w.txt");
  const std::string good = "waypoint 0 0\nwaypoint 10 0\n";
  std::ofstream(path) << good << "family sparse\n";
  EXPECT_NE(input_error_at([&] { read_world(path); }, path, 3).find("family <name> <world seed>"), std::string::npos);
  std::ofstream(path) << good << "family sparse -1\n";
  EXPECT_NE(input_error_at([&] { read_world(path); }, path, 3).find("world seed"), std::string::npos);
  std::ofstream(path) << "family sparse 1\n" << good << "family dense 2\n";
  EXPECT_NE(input_error_at([&] { read_world(path); }, path, 4).find("duplicate family line (first on line 1)"),
            std::string::npos);
}

}  // namespace
}  // namespace slamkit
