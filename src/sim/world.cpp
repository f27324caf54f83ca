#include "slamkit/sim/world.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <unordered_map>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/checked_integer.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/text_reader.hpp"

namespace slamkit {
namespace {

// Uniform on [0, 1) from the top 53 bits: unlike std::uniform_real_distribution its output is fixed
// by the standard engine alone, so a seed gives the same world with every standard library.
double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

// The route of a generated world: a rounded rectangle, lower straight centred on the origin, driven
// counter-clockwise from (0, 0).
class RoundedRectRoute {
 public:
  RoundedRectRoute(double width, double height)
      : half_w_(width / 2.0), half_h_(height / 2.0), radius_(std::min(width, height) / 4.0) {
    const double a = half_w_ - radius_, b = half_h_ - radius_, arc = radius_ * kPi / 2.0;
    pieces_ = {{{a, false},
                {arc, true},
                {2 * b, false},
                {arc, true},
                {2 * a, false},
                {arc, true},
                {2 * b, false},
                {arc, true},
                {a, false}}};
  }

  double length() const {
    double total = 0.0;
    for (const Piece& p : pieces_) total += p.length;
    return total;
  }

  // Walks the route like a turtle: straights keep the heading, corners turn left at the corner radius.
  Vector2 point_at(double s) const {
    Vector2 p = Vector2::Zero();
    double heading = 0.0;
    for (const Piece& piece : pieces_) {
      const double step = std::min(s, piece.length);
      if (piece.corner) {
        const double turned = heading + step / radius_;
        p += radius_ * Vector2(std::sin(turned) - std::sin(heading), std::cos(heading) - std::cos(turned));
        heading = turned;
      } else {
        p += step * Vector2(std::cos(heading), std::sin(heading));
      }
      s -= step;
      if (s <= 0.0) break;
    }
    return p;
  }

  // Unsigned distance to the route, from the signed distance of the rounded rectangle it encloses.
  double distance(const Vector2& p) const {
    const Vector2 q = (p - Vector2(0.0, half_h_)).cwiseAbs() - Vector2(half_w_ - radius_, half_h_ - radius_);
    const double outside = q.cwiseMax(0.0).norm();
    const double inside = std::min(std::max(q.x(), q.y()), 0.0);
    return std::abs(outside + inside - radius_);
  }

 private:
  struct Piece {
    double length;
    bool corner;
  };
  double half_w_, half_h_, radius_;
  std::array<Piece, 9> pieces_;
};

// A world is at most a thousand kilometres across (the plane of a range-bearing map; the grid keys
// below stay far inside 32 bits) and holds at most ten million landmarks (about a gigabyte of world
// and simulated observations).
constexpr double kMaxExtent = 1e6;
constexpr int kMaxLandmarks = 10'000'000;

void require(bool ok, const char* option, const char* expected, double found) {
  if (!ok)
    throw InputError(fmt::format("world generation: {} must be {}, found {}", option, expected, found));
}

void validate(const WorldGenOptions& o) {
  require(o.width > 0.0 && o.width <= kMaxExtent, "width", "a positive number of metres up to 1e6", o.width);
  require(o.height > 0.0 && o.height <= kMaxExtent, "height", "a positive number of metres up to 1e6", o.height);
  require(o.landmarks >= 0 && o.landmarks <= kMaxLandmarks, "landmarks", "from 0 to 1e7", o.landmarks);
  require(o.band_inner >= 0.0 && o.band_inner <= kMaxExtent, "band_inner", "a distance from 0 to 1e6", o.band_inner);
  require(o.band_outer > o.band_inner && o.band_outer <= kMaxExtent, "band_outer",
          "a distance greater than band_inner, up to 1e6", o.band_outer);
  require(std::isfinite(o.waypoint_spacing) && o.waypoint_spacing > 0.0, "waypoint_spacing",
          "a positive number of metres", o.waypoint_spacing);
  // With a centimetre at least, the spacing grid's cells number below 2^31 across a valid world.
  require(o.min_spacing >= 0.01 && o.min_spacing <= kMaxExtent, "min_spacing", "a distance from 0.01 to 1e6 m",
          o.min_spacing);
}

// Buckets of already placed landmarks, so that the spacing test looks at a handful of neighbours
// instead of all of them. Hashed cells keep memory proportional to the landmarks, not the area.
class SpacingGrid {
 public:
  explicit SpacingGrid(double cell) : cell_(cell) {}

