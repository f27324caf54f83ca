#pragma once
// A snapshot of an occupancy grid map as a plain raster: what a grid-mapping filter hands the runner,
// and what the run folder, the pictures and the evaluation read. The grid module builds and matches
// against its own tiled, copy-on-write grids; this is the flat copy that leaves the filter.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "slamkit/core/types.hpp"

namespace slamkit {

struct GridMap {
  double resolution = 0.05;  // cell side [m]
  /// World position of the lower-left corner of cell (0, 0).
  Vector2 origin = Vector2::Zero();
  int width = 0;   // cells along x
  int height = 0;  // cells along y
  /// Row-major from the lowest row (min y): cell (i, j) at index j * width + i.
  std::vector<float> log_odds;
  /// 1 where any beam has touched the cell; log_odds is 0 elsewhere.
  std::vector<std::uint8_t> observed;

  bool empty() const { return width <= 0 || height <= 0; }
  std::size_t index(int i, int j) const {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(width) + static_cast<std::size_t>(i);
  }
};

}  // namespace slamkit
