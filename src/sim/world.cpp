#include "slamkit/sim/world.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <climits>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/checked_integer.hpp"
#include "slamkit/core/coordinates.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/text_reader.hpp"
#include "slamkit/core/random_draws.hpp"

namespace slamkit {
namespace {

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
// A generated world reaches a band's width beyond its extent, and must read back as a world file.
static_assert(2 * kMaxExtent <= kMaxAbsCoordinate);

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

// Distance from p to the segment from a to b.
double distance_to_segment(const Vector2& p, const Vector2& a, const Vector2& b) {
  const Vector2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

// The closed route through `corners` (from the last back to the first).
double distance_to_closed_route(const std::vector<Vector2>& corners, const Vector2& p) {
  double d = std::numeric_limits<double>::infinity();
  const std::size_t n = corners.size();
  for (std::size_t i = 0; i < n; ++i) d = std::min(d, distance_to_segment(p, corners[i], corners[(i + 1) % n]));
  return d;
}

double closed_route_length(const std::vector<Vector2>& corners) {
  double length = 0.0;
  for (std::size_t i = 0; i < corners.size(); ++i) length += (corners[(i + 1) % corners.size()] - corners[i]).norm();
  return length;
}

// Where landmarks may lie beside a route: from `inner` to `outer` metres off it, `spacing` apart.
struct Band {
  double inner, outer, spacing;
};

// Random placement gives up after this many candidates in a row found no room: far beyond what a
// band with room left rejects in a row (at most 20 over 5,000 dense worlds).
constexpr int kMaxRejectedInARow = 10'000;

// Landmarks at uniformly random places along the closed route through `corners`, on a random side,
// a uniformly random distance off their leg, kept if no other leg is nearer than band.inner and no
// landmark nearer than band.spacing: stretches of 50 m and more without a landmark occur, as in the
// reference simulator's sparse example map.
std::vector<Landmark> scatter_beside_route(const std::vector<Vector2>& corners, int count, const Band& band,
                                           std::mt19937_64& rng) {
  std::vector<double> cumulative{0.0};
  const std::size_t n = corners.size();
  for (std::size_t i = 0; i < n; ++i) cumulative.push_back(cumulative.back() + (corners[(i + 1) % n] - corners[i]).norm());
  int rejected_in_a_row = 0;
  std::vector<Landmark> landmarks;
  while (static_cast<int>(landmarks.size()) < count) {
    if (rejected_in_a_row == kMaxRejectedInARow)
      throw InputError(fmt::format(
          "world generation: the band from {} to {} m beside a {:.0f} m route holds only {} of {} landmarks "
          "{} m apart; lower the density or the spacing",
          band.inner, band.outer, cumulative.back(), landmarks.size(), count, band.spacing));
    const double s = uniform01(rng) * cumulative.back();
    const std::size_t i = static_cast<std::size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), s) - cumulative.begin() - 1);
    const Vector2 a = corners[i], dir = (corners[(i + 1) % n] - a).normalized();
    const double side = uniform01(rng) < 0.5 ? 1.0 : -1.0;
    const double offset = band.inner + (band.outer - band.inner) * uniform01(rng);
    const Vector2 p = a + (s - cumulative[i]) * dir + side * offset * Vector2(-dir.y(), dir.x());
    const bool rejected = distance_to_closed_route(corners, p) < band.inner ||
                          std::any_of(landmarks.begin(), landmarks.end(), [&](const Landmark& l) {
                            return (l.position - p).norm() < band.spacing;
                          });
    if (rejected) {
      ++rejected_in_a_row;
      continue;
    }
    rejected_in_a_row = 0;
    landmarks.push_back(Landmark{static_cast<int>(landmarks.size()), p, Matrix2::Zero()});
  }
  return landmarks;
}