  // Valid for any spacing up to the cell size: closer points are then always in adjacent cells.
  bool has_neighbour_within(const Vector2& p, double spacing, const std::vector<Landmark>& placed) const {
    const std::int64_t cx = cell_of(p.x()), cy = cell_of(p.y());
    for (std::int64_t ix = cx - 1; ix <= cx + 1; ++ix) {
      for (std::int64_t iy = cy - 1; iy <= cy + 1; ++iy) {
        const auto it = cells_.find(key(static_cast<std::int32_t>(ix), static_cast<std::int32_t>(iy)));
        if (it == cells_.end()) continue;
        for (const int i : it->second)
          if ((placed[i].position - p).squaredNorm() < spacing * spacing) return true;
      }
    }
    return false;
  }

  void add(const Vector2& p, int index) { cells_[key(cell_of(p.x()), cell_of(p.y()))].push_back(index); }

 private:
  std::int32_t cell_of(double v) const { return checked_integer<std::int32_t>(std::floor(v / cell_), "a grid cell"); }
  static std::uint64_t key(std::int32_t ix, std::int32_t iy) {
    return static_cast<std::uint64_t>(static_cast<std::uint32_t>(ix)) << 32 | static_cast<std::uint32_t>(iy);
  }

  double cell_;
  std::unordered_map<std::uint64_t, std::vector<int>> cells_;
};

}  // namespace

World default_world() { return generate_world(WorldGenOptions{}); }

World loop_closure_world() {
  WorldGenOptions o;
  o.width = 300.0;
  o.height = 200.0;
  o.landmarks = 150;
  o.band_inner = 4.0;
  o.band_outer = 20.0;
  o.seed = 20240607;
  World world = generate_world(o);
  // Past the start along the first straight; waypoints are ~10 m apart and the straight runs 100 m
  // from the start to its corner, so the vehicle stops well before turning again.
  constexpr std::size_t kWaypointsPastStart = 8;
  const std::vector<Vector2> lap = world.waypoints;
  world.waypoints.insert(world.waypoints.end(), lap.begin(),
                         lap.begin() + static_cast<std::ptrdiff_t>(kWaypointsPastStart + 1));
  world.closed = false;
  return world;
}

World sparse_world() {
  // An irregular closed loop of straights with turns of 45 to 135 degrees, ~640 m round. The first
  // waypoint is 10 m ahead of the start, so each lap ends by driving back through the start area.
  World world;
  world.waypoints = {{10.0, 0.0},    {120.0, 0.0},   {160.0, 40.0}, {160.0, 120.0}, {100.0, 150.0},
                     {40.0, 110.0},  {-20.0, 140.0}, {-60.0, 90.0}, {-40.0, 30.0}};
  world.start = Pose2::Zero();
  std::vector<double> cumulative{0.0};
  const std::size_t n = world.waypoints.size();
  for (std::size_t i = 0; i < n; ++i)
    cumulative.push_back(cumulative.back() + (world.waypoints[(i + 1) % n] - world.waypoints[i]).norm());
  auto distance_to_route = [&](const Vector2& p) {
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < n; ++i) {
      const Vector2 a = world.waypoints[i], ab = world.waypoints[(i + 1) % n] - a;
      const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
      d = std::min(d, (a + t * ab - p).norm());
    }
    return d;
  };
  // Landmarks at uniformly random places along the route, on a random side, 4 to 25 m off it: gaps
  // of 50 m and more without a landmark occur, as in the reference simulator's sparse example map.
  constexpr int kLandmarks = 35;
  constexpr double kMinOffset = 4.0, kMaxOffset = 25.0, kMinSpacing = 8.0;
  std::mt19937_64 rng(20241123);
  while (static_cast<int>(world.landmarks.size()) < kLandmarks) {
    const double s = uniform01(rng) * cumulative.back();
    const std::size_t i = static_cast<std::size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), s) - cumulative.begin() - 1);
    const Vector2 a = world.waypoints[i], dir = (world.waypoints[(i + 1) % n] - a).normalized();
    const double side = uniform01(rng) < 0.5 ? 1.0 : -1.0;
    const double offset = kMinOffset + (kMaxOffset - kMinOffset) * uniform01(rng);
    const Vector2 p = a + (s - cumulative[i]) * dir + side * offset * Vector2(-dir.y(), dir.x());
    if (distance_to_route(p) < kMinOffset) continue;  // too close to another leg of the route
    const bool crowded = std::any_of(world.landmarks.begin(), world.landmarks.end(), [&](const Landmark& l) {
      return (l.position - p).norm() < kMinSpacing;
    });
    if (crowded) continue;
    world.landmarks.push_back(Landmark{static_cast<int>(world.landmarks.size()), p, Matrix2::Zero()});
  }
  return world;
}

