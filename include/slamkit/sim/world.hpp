#pragma once
// A simulated world: the true landmark map and the route the simulated vehicle drives.
//
// World file format (plain text, one item per line, '#' starts a comment, blank lines ignored):
//
//   landmark <id> <x> <y>     a point landmark; id a unique integer >= 0, x and y in metres
//   waypoint <x> <y>          a point of the route, in driving order
//   route open|closed         optional, at most once; closed when absent
//   start <x> <y> <heading>   optional, at most once: the vehicle's start pose (heading in degrees);
//                             without it the vehicle starts at the first waypoint facing the second
//   family <name> <seed>      optional, at most once: the family and world seed the world was drawn
//                             from (random_world); a record only, the simulator does not read it
//
// Lines may be interleaved; only the order of the waypoint lines matters. A closed route ends where
// it began: after the last waypoint the vehicle heads back to the first. An open route ends at its
// last waypoint. At least two waypoints are required, and no waypoint may repeat the one before it.
// Every number must be finite, and every coordinate within +-kMaxAbsCoordinate (2e6 m).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

/// Where a world drawn from a family came from, so that a log or a world file says how to make it
/// again (simulate --family NAME --world-seed SEED).
struct WorldOrigin {
  std::string family;
  std::uint64_t seed = 0;
};

struct World {
  std::vector<Landmark> landmarks;  // covariance zero: this is the truth
  std::vector<Vector2> waypoints;   // driving order; the vehicle starts at the first, facing the second
  bool closed = true;               // false: the route ends at the last waypoint (see simulate())
  std::optional<Pose2> start;       // where the vehicle starts, if not at the first waypoint
  std::optional<WorldOrigin> origin;  // set by the world families (simulator.hpp), else empty
};

/// Parameters of a generated world: a rounded rectangle of width x height metres (corner radius a
/// quarter of the shorter side), its lower straight centred on the origin and driven
/// counter-clockwise starting at (0, 0) heading along +x, with landmarks scattered uniformly in the
/// band between band_inner and band_outer metres from the route, on both sides of it.
struct WorldGenOptions {
  double width = 120.0;  // m
  double height = 80.0;  // m
  int landmarks = 100;
  double band_inner = 4.0;         // m, no landmark closer to the route than this
  double band_outer = 20.0;        // m, nor farther than this
  double waypoint_spacing = 10.0;  // m, along the route (adjusted so the loop divides evenly)
  std::uint64_t seed = 20240521;
  /// No two landmarks closer than this [m]. When the band cannot hold `landmarks` at this spacing,
  /// generation starts at the spacing at which random placement fits them with ease (0.86 of the
  /// spacing at which it jams), and reduces it further, step by step, if they still do not fit.
  double min_spacing = 3.0;
};

/// The built-in world: generate_world with the default options, ~366 m around, 100 landmarks.
World default_world();

/// The loop-closure test bed: a 300 m x 200 m loop (generate_world's shape, ~910 m around) with
/// 150 landmarks, sparse enough that the vehicle sees about nine at a time (3 to 17), so that the pose
/// uncertainty of a filter grows markedly over the lap. The route is open: one lap and then ~80 m on
/// along the first straight, so that a single loop returns to the start, re-observes the first
/// landmarks (the loop closure) and goes on a little through the already mapped area.
World loop_closure_world();

/// The sparse test bed, after the reference simulator's example map: 35 landmarks scattered 4 to 25 m
/// beside an irregular ~640 m loop with turns of 45 to 135 degrees, the vehicle starting at the
/// origin 10 m before the first waypoint. With a 180 degree field of view the sensor sees about 1.4
/// landmarks per scan and none at all over some stretches, so dead reckoning drifts for tens of
/// metres between sightings and the return to the start is a real loop closure.
World sparse_world();

/// What generate_world did, for a caller that reports it, and its work, which grows in proportion
/// to the landmarks.
struct WorldGenReport {
  double spacing = 0.0;           // m, the distance every two landmarks keep at least
  std::uint64_t candidates = 0;   // points drawn in the band's bounding box
  std::uint64_t comparisons = 0;  // distances from a candidate to a placed landmark tested
};