void validate(const RandomWorldOptions& o) {
  require(o.min_lap_m > 0.0 && o.min_lap_m <= kMaxExtent, "min_lap_m", "a positive length up to 1e6 m", o.min_lap_m);
  require(o.max_lap_m >= o.min_lap_m && o.max_lap_m <= kMaxExtent, "max_lap_m", "from min_lap_m to 1e6 m",
          o.max_lap_m);
  // With fewer than four corners the jittered corner angles below could leave a gap of more than a
  // half turn, and the polygon would no longer wind once round its centre.
  require(o.min_corners >= 4, "min_corners", "at least 4", o.min_corners);
  require(o.max_corners >= o.min_corners && o.max_corners <= 64, "max_corners", "from min_corners to 64",
          o.max_corners);
  require(o.min_leg_m > 0.0 && o.min_leg_m <= o.max_lap_m / o.max_corners, "min_leg_m",
          "positive, and at most max_lap_m / max_corners", o.min_leg_m);
  require(o.max_turn > 0.0 && o.max_turn < kPi, "max_turn", "an angle in (0, pi) rad", o.max_turn);
  require(o.min_leg_gap_m >= 0.0 && o.min_leg_gap_m <= o.min_leg_m, "min_leg_gap_m", "from 0 to min_leg_m",
          o.min_leg_gap_m);
  require(o.landmarks_per_km >= 0.0 && o.landmarks_per_km * o.max_lap_m / 1000.0 <= kMaxLandmarks,
          "landmarks_per_km", "at least 0, and at most 1e7 landmarks on the longest lap", o.landmarks_per_km);
  require(o.band_inner >= 0.0 && o.band_inner <= kMaxExtent, "band_inner", "a distance from 0 to 1e6", o.band_inner);
  require(o.band_outer > o.band_inner && o.band_outer <= kMaxExtent, "band_outer",
          "a distance greater than band_inner, up to 1e6", o.band_outer);
  require(o.min_spacing > 0.0 && o.min_spacing <= kMaxExtent, "min_spacing", "a positive distance up to 1e6",
          o.min_spacing);
}

// Whether a closed polygon keeps the rules of RandomWorldOptions: legs long enough, turns within
// max_turn, and legs that share no corner apart. Its legs do not cross (see random_route), so the
// distance between two of them is that of an end of one to the other.
bool drivable(const std::vector<Vector2>& p, const RandomWorldOptions& o) {
  const std::size_t n = p.size();
  const auto leg = [&](std::size_t i) { return p[(i + 1) % n] - p[i]; };
  for (std::size_t i = 0; i < n; ++i) {
    const Vector2 in = leg((i + n - 1) % n), out = leg(i);
    if (out.norm() < o.min_leg_m) return false;
    if (std::abs(wrap_angle(std::atan2(out.y(), out.x()) - std::atan2(in.y(), in.x()))) > o.max_turn) return false;
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // the last leg ends where the first begins
      const Vector2 a0 = p[i], a1 = p[(i + 1) % n], b0 = p[j], b1 = p[(j + 1) % n];
      const double gap = std::min({distance_to_segment(a0, b0, b1), distance_to_segment(a1, b0, b1),
                                   distance_to_segment(b0, a0, a1), distance_to_segment(b1, a0, a1)});
      if (gap < o.min_leg_gap_m) return false;
    }
  }
  return true;
}

