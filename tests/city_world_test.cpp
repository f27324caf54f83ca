// The street grid (street_grid_world, the city scenario): the large-scale test bed whose properties
// the information-form filters will be measured on, pinned down here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "slamkit/core/error.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace slamkit {
namespace {

// A fifteenth of the city's streets, with their density of landmarks: 1,800 on 4 km of street
// against 30,000 on 66 km.
constexpr StreetGridOptions kSmallCity{.blocks = 4, .block_m = 100.0, .landmarks = 1'800, .seed = 7};

// Distance from p to the nearest street centre line of a grid of `block`-metre blocks.
double distance_to_street(const Vector2& p, double block) {
  const auto off = [block](double v) { return std::abs(v - block * std::round(v / block)); };
  return std::min(off(p.x()), off(p.y()));
}

TEST(StreetGridWorld, LandmarksLineTheStreetsAtTheirSpacing) {
  const World w = street_grid_world(kSmallCity);
  ASSERT_EQ(w.landmarks.size(), 1'800U);
  for (std::size_t i = 0; i < w.landmarks.size(); ++i) {
    const Vector2 p = w.landmarks[i].position;
    EXPECT_EQ(w.landmarks[i].id, static_cast<int>(i));
    const double street = distance_to_street(p, kSmallCity.block_m);
    EXPECT_GE(street, kSmallCity.band_inner) << "landmark " << i << " stands in a street";
    EXPECT_LE(street, kSmallCity.band_outer + 1e-9) << "landmark " << i << " is off every street's band";
    for (std::size_t j = 0; j < i; ++j)
      ASSERT_GE((p - w.landmarks[j].position).norm(), kSmallCity.min_spacing) << i << " and " << j;
  }
}

// Every leg of the route is one block of one street, and every block of every street is driven:
// the east-west streets once each, the north-south ones once each, and the joins between rows again.
TEST(StreetGridWorld, RouteDrivesEveryBlockOfEveryStreetAndReturnsToTheStart) {
  const World w = street_grid_world(kSmallCity);
  EXPECT_TRUE(w.closed);
  ASSERT_FALSE(w.start.has_value()) << "starts at the first waypoint facing the second";
  EXPECT_EQ(w.waypoints.front(), Vector2(0.0, 0.0));
  EXPECT_EQ(w.waypoints[1], Vector2(kSmallCity.block_m, 0.0));
  std::map<std::pair<std::pair<double, double>, std::pair<double, double>>, int> driven;
  for (std::size_t i = 0; i < w.waypoints.size(); ++i) {
    const Vector2 a = w.waypoints[i], b = w.waypoints[(i + 1) % w.waypoints.size()];
    ASSERT_NEAR((b - a).norm(), kSmallCity.block_m, 1e-9) << "leg " << i;
    ASSERT_TRUE(a.x() == b.x() || a.y() == b.y()) << "leg " << i << " runs along a street";
    const Vector2 lo = a.x() + a.y() < b.x() + b.y() ? a : b, hi = lo == a ? b : a;
    ++driven[{{lo.x(), lo.y()}, {hi.x(), hi.y()}}];
  }
  const int n = kSmallCity.blocks;
  EXPECT_EQ(driven.size(), static_cast<std::size_t>(2 * n * (n + 1))) << "every block of every street";
  const double length = static_cast<double>(w.waypoints.size()) * kSmallCity.block_m;
  EXPECT_NEAR(length, 2.0 * ((n + 1) * n + n) * kSmallCity.block_m, 1e-9);
}

TEST(StreetGridWorld, SameSeedSameCityAndClearErrors) {
  const World a = street_grid_world(kSmallCity), b = street_grid_world(kSmallCity);
  ASSERT_EQ(a.landmarks.size(), b.landmarks.size());
  for (std::size_t i = 0; i < a.landmarks.size(); ++i) EXPECT_EQ(a.landmarks[i].position, b.landmarks[i].position);
  StreetGridOptions odd = kSmallCity;
  odd.blocks = 3;
  EXPECT_THROW(street_grid_world(odd), InputError) << "an odd grid's route would not end at its start";
  StreetGridOptions crowded = kSmallCity;
  crowded.landmarks = 20'000;
  EXPECT_THROW(street_grid_world(crowded), InputError);
  StreetGridOptions band_in_street = kSmallCity;
  band_in_street.band_inner = 60.0;
  EXPECT_THROW(street_grid_world(band_in_street), InputError);
}

// The vehicle keeps to the streets through every turn, and the city scenario's sensor sees about ten
// landmarks of the street ahead at a time.
TEST(StreetGridWorld, VehicleKeepsToTheStreetsAndSeesAboutTenAtATime) {
  Scenario city = scenario("city");
  EXPECT_EQ(city.world.landmarks.size(), 30'000U);
  EXPECT_EQ(city.config.loops, 1);
  city.world = street_grid_world(kSmallCity);
  const Dataset d = simulate(city.world, city.config);
  double worst = 0.0;
  for (const StampedPose& p : d.truth.poses) worst = std::max(worst, distance_to_street(p.pose.head<2>(), 100.0));
  EXPECT_LT(worst, kSmallCity.band_inner + 2.0) << "turns cut corners by a few metres at most";
  std::size_t scans = 0, observations = 0;
  std::set<int> seen;
  for (const Event& e : d.events)
    if (const auto* scan = std::get_if<ScanEvent>(&e)) {
      ++scans;
      observations += scan->observations.size();
      for (const Observation& o : scan->observations) seen.insert(o.id);
    }
  EXPECT_EQ(seen.size(), kSmallCity.landmarks) << "every landmark is passed";
  const double per_scan = static_cast<double>(observations) / static_cast<double>(scans);
  EXPECT_GT(per_scan, 8.0);
  EXPECT_LT(per_scan, 12.0);
}

}  // namespace
}  // namespace slamkit
