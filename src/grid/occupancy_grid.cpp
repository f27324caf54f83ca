#include "slamkit/grid/occupancy_grid.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/checked_integer.hpp"
#include "slamkit/core/coordinates.hpp"
#include "slamkit/core/memory_budget.hpp"

namespace slamkit {
namespace {

/// Points on a beam in fixed point, 1/kSubcells of a cell, so that the traversal's arithmetic is exact:
/// no parameter accumulated over thousands of cells drifts, and every pass computes the same end cell.
/// GridCell indices stay below 2^31 (validate() and the coordinate bound), so coordinates stay below 2^47;
/// a beam is at most 10^7 cells long (range_cutoff / resolution), so the traversal's products of a
/// fraction of a cell and a length stay below 2^56.
constexpr int kSubcellBits = 16;
constexpr std::int64_t kSubcells = std::int64_t{1} << kSubcellBits;

struct FixedPoint {
  std::int64_t x = 0;
  std::int64_t y = 0;
};

/// Rounded down, by a truncation and a correction: std::floor and std::llround are library calls on
/// the baseline x86-64 instruction set, and this runs for every beam in every pass.
std::int64_t subcells_below(double cell_units) {
  const double scaled = cell_units * kSubcells;
  const auto truncated = static_cast<std::int64_t>(scaled);
  return truncated - (scaled < static_cast<double>(truncated) ? 1 : 0);
}

FixedPoint fixed_point(const Vector2& cell_units) {
  return FixedPoint{subcells_below(cell_units.x()), subcells_below(cell_units.y())};
}

GridCell floor_cell(FixedPoint point) {
  return GridCell{static_cast<int>(point.x >> kSubcellBits), static_cast<int>(point.y >> kSubcellBits)};
}

/// Moves a cell's mean hit point (OccupancyGrid::tile_cells) towards `end`, a point in the cell:
/// a cell that was not occupied takes the new point as it is; one that was, a quarter of the way (a
/// running mean without a count: the range noise averaged, a cell's first hits not kept for ever).
void record_hit(std::int8_t* offsets, FixedPoint end, bool was_occupied) {
  constexpr int kToByte = kSubcellBits - 8;
  const std::int64_t coordinates[2] = {end.x, end.y};
  for (int axis = 0; axis < 2; ++axis) {
    const int sample = static_cast<int>((coordinates[axis] & (kSubcells - 1)) >> kToByte) - 128;
    const int moved = was_occupied ? offsets[axis] + (sample - offsets[axis]) / 4 : sample;
    offsets[axis] = static_cast<std::int8_t>(moved);
  }
}

/// A beam as integrate() traces it: its end point and whether a reading ends there (false for a
/// no-return or a reading beyond the cut-off, traced free only).
struct TracedBeam {
  FixedPoint end;
  bool hit = false;
};

void extend(CellBox& box, GridCell cell) {
  if (box.empty()) {
    box = CellBox{cell, cell};
    return;
  }
  box.min = GridCell{std::min(box.min.x, cell.x), std::min(box.min.y, cell.y)};
  box.max = GridCell{std::max(box.max.x, cell.x), std::max(box.max.y, cell.y)};
}

/// Calls `visit` with every usable beam of `scan` from the sensor at `sensor` (world frame).
template <typename Visit>
void for_each_beam(const Pose2& sensor, const RangeScanEvent& scan, const GridOptions& options, Visit&& visit) {
  const double cells_per_metre = 1.0 / options.resolution;
  const Vector2 origin = sensor.head<2>() * cells_per_metre;
  // Each beam's direction is the previous one's turned by the increment: two products instead of a
  // sine and a cosine per beam, with a rounding drift of ~1e-13 over thousands of beams.
  Vector2 direction(std::cos(sensor.z() + scan.angle_min), std::sin(sensor.z() + scan.angle_min));
  const double turn_cos = std::cos(scan.angle_increment), turn_sin = std::sin(scan.angle_increment);
  for (const float reading : scan.ranges) {
    const double range = reading;
    if (std::isfinite(range) && range > 0.0) {
      const bool hit = range < scan.max_range && range <= options.range_cutoff;
      const double length = std::min(range, options.range_cutoff) * cells_per_metre;
      visit(TracedBeam{fixed_point(origin + length * direction), hit});
    }
    direction = Vector2(direction.x() * turn_cos - direction.y() * turn_sin,
                        direction.y() * turn_cos + direction.x() * turn_sin);
  }
}

/// Adds `free` (down to `lowest`) to the cells the segment from `start` to `end` crosses, the end's
/// cell excluded, except those marked hit by the scan; returns the last cell it visits. The
/// traversal is exact (Amanatides and Woo): the next boundary crossed is the x one while
/// (first_x + i) / |dx| < (first_y + j) / |dy| (first_*: the distance to the first boundary, i and j
/// the boundaries crossed since), kept cross-multiplied as `ahead`. Counting the steps left along
/// each axis makes it arrive at the end cell on a tie too. `tile_of(tile)` gives the tile to write,
/// looked up again only when the traversal leaves it; everything the loop uses is local, so no
/// store to a cell can alias it.
template <typename TileOf>
GridCell trace_free(FixedPoint start, FixedPoint end, float free, float lowest, TileOf&& tile_of) {
  constexpr int kShift = OccupancyGrid::kTileShift, kMask = OccupancyGrid::kTileSide - 1;
  const GridCell start_cell = floor_cell(start), end_cell = floor_cell(end);
  int steps_x = std::abs(end_cell.x - start_cell.x), steps_y = std::abs(end_cell.y - start_cell.y);
  const std::int64_t length_x = std::abs(end.x - start.x), length_y = std::abs(end.y - start.y);
  const int step_x = end.x > start.x ? 1 : -1, step_y = end.y > start.y ? 1 : -1;
  const std::int64_t corner_x = std::int64_t{start_cell.x} * kSubcells;
  const std::int64_t corner_y = std::int64_t{start_cell.y} * kSubcells;
  const std::int64_t first_x = step_x > 0 ? corner_x + kSubcells - start.x : start.x - corner_x;
  const std::int64_t first_y = step_y > 0 ? corner_y + kSubcells - start.y : start.y - corner_y;
  std::int64_t ahead = first_x * length_y - first_y * length_x;  // < 0: the x boundary comes first
  const std::int64_t after_x = length_y * kSubcells, after_y = length_x * kSubcells;

  GridCell cell = start_cell, last = start_cell, tile_key{cell.x >> kShift, cell.y >> kShift};
  auto* tile = &tile_of(tile_key);
  while (steps_x + steps_y > 0) {
    const GridCell key{cell.x >> kShift, cell.y >> kShift};
    if (!(key == tile_key)) {
      tile_key = key;
      tile = &tile_of(key);
    }
    const int row = cell.y & kMask;
    const std::uint32_t bit = 1u << (cell.x & kMask);
    if ((tile->hit_rows[row] & bit) == 0) {
      float& value = tile->log_odds[static_cast<std::size_t>(row * OccupancyGrid::kTileSide + (cell.x & kMask))];
      value = std::max(value + free, lowest);
      tile->observed_rows[row] |= bit;
    }
    last = cell;
    // Which axis steps is a coin toss for a diagonal beam, so selects rather than branches.
    const bool along_x = steps_x > 0 && (steps_y == 0 || ahead < 0);
    cell.x += along_x ? step_x : 0;
    cell.y += along_x ? 0 : step_y;
    steps_x -= along_x ? 1 : 0;
    steps_y -= along_x ? 0 : 1;
    ahead += along_x ? after_x : -after_y;
  }
  return last;
}

}  // namespace

void validate(const GridOptions& o) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("occupancy grid: " + what); };
  if (!(o.resolution >= 0.001 && o.resolution <= 100.0))
    fail(fmt::format("resolution must be from 0.001 to 100 m, found {}", o.resolution));
  if (!(o.range_cutoff > 0.0 && o.range_cutoff <= 1e4))
    fail(fmt::format("range_cutoff must be > 0 and <= 10000 m, found {}", o.range_cutoff));
  if (!(o.log_odds_occupied >= 0.0f && std::isfinite(o.log_odds_occupied)))
    fail(fmt::format("log_odds_occupied must be finite and >= 0, found {}", o.log_odds_occupied));
  if (!(o.log_odds_free <= 0.0f && std::isfinite(o.log_odds_free)))
    fail(fmt::format("log_odds_free must be finite and <= 0, found {}", o.log_odds_free));
  if (!(o.log_odds_limit > 0.0f && std::isfinite(o.log_odds_limit)))
    fail(fmt::format("log_odds_limit must be finite and > 0, found {}", o.log_odds_limit));
  if (!(o.max_cells >= 1.0 && o.max_cells <= 1e12))
    fail(fmt::format("max_cells must be from 1 to 1e12, found {}", o.max_cells));
}

