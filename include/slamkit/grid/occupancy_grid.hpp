#pragma once
// An occupancy grid map: log-odds of occupancy per square cell, built by ray casting each range scan
// through an inverse sensor model. Storage is in square tiles shared copy-on-write, so a copy of a
// grid (a resampled particle's map) costs a table of pointers, and memory grows only with the tiles
// the copies have written since they parted.
//
// Threads: grids that share tiles may be read and written from different threads at once (each
// grid by one thread); one grid must not be copied while another thread writes it.
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <vector>

#include "slamkit/core/types.hpp"

namespace slamkit {

/// How scans are turned into evidence.
struct GridOptions {
  double resolution = 0.05;  // cell side [m]
  /// Readings beyond this (and no-return readings, at or beyond the scan's max_range) mark free space
  /// up to min(reading, this distance) only and no obstacle [m].
  double range_cutoff = 30.0;
  float log_odds_occupied = 0.9f;  // added to the cell a beam ends in
  float log_odds_free = -0.4f;     // added to each cell a beam passes through
  /// Cells are clamped to +-this, so a cell can change its mind after enough contrary evidence.
  float log_odds_limit = 6.0f;
  /// The most cells the map's bounding box may hold. Every output of a grid is a raster of that box
  /// (map.pgm, the replay page), and its tile table spans it, so two poses kilometres apart (a jump
  /// in a log, a filter gone astray) would cost gigabytes; 1e8 cells is 500 m x 500 m at 5 cm.
  double max_cells = 1e8;
};

/// A scan the grid cannot take: a sensor pose that is not finite or beyond kMaxAbsCoordinate
/// (core/coordinates.hpp), or one that would make the map's bounding box exceed max_cells. Nothing
/// of the scan was integrated. The runner reports it as bad input naming the event.
class GridExtentError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Throws std::invalid_argument naming the setting: resolution from 0.001 to 100 m (cell indices of
/// every position slamkit accepts must fit in an int), range_cutoff > 0 and <= 10 km, log_odds_occupied
/// >= 0, log_odds_free <= 0, log_odds_limit > 0, max_cells from 1 to 1e12, all finite.
void validate(const GridOptions& options);

/// Integer cell coordinates: cell (i, j) covers [i, i+1) x [j, j+1) times the resolution.
struct GridCell {
  int x = 0;
  int y = 0;
  friend bool operator==(GridCell, GridCell) = default;
};

/// The cells touched so far, inclusive on both ends; empty when min > max.
struct CellBox {
  GridCell min{1, 1};
  GridCell max{0, 0};
  bool empty() const { return min.x > max.x || min.y > max.y; }
  int width() const { return empty() ? 0 : max.x - min.x + 1; }
  int height() const { return empty() ? 0 : max.y - min.y + 1; }
};

class OccupancyGrid {
 public:
  static constexpr int kTileSide = 32;  // cells
  static constexpr int kTileShift = 5;  // log2(kTileSide): tile of a cell by an arithmetic shift (floor)

  /// Throws std::invalid_argument when `options` fail validate().
  explicit OccupancyGrid(const GridOptions& options = {});

  const GridOptions& options() const { return options_; }
  double resolution() const { return options_.resolution; }

  /// Throws std::out_of_range for a point whose cell index does not fit in an int (or NaN).
  GridCell cell_of(const Vector2& point) const;
  Vector2 centre_of(GridCell cell) const;

  /// Log-odds of occupancy; 0 for a cell never observed.
  float log_odds(GridCell cell) const {
    const float* cells = tile_log_odds(GridCell{cell.x >> kTileShift, cell.y >> kTileShift});
    return cells == nullptr ? 0.0f : cells[local_index(cell)];
  }
  /// Whether any beam has touched the cell.
  bool observed(GridCell cell) const;
  /// Occupancy probability, 0.5 for a cell never observed.
  double probability(GridCell cell) const;
  /// Adds evidence to one cell, clamped to +-options().log_odds_limit, and marks it observed; copies
  /// the cell's tile first when another grid shares it. Throws std::invalid_argument for a log-odds
  /// that is not finite, GridExtentError for a cell that would make the map exceed max_cells.
  void add(GridCell cell, float log_odds);

  /// Integrates one scan with the vehicle at `vehicle_pose` (world frame; the scan's sensor_offset
  /// is applied): every beam marks the cells it crosses free (exact traversal: every cell the segment
  /// passes through) and, unless it is a no-return or beyond the cut-off, the cell it ends in
  /// occupied. A cell some beam of the scan ends in is not freed by the scan's other beams. Readings
  /// that are not finite or not positive are skipped. Throws, before changing anything,
  /// GridExtentError (see there) and std::invalid_argument for a scan whose angles or max_range are
  /// not numbers.
  void integrate(const Pose2& vehicle_pose, const RangeScanEvent& scan);

  /// The box of the cells observed so far.
  CellBox bounds() const { return observed_box_; }

  /// Tiles this grid holds, and their bytes with the tile table's.
  std::size_t tile_count() const;
  std::size_t bytes() const;
  /// Bytes of the distinct tiles and tables of several grids together: what they cost in memory
  /// while they share tiles.
  static std::size_t distinct_bytes(std::span<const OccupancyGrid* const> grids);
  /// Bytes of one tile: what a grid's first write to a tile it shares costs (memory estimates).
  static constexpr std::size_t tile_bytes() { return sizeof(Tile); }

  /// The log-odds of one tile's cells, row by row (cell (x, y) of the tile at y * kTileSide + x), or
  /// nullptr where no cell of the tile was ever written (all 0). For readers that visit many nearby
  /// cells, such as the scan matcher, without looking the tile up for each.
  const float* tile_log_odds(GridCell tile) const {
    const Tile* t = tile_at(tile);
    return t == nullptr ? nullptr : t->log_odds.data();
  }
  /// One tile's cells for a reader that wants where their hits ended too: `log_odds` as
  /// tile_log_odds, and `hit_offsets`, per cell (x, y) at 2 (y * kTileSide + x) and the next byte, the
  /// mean end point of the beams that hit it as its offset from the cell's centre in 1/256 of a cell
  /// (0 where none hit); both nullptr where the tile was never written. A matcher that measures to
  /// these points instead of the centres sees a wall where the beams found it, not up to half a cell
  /// off.
  struct TileCells {
    const float* log_odds = nullptr;
    const std::int8_t* hit_offsets = nullptr;
  };
  TileCells tile_cells(GridCell tile) const {
    const Tile* t = tile_at(tile);
    return t == nullptr ? TileCells{} : TileCells{t->log_odds.data(), t->hit_offsets.data()};
  }
  static int local_index(GridCell cell) { return (cell.y & (kTileSide - 1)) * kTileSide + (cell.x & (kTileSide - 1)); }

 private:
  struct Tile {
    std::array<float, kTileSide * kTileSide> log_odds{};
    std::array<std::uint32_t, kTileSide> observed_rows{};  // bit x of word y: cell (x, y) observed
    std::array<std::int8_t, 2 * kTileSide * kTileSide> hit_offsets{};  // see tile_cells()
    /// Scratch of integrate(): the cells the current scan's beams end in. All clear between calls.
    std::array<std::uint32_t, kTileSide> hit_rows{};
  };
  const Tile* tile_at(GridCell tile) const {
    const int column = tile.x - tile_origin_.x;
    const int row = tile.y - tile_origin_.y;
    if (static_cast<unsigned>(column) >= static_cast<unsigned>(tiles_wide_) ||
        static_cast<unsigned>(row) >= static_cast<unsigned>(tiles_high_))
      return nullptr;
    return tiles_[static_cast<std::size_t>(row) * static_cast<std::size_t>(tiles_wide_) +
                  static_cast<std::size_t>(column)]
        .get();
  }
  /// The tile, created or copied as needed so that this grid alone holds it; the table covers it.
  Tile& writable_tile(GridCell tile);
  /// The tile if the table holds one, for clearing integrate()'s scratch without creating tiles.
  Tile* existing_tile(GridCell tile) { return const_cast<Tile*>(tile_at(tile)); }
  /// Throws GridExtentError when the map's box grown by `cells` would exceed options_.max_cells.
  void check_extent(const CellBox& cells) const;
  /// Grows the table so that it covers the tiles of `cells` (a box in cell coordinates).
  void cover(const CellBox& cells);

  GridOptions options_;
  std::vector<std::shared_ptr<Tile>> tiles_;  // row-major over the tiles' box, nullptr where none
  GridCell tile_origin_;                          // tile coordinates of tiles_[0]
  int tiles_wide_ = 0;
  int tiles_high_ = 0;
  CellBox observed_box_;
};

/// The pose of the sensor in the world frame when the vehicle is at `vehicle_pose`.
Pose2 sensor_pose(const Pose2& vehicle_pose, const Pose2& sensor_offset);

}  // namespace slamkit
