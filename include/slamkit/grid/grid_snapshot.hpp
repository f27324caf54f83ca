#pragma once
// Between the grid module's tiled grids and the flat GridMap raster that leaves a filter (the run
// folder, the pictures and the evaluation read rasters).
#include "slamkit/core/grid_map.hpp"
#include "slamkit/grid/occupancy_grid.hpp"

namespace slamkit {

/// The observed box of `grid` as a raster (empty for a grid nothing has touched).
GridMap to_grid_map(const OccupancyGrid& grid);

/// A grid holding the raster's cells, with `options` for anything integrated into it later; the
/// raster's resolution replaces options.resolution, and its origin must lie on that resolution's
/// cell boundaries (as to_grid_map's does) for the cells to keep their places.
OccupancyGrid from_grid_map(const GridMap& raster, GridOptions options = {});

}  // namespace slamkit