Pose2 sensor_pose(const Pose2& vehicle_pose, const Pose2& sensor_offset) {
  const double c = std::cos(vehicle_pose.z()), s = std::sin(vehicle_pose.z());
  return Pose2(vehicle_pose.x() + c * sensor_offset.x() - s * sensor_offset.y(),
               vehicle_pose.y() + s * sensor_offset.x() + c * sensor_offset.y(),
               wrap_angle(vehicle_pose.z() + sensor_offset.z()));
}

OccupancyGrid::OccupancyGrid(const GridOptions& options) : options_((validate(options), options)) {}

GridCell OccupancyGrid::cell_of(const Vector2& point) const {
  return GridCell{checked_integer<int>(std::floor(point.x() / options_.resolution), "the cell index of x"),
              checked_integer<int>(std::floor(point.y() / options_.resolution), "the cell index of y")};
}

Vector2 OccupancyGrid::centre_of(GridCell cell) const {
  return Vector2((cell.x + 0.5) * options_.resolution, (cell.y + 0.5) * options_.resolution);
}

bool OccupancyGrid::observed(GridCell cell) const {
  const Tile* tile = tile_at(GridCell{cell.x >> kTileShift, cell.y >> kTileShift});
  return tile != nullptr && (tile->observed_rows[cell.y & (kTileSide - 1)] >> (cell.x & (kTileSide - 1)) & 1u) != 0;
}

