#pragma once
// Occupancy grids as files and pictures: the ROS map_server pair (an 8-bit PGM and a YAML file that
// places it in the world), which RViz, the ROS navigation stack and most SLAM tools read and write,
// and a PNG for reports and the replay page.
#include <string>

#include "slamkit/core/grid_map.hpp"
#include "slamkit/grid/occupancy_grid.hpp"

namespace slamkit {

/// map_server's defaults: a cell is occupied above kOccupiedThreshold and free below kFreeThreshold
/// (probabilities); in between, or never observed, it is unknown.
inline constexpr double kOccupiedThreshold = 0.65;
inline constexpr double kFreeThreshold = 0.196;

/// The classes of map_server's trinary maps.
enum class CellClass { free, unknown, occupied };

/// A cell's class by its occupancy probability against the thresholds above.
CellClass cell_class(const OccupancyGrid& grid, GridCell cell);

/// Writes the box of the observed cells (bounds()) as a binary PGM (P5, maxval 255, the first row at
/// the top, i.e. at the largest y) and its YAML: occupied cells 0 (black), free 254 (white), unknown
/// 205, which map_server's thresholds read back as the same classes; `image` is the PGM's path
/// relative to the YAML's folder, `origin` the world position of the lower-left pixel's corner. A
/// grid with no observed cell is written as one unknown pixel at the world origin. Each file appears
/// whole or not at all (AtomicFile), the PGM first. Throws InputError naming a file that cannot be
/// written.
void write_map_server(const OccupancyGrid& grid, const std::string& pgm_path, const std::string& yaml_path);

/// Reads a map_server pair: the YAML (read by yaml-cpp, so block or flow style, comments and quoted
/// values as ROS tools write them) with the keys image, resolution, origin, negate, occupied_thresh
/// and free_thresh (all required; mode only as `trinary`), and its binary 8-bit PGM (P5). Occupied
/// pixels become cells at +log_odds_limit, free ones at -log_odds_limit, unknown ones stay
/// unobserved. The grid has `options` with the file's resolution; an origin that is not a whole
/// number of cells is rounded to the nearest cell (the map moves by at most half a cell). Throws
/// InputError naming the file, the line and what was expected for anything else: malformed YAML,
/// more than one document, unknown or repeated keys, a value of the wrong type or out of range, a
/// rotated origin, a malformed or truncated PGM.
OccupancyGrid read_map_server(const std::string& yaml_path, const GridOptions& options = {});

/// An 8-bit greyscale PNG of a grid and where it lies in the world.
struct GridImage {
  std::string png;        // the file's bytes
  double origin_x = 0.0;  // world position of the image's lower-left corner [m]
  double origin_y = 0.0;
  double width_m = 0.0;  // the extent the image covers [m]
  double height_m = 0.0;
};

/// The observed box as the PGM shows it (same orientation), each cell `scale` x `scale` pixels, shaded
/// by occupancy probability: 254 (white) at 0, 205 (grey) at 0.5, which is also every unobserved cell,
/// 0 (black) at 1, linear in between. An empty grid gives one unknown pixel at the origin. Throws
/// std::invalid_argument for a scale outside 1 to 64.
GridImage grid_png(const OccupancyGrid& grid, int scale = 1);

/// A filter's map (GridMap raster) as a PNG of at most `max_side` pixels a side: each pixel covers
/// k x k cells (the smallest k that fits) and shows the most occupied observed cell among them, so
/// walls stay visible when a large map is shrunk; a pixel with no observed cell is unknown. The
/// image's extent is the pixels' (up to k - 1 cells beyond the map on the right and at the top). An
/// empty map gives one unknown pixel at the origin. Throws std::invalid_argument for max_side < 1.
GridImage grid_png(const GridMap& map, int max_side);

}  // namespace slamkit