// A random polygon that winds once round the origin: corners at jittered, increasing angles (each
// within 0.3 of a step of its place, so consecutive ones stay less than a half turn apart and the
// legs cannot cross) and random radii from 0.35 of the largest to the largest, scaled to a random lap
// length. Drawn again until it keeps the rules; the draws of a seed are fixed, so is its route.
std::vector<Vector2> random_route(const RandomWorldOptions& o, std::mt19937_64& rng) {
  // The families' options take at most 5 draws over 5,000 seeds; this many means the rules cannot be met.
  constexpr int kMaxDraws = 10'000;
  for (int draw = 0; draw < kMaxDraws; ++draw) {
    const double lap = o.min_lap_m + (o.max_lap_m - o.min_lap_m) * uniform01(rng);
    const int n = o.min_corners + static_cast<int>(uniform01(rng) * (o.max_corners - o.min_corners + 1));
    const bool clockwise = uniform01(rng) < 0.5;
    const double step = 2.0 * kPi / n;
    std::vector<Vector2> p;
    for (int k = 0; k < n; ++k) {
      const double angle = step * (k + 0.6 * (uniform01(rng) - 0.5));
      const double radius = 0.35 + 0.65 * uniform01(rng);
      p.emplace_back(radius * std::cos(angle), radius * std::sin(angle));
    }
    if (clockwise) std::reverse(p.begin(), p.end());
    const double scale = lap / closed_route_length(p);
    for (Vector2& corner : p) corner *= scale;
    if (drivable(p, o)) return p;
  }
  throw InputError(fmt::format(
      "world generation: no route of {} to {} corners and {} to {} m met the rules (legs >= {} m, turns <= {:.0f} "
      "deg, legs {} m apart) in {} draws; relax them",
      o.min_corners, o.max_corners, o.min_lap_m, o.max_lap_m, o.min_leg_m, rad2deg(o.max_turn), o.min_leg_gap_m,
      kMaxDraws));
}

// Buckets of already placed landmarks, so that the spacing test looks at a handful of neighbours
// instead of all of them. Hashed cells keep memory proportional to the landmarks, not the area; each
// cell is a list threaded through the landmarks (its first in the map, the rest by `next_`).
class SpacingGrid {
 public:
  explicit SpacingGrid(double cell) : cell_(cell) {}

  // Valid for any spacing up to the cell size: closer points are then always in adjacent cells.
  // Counts the distances it tests in `comparisons`.
  bool has_neighbour_within(const Vector2& p, double spacing, const std::vector<Landmark>& placed,
                            std::uint64_t& comparisons) const {
    const std::int64_t cx = cell_of(p.x()), cy = cell_of(p.y());
    for (std::int64_t ix = cx - 1; ix <= cx + 1; ++ix) {
      for (std::int64_t iy = cy - 1; iy <= cy + 1; ++iy) {
        const auto it = first_.find(key(static_cast<std::int32_t>(ix), static_cast<std::int32_t>(iy)));
        if (it == first_.end()) continue;
        for (int i = it->second; i >= 0; i = next_[static_cast<std::size_t>(i)]) {
          ++comparisons;
          if ((placed[static_cast<std::size_t>(i)].position - p).squaredNorm() < spacing * spacing) return true;
        }
      }
    }
    return false;
  }

  /// Adds placed landmark `index` (the next one: indices come in order).
  void add(const Vector2& p, int index) {
    const auto [it, fresh] = first_.try_emplace(key(cell_of(p.x()), cell_of(p.y())), index);
    next_.push_back(fresh ? -1 : std::exchange(it->second, index));
  }

  /// Once the spacing has shrunk to half the cells or less, rebuilds them at the spacing: with cells
  /// much wider than it, a full band puts ever more landmarks in each cell, and the test, which
  /// looks at every landmark of nine cells, grows with their number (quadratic generation).
  void fit(double spacing, const std::vector<Landmark>& placed) {
    if (spacing > 0.5 * cell_) return;
    cell_ = spacing;
    first_.clear();
    next_.clear();
    for (std::size_t i = 0; i < placed.size(); ++i) add(placed[i].position, static_cast<int>(i));
  }

 private:
  std::int32_t cell_of(double v) const { return checked_integer<std::int32_t>(std::floor(v / cell_), "a grid cell"); }
  static std::uint64_t key(std::int32_t ix, std::int32_t iy) {
    return static_cast<std::uint64_t>(static_cast<std::uint32_t>(ix)) << 32 | static_cast<std::uint32_t>(iy);
  }

  double cell_;
  std::unordered_map<std::uint64_t, int> first_;
  std::vector<int> next_;
};