/// The indoor test bed, after the MRCLAM logs: a 15 m x 8 m room centred on the origin with 15
/// landmarks, which a slow robot with a narrow camera (see the "room" scenario) drives to waypoints.
/// Three landmarks stand by the west wall, the others in the eastern half. The robot starts at
/// (-4, 0) facing the three, then spends two minutes up and down the western half, where its view
/// holds no landmark for spells of 20 to 40 s (MRCLAM Dataset6's robot 2 sees none for 48 s after its
/// first, Dataset1's robot 5 none for 39 s) and glimpses the eastern ones from 6-8 m, returns to the
/// first three and goes on to 30 waypoints drawn at random across the room, as the MRCLAM robots do.
/// So landmarks are first seen from afar after dead reckoning, with the heading off by tenths of a
/// radian, and later from close by.
World room_world();

/// Throws InputError when an option is out of range (non-positive size, empty band, ...).
World generate_world(const WorldGenOptions& options, WorldGenReport* report = nullptr);

/// A city: a square grid of `blocks` x `blocks` blocks of block_m (an even number of blocks), whose
/// streets (blocks + 1 each way) are lined on both sides with landmarks band_inner to band_outer
/// metres from their centre line (none nearer than band_inner to any street, none nearer than
/// min_spacing to another). The closed route drives every street once end to end: the east-west
/// ones in turn (east, one block north, west, ...), then the north-south ones in turn back to the
/// start, turning at the intersections; it crosses itself at every one of them, so loops of every
/// size from a block to the whole city close along it. The vehicle starts at the south-west corner,
/// (0, 0), facing east.
struct StreetGridOptions {
  int blocks = 10;
  double block_m = 300.0;
  int landmarks = 30'000;
  double band_inner = 4.0;   // m
  double band_outer = 12.0;  // m
  double min_spacing = 3.0;  // m
  std::uint64_t seed = 20261128;
};

/// The large-scale test bed: street_grid_world with the default options, a 3 km x 3 km city of 100
/// blocks, 30,000 landmarks and a 72 km route.
World city_world();

/// Throws InputError when an option is out of range or the bands cannot hold the landmarks at
/// their spacing.
World street_grid_world(const StreetGridOptions& options);

/// A random world after the sparse world's pattern, for families of worlds (simulator.hpp). The
/// route is a closed polygon of min_corners to max_corners straight legs round a centre, driven
/// counter-clockwise or clockwise, min_lap_m to max_lap_m long; concave corners make shapes other
/// than convex rings. Every leg is at least min_leg_m long, every corner turns by at most max_turn,
/// and legs that share no corner are at least min_leg_gap_m apart, so the route never crosses itself
/// and the reference vehicle (turning radius 8 m) reaches every corner. The vehicle starts at the
/// origin facing +x, in the middle of the leg from the last waypoint to the first, so each lap ends
/// by driving back through the start area. Landmarks: landmarks_per_km per kilometre of route, at
/// uniformly random places along it on a random side, band_inner to band_outer metres from every
/// leg and at least min_spacing apart.
struct RandomWorldOptions {
  double min_lap_m = 400.0;
  double max_lap_m = 1000.0;
  int min_corners = 5;
  int max_corners = 8;
  double min_leg_m = 40.0;
  double max_turn = 2.0 * kPi / 3.0;  // rad
  double min_leg_gap_m = 40.0;
  double landmarks_per_km = 55.0;  // the sparse world's 35 on 640 m
  double band_inner = 4.0;         // m
  double band_outer = 25.0;        // m
  double min_spacing = 8.0;        // m
};

/// The world of `seed`: the route from one random stream and the landmarks from another, so options
/// that differ only in their landmarks give the same route for a seed. Throws InputError when an
/// option is out of range or the band cannot hold the landmarks at their spacing.
World random_world(const RandomWorldOptions& options, std::uint64_t seed);

/// Reads a world file (format above). Throws InputError naming the file, the line and what was
/// expected.
World read_world(const std::string& path);

/// Writes `world` in the format above, numbers in their shortest exact form so that read_world
/// gives back the same values. Throws InputError if the file cannot be written, and
/// std::invalid_argument for an origin whose family name is not one word.
void write_world(const std::string& path, const World& world);

}  // namespace slamkit