double OccupancyGrid::probability(GridCell cell) const { return 1.0 / (1.0 + std::exp(-double{log_odds(cell)})); }

void OccupancyGrid::add(GridCell cell, float log_odds) {
  if (!std::isfinite(log_odds)) throw std::invalid_argument(fmt::format("occupancy grid: log-odds {} added", log_odds));
  check_extent(CellBox{cell, cell});
  cover(CellBox{cell, cell});
  Tile& tile = writable_tile(GridCell{cell.x >> kTileShift, cell.y >> kTileShift});
  float& value = tile.log_odds[static_cast<std::size_t>(local_index(cell))];
  value = std::clamp(value + log_odds, -options_.log_odds_limit, options_.log_odds_limit);
  tile.observed_rows[cell.y & (kTileSide - 1)] |= 1u << (cell.x & (kTileSide - 1));
  extend(observed_box_, cell);
}

void OccupancyGrid::integrate(const Pose2& vehicle_pose, const RangeScanEvent& scan) {
  const Pose2 sensor = sensor_pose(vehicle_pose, scan.sensor_offset);
  // The bounds keep every cell index a beam reaches within an int (validate() bounds the rest).
  if (!(within_coordinates(sensor.head<2>()) && std::isfinite(sensor.z())))
    throw GridExtentError(fmt::format("occupancy grid: sensor pose ({}, {}, {}) is not finite or beyond {} m",
                                      sensor.x(), sensor.y(), sensor.z(), kMaxAbsCoordinate));
  if (!(std::isfinite(scan.angle_min) && std::isfinite(scan.angle_increment) && !std::isnan(scan.max_range)))
    throw std::invalid_argument("occupancy grid: a scan's angle_min, angle_increment or max_range is not a number");

  const FixedPoint start = fixed_point(sensor.head<2>() / options_.resolution);
  const GridCell start_cell = floor_cell(start);
  // The tile table covers only cells a scan observes (the passes below: every hit's end, and the
  // trace of every beam that leaves the sensor's cell), so it grows only where the observed box,
  // which check_extent bounds by max_cells, grows too. A scan that observes nothing changes nothing.
  CellBox reach;
  for_each_beam(sensor, scan, options_, [&](const TracedBeam& beam) {
    const GridCell end = floor_cell(beam.end);
    if (!beam.hit && end == start_cell) return;
    extend(reach, start_cell);
    extend(reach, end);
  });
  if (reach.empty()) return;
  check_extent(reach);
  cover(reach);

  const float limit = options_.log_odds_limit;
  const float occupied = options_.log_odds_occupied;
  const float free = options_.log_odds_free;
  const auto clear_hits = [&] {
    for_each_beam(sensor, scan, options_, [&](const TracedBeam& beam) {
      if (!beam.hit) return;
      const GridCell end = floor_cell(beam.end);
      Tile* tile = existing_tile(GridCell{end.x >> kTileShift, end.y >> kTileShift});
      const std::uint32_t bit = 1u << (end.x & (kTileSide - 1));
      // Only tiles this grid alone holds were marked; a shared tile is read, never written here.
      if (tile != nullptr && (tile->hit_rows[end.y & (kTileSide - 1)] & bit) != 0)
        tile->hit_rows[end.y & (kTileSide - 1)] &= ~bit;
    });
  };

  // A cell a beam ends in is not freed by the same scan's other beams passing through it. Beams at a
  // grazing angle to a wall cross the wall's cells just before their neighbours end in them, so a
  // scan would otherwise erase much of what it sees; applying the hits after the free updates is not
  // enough, as several crossings outweigh one hit. Hence two passes: the hits, marked in the tiles'
  // scratch bits, then the free traces, which skip marked cells; then the marks are cleared.
  const auto tile_of = [this](GridCell tile) -> Tile& { return writable_tile(tile); };
  try {
    for_each_beam(sensor, scan, options_, [&](const TracedBeam& beam) {
      if (!beam.hit) return;
      const GridCell end = floor_cell(beam.end);
      Tile& tile = writable_tile(GridCell{end.x >> kTileShift, end.y >> kTileShift});
      const auto index = static_cast<std::size_t>(local_index(end));
      float& value = tile.log_odds[index];
      record_hit(&tile.hit_offsets[2 * index], beam.end, value > 0.0f);
      value = std::min(value + occupied, limit);
      const std::uint32_t bit = 1u << (end.x & (kTileSide - 1));
      tile.observed_rows[end.y & (kTileSide - 1)] |= bit;
      tile.hit_rows[end.y & (kTileSide - 1)] |= bit;
      extend(observed_box_, end);
    });
    for_each_beam(sensor, scan, options_, [&](const TracedBeam& beam) {
      if (floor_cell(beam.end) == start_cell) return;
      extend(observed_box_, start_cell);
      extend(observed_box_, trace_free(start, beam.end, free, -limit, tile_of));
    });
  } catch (...) {
    clear_hits();
    throw;
  }
  clear_hits();
}