World room_world() {
  World world;
  world.closed = false;
  world.start = Pose2(-4.0, 0.0, kPi);
  world.landmarks = {{6, {-7.2, 1.0}, Matrix2::Zero()}, {7, {-7.2, -1.2}, Matrix2::Zero()},
                     {8, {-6.8, 2.8}, Matrix2::Zero()}};
  std::mt19937_64 rng(20261126);
  constexpr double kHalfWidth = 7.5, kHalfHeight = 4.0, kMinSpacing = 1.5, kClearance = 0.6;
  while (world.landmarks.size() < 15) {
    const Vector2 p(1.0 + (kHalfWidth - 1.3) * uniform01(rng), (kHalfHeight - 0.4) * (2.0 * uniform01(rng) - 1.0));
    const bool crowded = std::any_of(world.landmarks.begin(), world.landmarks.end(),
                                     [&](const Landmark& l) { return (l.position - p).norm() < kMinSpacing; });
    if (!crowded) world.landmarks.push_back({static_cast<int>(world.landmarks.size()) + 6, p, Matrix2::Zero()});
  }
  // The blind spell in the west, the crossing, the return to the first landmarks.
  world.waypoints = {{-5.5, 0.0}, {-5.0, 3.5}, {-3.0, -3.5}, {-1.0, 3.5}, {-2.0, 0.0}, {4.0, 0.0}, {-5.0, 0.0}};
  while (world.waypoints.size() < 37) {
    const Vector2 p((kHalfWidth - 1.0) * (2.0 * uniform01(rng) - 1.0),
                    (kHalfHeight - 1.0) * (2.0 * uniform01(rng) - 1.0));
    const bool blocked = std::any_of(world.landmarks.begin(), world.landmarks.end(),
                                     [&](const Landmark& l) { return (l.position - p).norm() < kClearance; });
    if (!blocked && (p - world.waypoints.back()).norm() >= 2.0) world.waypoints.push_back(p);
  }
  return world;
}

World generate_world(const WorldGenOptions& o) {
  validate(o);
  const RoundedRectRoute route(o.width, o.height);
  World world;

  const double length = route.length();
  const long n_waypoints = std::max(4L, std::lround(length / o.waypoint_spacing));
  world.waypoints.reserve(static_cast<std::size_t>(n_waypoints));
  for (long k = 0; k < n_waypoints; ++k)
    world.waypoints.push_back(
        route.point_at(length * static_cast<double>(k) / static_cast<double>(n_waypoints)));

  // Rejection sampling from the bounding box of the band keeps the density uniform over the band.
  const double x0 = -o.width / 2.0 - o.band_outer, x1 = o.width / 2.0 + o.band_outer;
  const double y0 = -o.band_outer, y1 = o.height + o.band_outer;
  // Past this many spacing rejections in a row the band is close to full at the current spacing;
  // a band with room left essentially never produces such a run.
  constexpr int kPatience = 1000;
  std::mt19937_64 rng(o.seed);
  SpacingGrid grid(o.min_spacing);
  double spacing = o.min_spacing;
  int rejected_in_a_row = 0;
  // A band that covers a fraction f of the box takes 1/f samples per landmark; past this many in a
  // row outside it (f below about 1e-6) it is too thin to fill in any reasonable time.
  constexpr long kMaxOutsideBand = 20'000'000;
  long outside_band_in_a_row = 0;
  world.landmarks.reserve(static_cast<std::size_t>(o.landmarks));
  while (world.landmarks.size() < static_cast<std::size_t>(o.landmarks)) {
    // The two draws in a fixed order (the order of a call's arguments is unspecified: gcc and clang
    // differ, and the worlds with them); y first, the order gcc gave the existing worlds.
    const double uy = uniform01(rng);
    const double ux = uniform01(rng);
    const Vector2 p(x0 + (x1 - x0) * ux, y0 + (y1 - y0) * uy);
    const double d = route.distance(p);
    if (d < o.band_inner || d > o.band_outer) {
      if (++outside_band_in_a_row == kMaxOutsideBand)
        throw InputError(fmt::format(
            "world generation: the band from {} to {} m of the route is too thin for its {:.0f} x {:.0f} m "
            "bounding box: {} samples in a row fell outside it; widen it (band_outer - band_inner)",
            o.band_inner, o.band_outer, x1 - x0, y1 - y0, kMaxOutsideBand));
      continue;
    }
    outside_band_in_a_row = 0;
    if (grid.has_neighbour_within(p, spacing, world.landmarks)) {
      if (++rejected_in_a_row == kPatience) {
        spacing *= 0.9;
        rejected_in_a_row = 0;
      }
      continue;
    }
    rejected_in_a_row = 0;
    const int id = static_cast<int>(world.landmarks.size());
    grid.add(p, id);
    world.landmarks.push_back(Landmark{id, p, Matrix2::Zero()});
  }
  return world;
}