// Random placement of points at least s apart jams when disks of diameter s about them cover 0.547 of
// the plane (random sequential adsorption; Feder, J. Theor. Biol. 87, 1980). Near that, most samples
// are rejected; at kEasyCover, a sample still finds room often.
constexpr double kJammedCover = 0.547;
constexpr double kEasyCover = 0.40;

/// The spacing at which `count` disks cover `cover` of `area`.
double spacing_for(double cover, double area, int count) {
  return std::sqrt(cover * 4.0 * area / (kPi * static_cast<double>(count)));
}

/// The band's area: its bounding box's, times the share of a lattice of points over the box that
/// lie in the band (0 for a band thinner than the lattice's pitch).
double band_area(const RoundedRectRoute& route, const WorldGenOptions& o, const Vector2& lo, const Vector2& hi) {
  constexpr int kLattice = 256;
  long inside = 0;
  for (int i = 0; i < kLattice; ++i)
    for (int j = 0; j < kLattice; ++j) {
      const Vector2 p = lo + (hi - lo).cwiseProduct(Vector2(i + 0.5, j + 0.5) / kLattice);
      const double d = route.distance(p);
      inside += d >= o.band_inner && d <= o.band_outer;
    }
  return (hi - lo).prod() * static_cast<double>(inside) / (kLattice * kLattice);
}

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
  std::mt19937_64 rng(20241123);
  world.landmarks = scatter_beside_route(world.waypoints, 35, Band{4.0, 25.0, 8.0}, rng);
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

World city_world() { return street_grid_world(StreetGridOptions{}); }

World street_grid_world(const StreetGridOptions& o) {
  // An even number, so that the north-south streets, driven in turn from the east, end at the start.
  require(o.blocks >= 2 && o.blocks <= 1000 && o.blocks % 2 == 0, "blocks", "an even number from 2 to 1000",
          o.blocks);
  require(o.block_m > 0.0 && o.blocks * o.block_m <= kMaxExtent, "block_m",
          "a positive number of metres, the city up to 1e6 m across", o.block_m);
  require(o.landmarks >= 0 && o.landmarks <= kMaxLandmarks, "landmarks", "from 0 to 1e7", o.landmarks);
  require(o.band_inner >= 0.0 && 2.0 * o.band_inner < o.block_m, "band_inner",
          "a distance from 0 to under half a block", o.band_inner);
  require(o.band_outer > o.band_inner && o.band_outer <= kMaxExtent, "band_outer",
          "a distance greater than band_inner, up to 1e6", o.band_outer);
  require(o.min_spacing >= 0.01 && o.min_spacing <= kMaxExtent, "min_spacing", "a distance from 0.01 to 1e6 m",
          o.min_spacing);
  const int n = o.blocks;
  const double block = o.block_m, side = n * block;
  World world;
  // East-west streets in turn, joined by one block of the north-south street at their end, to the
  // north-east corner; then the north-south streets in turn from the east, back to the start.
  for (int j = 0; j <= n; ++j)
    for (int k = 0; k <= n; ++k) world.waypoints.emplace_back((j % 2 == 0 ? k : n - k) * block, j * block);
  for (int i = 0; i <= n; ++i)
    for (int k = 0; k <= n; ++k) {
      const Vector2 p((n - i) * block, (i % 2 == 0 ? n - k : k) * block);
      if (p != world.waypoints.back()) world.waypoints.push_back(p);
    }
  // The route ends where it began: the closing leg returns to the first waypoint.
  while (world.waypoints.back() == world.waypoints.front()) world.waypoints.pop_back();

  std::mt19937_64 rng(o.seed);
  const auto off_street = [&](double v) { return std::abs(v - block * std::round(v / block)) >= o.band_inner; };
  SpacingGrid spacing(o.min_spacing);
  std::uint64_t comparisons = 0;
  int rejected_in_a_row = 0;
  while (static_cast<int>(world.landmarks.size()) < o.landmarks) {
    if (rejected_in_a_row == kMaxRejectedInARow)
      throw InputError(fmt::format("world generation: the streets' bands from {} to {} m hold only {} of {} "
                                   "landmarks {} m apart; lower the number or the spacing",
                                   o.band_inner, o.band_outer, world.landmarks.size(), o.landmarks, o.min_spacing));
    const auto street = static_cast<int>(uniform01(rng) * 2 * (n + 1));
    const double along = uniform01(rng) * side;
    const double across = block * (street % (n + 1)) + (uniform01(rng) < 0.5 ? 1.0 : -1.0) *
                                                           (o.band_inner + (o.band_outer - o.band_inner) * uniform01(rng));
    const Vector2 p = street <= n ? Vector2(along, across) : Vector2(across, along);
    if (!off_street(p.x()) || !off_street(p.y()) || spacing.has_neighbour_within(p, o.min_spacing, world.landmarks, comparisons)) {
      ++rejected_in_a_row;
      continue;
    }
    rejected_in_a_row = 0;
    const int id = static_cast<int>(world.landmarks.size());
    spacing.add(p, id);
    world.landmarks.push_back(Landmark{id, p, Matrix2::Zero()});
  }
  return world;
}