OccupancyGrid::Tile& OccupancyGrid::writable_tile(GridCell tile) {
  std::shared_ptr<Tile>& slot =
      tiles_[static_cast<std::size_t>(tile.y - tile_origin_.y) * static_cast<std::size_t>(tiles_wide_) +
             static_cast<std::size_t>(tile.x - tile_origin_.x)];
  if (!slot) {
    slot = std::make_shared<Tile>();
  } else if (slot.use_count() > 1) {
    slot = std::make_shared<Tile>(*slot);
  } else {
    // use_count() loads relaxed. A grid that shared this tile until a moment ago may have read it
    // (copying it) on another thread before dropping its reference; the fence orders those reads
    // before our writes, with the release of that drop.
    std::atomic_thread_fence(std::memory_order_acquire);
  }
  return *slot;
}

void OccupancyGrid::check_extent(const CellBox& cells) const {
  CellBox grown = observed_box_;
  extend(grown, cells.min);
  extend(grown, cells.max);
  const double cells_wide = static_cast<double>(grown.max.x) - grown.min.x + 1.0;
  const double cells_high = static_cast<double>(grown.max.y) - grown.min.y + 1.0;
  if (cells_wide * cells_high <= options_.max_cells) return;
  const double r = options_.resolution;
  const Vector2 centre = 0.5 * (centre_of(cells.min) + centre_of(cells.max));
  throw GridExtentError(fmt::format(
      "occupancy grid: cells around ({:.6g}, {:.6g}) m would make the map {:.0f} x {:.0f} cells ({:.6g} m x {:.6g} m "
      "at {} m), beyond its max_cells ({:.6g}): a pose far from the rest of the map (a jump in the log, or a filter "
      "gone astray), or a map larger than allowed (raise grid.max_cells or grid.resolution_m)",
      centre.x(), centre.y(), cells_wide, cells_high, cells_wide * r, cells_high * r, r, options_.max_cells));
}

