#include "slamkit/grid/grid_snapshot.hpp"

#include <cmath>

namespace slamkit {

GridMap to_grid_map(const OccupancyGrid& grid) {
  GridMap raster;
  raster.resolution = grid.resolution();
  const CellBox box = grid.bounds();
  if (box.empty()) return raster;
  raster.width = box.width();
  raster.height = box.height();
  raster.origin = Vector2(box.min.x, box.min.y) * grid.resolution();
  const std::size_t cells = static_cast<std::size_t>(raster.width) * static_cast<std::size_t>(raster.height);
  raster.log_odds.assign(cells, 0.0f);
  raster.observed.assign(cells, 0);
  for (int j = 0; j < raster.height; ++j)
    for (int i = 0; i < raster.width; ++i) {
      const GridCell cell{box.min.x + i, box.min.y + j};
      if (!grid.observed(cell)) continue;
      raster.log_odds[raster.index(i, j)] = grid.log_odds(cell);
      raster.observed[raster.index(i, j)] = 1;
    }
  return raster;
}

OccupancyGrid from_grid_map(const GridMap& raster, GridOptions options) {
  options.resolution = raster.resolution;
  OccupancyGrid grid(options);
  const int x0 = static_cast<int>(std::lround(raster.origin.x() / raster.resolution));
  const int y0 = static_cast<int>(std::lround(raster.origin.y() / raster.resolution));
  for (int j = 0; j < raster.height; ++j)
    for (int i = 0; i < raster.width; ++i)
      if (raster.observed[raster.index(i, j)] != 0) grid.add({x0 + i, y0 + j}, raster.log_odds[raster.index(i, j)]);
  return grid;
}

}  // namespace slamkit