World random_world(const RandomWorldOptions& o, std::uint64_t seed) {
  validate(o);
  // Two streams, so that the landmark options leave a seed's route unchanged.
  std::mt19937_64 route_rng(seed);
  std::mt19937_64 landmark_rng(seed ^ 0x9e3779b97f4a7c15ULL);
  const std::vector<Vector2> corners = random_route(o, route_rng);

  // In the frame of the start, the middle of the first leg facing along it; the lap then runs from
  // the end of that leg round to its beginning.
  const Vector2 start = 0.5 * (corners[0] + corners[1]);
  const Vector2 along = (corners[1] - corners[0]).normalized();
  World world;
  world.start = Pose2::Zero();
  for (std::size_t k = 1; k <= corners.size(); ++k) {
    const Vector2 d = corners[k % corners.size()] - start;
    world.waypoints.emplace_back(along.dot(d), along.x() * d.y() - along.y() * d.x());
  }
  const double count = std::round(o.landmarks_per_km * closed_route_length(world.waypoints) / 1000.0);
  world.landmarks = scatter_beside_route(world.waypoints, static_cast<int>(count),
                                         Band{o.band_inner, o.band_outer, o.min_spacing}, landmark_rng);
  return world;
}

World generate_world(const WorldGenOptions& o, WorldGenReport* report) {
  validate(o);
  WorldGenReport done;
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
  // A band that cannot hold the landmarks at min_spacing would be filled until it jams at one
  // spacing after another, each 10% below the last: for a million landmarks in the default band,
  // twenty-odd times over. Starting at a spacing it holds them at with ease fills it once.
  double spacing = o.min_spacing;
  if (spacing_for(kJammedCover, (x1 - x0) * (y1 - y0), o.landmarks) < o.min_spacing) {  // even the box is too small
    const double area = band_area(route, o, Vector2(x0, y0), Vector2(x1, y1));
    if (area > 0.0 && spacing_for(kJammedCover, area, o.landmarks) < o.min_spacing)
      spacing = spacing_for(kEasyCover, area, o.landmarks);
  }
  SpacingGrid grid(spacing);
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
    ++done.candidates;
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
    if (grid.has_neighbour_within(p, spacing, world.landmarks, done.comparisons)) {
      if (++rejected_in_a_row == kPatience) {
        spacing *= 0.9;
        grid.fit(spacing, world.landmarks);
        rejected_in_a_row = 0;
      }
      continue;
    }
    rejected_in_a_row = 0;
    const int id = static_cast<int>(world.landmarks.size());
    grid.add(p, id);
    world.landmarks.push_back(Landmark{id, p, Matrix2::Zero()});
  }
  done.spacing = spacing;
  if (report != nullptr) *report = done;
  return world;
}