void OccupancyGrid::cover(const CellBox& cells) {
  const GridCell low{cells.min.x >> kTileShift, cells.min.y >> kTileShift};
  const GridCell high{cells.max.x >> kTileShift, cells.max.y >> kTileShift};
  const GridCell old_high{tile_origin_.x + tiles_wide_ - 1, tile_origin_.y + tiles_high_ - 1};
  if (tiles_wide_ > 0 && low.x >= tile_origin_.x && low.y >= tile_origin_.y && high.x <= old_high.x &&
      high.y <= old_high.y)
    return;
  GridCell new_low = low, new_high = high;
  if (tiles_wide_ > 0) {
    // A side that must grow grows by a quarter of the extent more than needed, so a robot exploring
    // in one direction rebuilds the table a logarithmic number of times.
    const int margin_x = std::max(1, tiles_wide_ / 4), margin_y = std::max(1, tiles_high_ / 4);
    new_low = GridCell{low.x < tile_origin_.x ? low.x - margin_x : tile_origin_.x,
                   low.y < tile_origin_.y ? low.y - margin_y : tile_origin_.y};
    new_high = GridCell{high.x > old_high.x ? high.x + margin_x : old_high.x,
                    high.y > old_high.y ? high.y + margin_y : old_high.y};
  }
  const int wide = new_high.x - new_low.x + 1, high_count = new_high.y - new_low.y + 1;
  const std::size_t slots = static_cast<std::size_t>(wide) * static_cast<std::size_t>(high_count);
  require_memory(static_cast<double>(slots) * sizeof(std::shared_ptr<Tile>), "the tile table of an occupancy grid");
  std::vector<std::shared_ptr<Tile>> table(slots);
  for (int row = 0; row < tiles_high_; ++row)
    for (int column = 0; column < tiles_wide_; ++column)
      table[static_cast<std::size_t>(row + tile_origin_.y - new_low.y) * static_cast<std::size_t>(wide) +
            static_cast<std::size_t>(column + tile_origin_.x - new_low.x)] =
          std::move(tiles_[static_cast<std::size_t>(row) * static_cast<std::size_t>(tiles_wide_) +
                           static_cast<std::size_t>(column)]);
  tiles_ = std::move(table);
  tile_origin_ = new_low;
  tiles_wide_ = wide;
  tiles_high_ = high_count;
}

std::size_t OccupancyGrid::tile_count() const {
  return static_cast<std::size_t>(
      std::count_if(tiles_.begin(), tiles_.end(), [](const auto& tile) { return tile != nullptr; }));
}

std::size_t OccupancyGrid::bytes() const {
  return tile_count() * sizeof(Tile) + tiles_.size() * sizeof(std::shared_ptr<Tile>);
}

std::size_t OccupancyGrid::distinct_bytes(std::span<const OccupancyGrid* const> grids) {
  std::vector<const Tile*> tiles;
  std::size_t table_bytes = 0;
  for (const OccupancyGrid* grid : grids) {
    table_bytes += grid->tiles_.size() * sizeof(std::shared_ptr<Tile>);
    for (const auto& tile : grid->tiles_)
      if (tile) tiles.push_back(tile.get());
  }
  std::sort(tiles.begin(), tiles.end());
  const auto distinct = static_cast<std::size_t>(std::unique(tiles.begin(), tiles.end()) - tiles.begin());
  return distinct * sizeof(Tile) + table_bytes;
}

}  // namespace slamkit
