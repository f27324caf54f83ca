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
//
// Lines may be interleaved; only the order of the waypoint lines matters. A closed route ends where
// it began: after the last waypoint the vehicle heads back to the first. An open route ends at its
// last waypoint. At least two waypoints are required, and no waypoint may repeat the one before it.
// Every number must be finite.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "slamkit/core/types.hpp"

namespace slamkit {

struct World {
  std::vector<Landmark> landmarks;  // covariance zero: this is the truth
  std::vector<Vector2> waypoints;   // driving order; the vehicle starts at the first, facing the second
  bool closed = true;               // false: the route ends at the last waypoint (see simulate())
  std::optional<Pose2> start;       // where the vehicle starts, if not at the first waypoint
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
  /// the spacing is reduced step by step until they fit.
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
World generate_world(const WorldGenOptions& options);

/// Reads a world file (format above). Throws InputError naming the file, the line and what was
/// expected.
World read_world(const std::string& path);

/// Writes `world` in the format above, numbers in their shortest exact form so that read_world
/// gives back the same values. Throws InputError if the file cannot be written.
void write_world(const std::string& path, const World& world);

}  // namespace slamkit