World read_world(const std::string& path) {
  TextReader in(path);
  World world;
  std::unordered_map<long, std::size_t> line_of_id;
  std::size_t route_line = 0, start_line = 0, family_line = 0;
  while (in.next()) {
    const std::string_view keyword = in.field(0);
    if (keyword == "landmark") {
      in.expect_fields(4, "landmark <id> <x> <y>");
      const long id = in.integer(1, "the landmark id");
      if (id < 0 || id > INT_MAX)
        in.fail(fmt::format("expected a landmark id from 0 to {}, found {}", INT_MAX, id));
      if (const auto [it, fresh] = line_of_id.emplace(id, in.line_number()); !fresh)
        in.fail(fmt::format("duplicate landmark id {} (first defined on line {})", id, it->second));
      const Vector2 p(in.coordinate(2, "landmark x"), in.coordinate(3, "landmark y"));
      world.landmarks.push_back(Landmark{static_cast<int>(id), p, Matrix2::Zero()});
    } else if (keyword == "waypoint") {
      in.expect_fields(3, "waypoint <x> <y>");
      const Vector2 p(in.coordinate(1, "waypoint x"), in.coordinate(2, "waypoint y"));
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
      world.start = Pose2(in.coordinate(1, "start x"), in.coordinate(2, "start y"),
                          wrap_angle(deg2rad(in.number(3, "start heading in degrees"))));
    } else if (keyword == "family") {
      in.expect_fields(3, "family <name> <world seed>");
      if (family_line != 0)
        in.fail(fmt::format("duplicate family line (first on line {}); expected at most one", family_line));
      family_line = in.line_number();
      const std::string_view seed = in.field(2);
      std::uint64_t value = 0;
      if (const auto [end, error] = std::from_chars(seed.data(), seed.data() + seed.size(), value);
          error != std::errc() || end != seed.data() + seed.size())
        in.fail(fmt::format("expected the world seed as an integer from 0 to 2^64 - 1, found '{}'", seed));
      world.origin = WorldOrigin{std::string(in.field(1)), value};
    } else {
      in.fail(fmt::format("unknown keyword '{}'; expected 'landmark', 'waypoint', 'route', 'start' or 'family'",
                          keyword));
    }
  }
  if (world.waypoints.size() < 2)
    throw InputError(path, 0, fmt::format("expected at least 2 waypoints, found {}", world.waypoints.size()));
  return world;
}

void write_world(const std::string& path, const World& world) {
  // read_world takes the family's name as one field.
  if (world.origin && (world.origin->family.empty() ||
                       world.origin->family.find_first_of(" \t\r\n#") != std::string::npos))
    throw std::invalid_argument(
        fmt::format("write_world: the family name must be one word, found '{}'", world.origin->family));
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  fmt::format_to(it,
                 "# slamkit world\n"
                 "# landmark <id> <x> <y>   point landmark, metres\n"
                 "# waypoint <x> <y>        route point, metres, in driving order\n"
                 "# route open|closed       closed: back to the first waypoint at the end\n"
                 "# start <x> <y> <deg>     start pose (else at the first waypoint, facing the second)\n"
                 "# family <name> <seed>    the family and world seed it was drawn from, if any\n"
                 "route {}\n",
                 world.closed ? "closed" : "open");
  if (world.start)
    fmt::format_to(it, "start {} {} {}\n", world.start->x(), world.start->y(), rad2deg((*world.start)[2]));
  if (world.origin) fmt::format_to(it, "family {} {}\n", world.origin->family, world.origin->seed);
  for (const Landmark& l : world.landmarks)
    fmt::format_to(it, "landmark {} {} {}\n", l.id, l.position.x(), l.position.y());
  for (const Vector2& w : world.waypoints) fmt::format_to(it, "waypoint {} {}\n", w.x(), w.y());
  write_file_atomically(path, std::string_view(out.data(), out.size()));
}

}  // namespace slamkit