// A coordinate of a world file, in metres: finite and inside the largest world (see kMaxExtent),
// with room for the band around a route.
double coordinate(const TextReader& in, std::size_t field, const char* what) {
  const double v = in.number(field, what);
  if (std::abs(v) > 2.0 * kMaxExtent) in.fail(fmt::format("expected {} within +-2e6 m, found {}", what, v));
  return v;
}

World read_world(const std::string& path) {
  TextReader in(path);
  World world;
  std::unordered_map<long, std::size_t> line_of_id;
  std::size_t route_line = 0, start_line = 0;
  while (in.next()) {
    const std::string_view keyword = in.field(0);
    if (keyword == "landmark") {
      in.expect_fields(4, "landmark <id> <x> <y>");
      const long id = in.integer(1, "the landmark id");
      if (id < 0 || id > INT_MAX)
        in.fail(fmt::format("expected a landmark id from 0 to {}, found {}", INT_MAX, id));
      if (const auto [it, fresh] = line_of_id.emplace(id, in.line_number()); !fresh)
        in.fail(fmt::format("duplicate landmark id {} (first defined on line {})", id, it->second));
      const Vector2 p(coordinate(in, 2, "landmark x"), coordinate(in, 3, "landmark y"));
      world.landmarks.push_back(Landmark{static_cast<int>(id), p, Matrix2::Zero()});
    } else if (keyword == "waypoint") {
      in.expect_fields(3, "waypoint <x> <y>");
      const Vector2 p(coordinate(in, 1, "waypoint x"), coordinate(in, 2, "waypoint y"));
      if (!world.waypoints.empty() && p == world.waypoints.back())
        in.fail("waypoint repeats the previous one; expected a distinct point");
      world.waypoints.push_back(p);
    } else if (keyword == "route") {
      in.expect_fields(2, "route open|closed");
      if (route_line != 0)
        in.fail(fmt::format("duplicate route line (first on line {}); expected at most one", route_line));
      route_line = in.line_number();
      const std::string_view kind = in.field(1);
      if (kind != "open" && kind != "closed")
        in.fail(fmt::format("expected 'route open' or 'route closed', found 'route {}'", kind));
      world.closed = kind == "closed";
    } else if (keyword == "start") {
      in.expect_fields(4, "start <x> <y> <heading_deg>");
      if (start_line != 0)
        in.fail(fmt::format("duplicate start line (first on line {}); expected at most one", start_line));
      start_line = in.line_number();
      world.start = Pose2(coordinate(in, 1, "start x"), coordinate(in, 2, "start y"),
                          wrap_angle(deg2rad(in.number(3, "start heading in degrees"))));
    } else {
      in.fail(fmt::format("unknown keyword '{}'; expected 'landmark', 'waypoint', 'route' or 'start'", keyword));
    }
  }
  if (world.waypoints.size() < 2)
    throw InputError(path, 0, fmt::format("expected at least 2 waypoints, found {}", world.waypoints.size()));
  return world;
}

void write_world(const std::string& path, const World& world) {
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  fmt::format_to(it,
                 "# slamkit world\n"
                 "# landmark <id> <x> <y>   point landmark, metres\n"
                 "# waypoint <x> <y>        route point, metres, in driving order\n"
                 "# route open|closed       closed: back to the first waypoint at the end\n"
                 "# start <x> <y> <deg>     start pose (else at the first waypoint, facing the second)\n"
                 "route {}\n",
                 world.closed ? "closed" : "open");
  if (world.start)
    fmt::format_to(it, "start {} {} {}\n", world.start->x(), world.start->y(), rad2deg((*world.start)[2]));
  for (const Landmark& l : world.landmarks)
    fmt::format_to(it, "landmark {} {} {}\n", l.id, l.position.x(), l.position.y());
  for (const Vector2& w : world.waypoints) fmt::format_to(it, "waypoint {} {}\n", w.x(), w.y());
  write_file_atomically(path, std::string_view(out.data(), out.size()));
}

}  // namespace slamkit
