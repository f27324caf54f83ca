#include "slamkit/grid/map_comparison.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "slamkit/grid/map_files.hpp"

namespace slamkit {
namespace {

bool is_occupied(const OccupancyGrid& grid, GridCell cell) { return cell_class(grid, cell) == CellClass::occupied; }

/// Counts the occupied cells of `from` and those with an occupied cell of `to` within `tolerance`.
struct WallCount {
  std::size_t walls = 0;
  std::size_t near = 0;
};

WallCount walls_near(const OccupancyGrid& from, const OccupancyGrid& to, int tolerance) {
  WallCount count;
  const CellBox box = from.bounds();
  for (int y = box.min.y; y <= box.max.y; ++y) {
    for (int x = box.min.x; x <= box.max.x; ++x) {
      if (!is_occupied(from, GridCell{x, y})) continue;
      ++count.walls;
      bool found = false;
      for (int dy = -tolerance; dy <= tolerance && !found; ++dy)
        for (int dx = -tolerance; dx <= tolerance && !found; ++dx) found = is_occupied(to, GridCell{x + dx, y + dy});
      if (found) ++count.near;
    }
  }
  return count;
}

double share_of(std::size_t part, std::size_t whole) {
  return whole == 0 ? 0.0 : static_cast<double>(part) / static_cast<double>(whole);
}

}  // namespace

MapAgreement compare_maps(const OccupancyGrid& estimate, const OccupancyGrid& reference, int tolerance_cells) {
  if (std::abs(estimate.resolution() - reference.resolution()) > 1e-9 * reference.resolution())
    throw std::invalid_argument(
        fmt::format("map comparison: the estimate's resolution ({} m) differs from the "
                    "reference's ({} m)",
                    estimate.resolution(), reference.resolution()));
  if (tolerance_cells < 0 || tolerance_cells > 100)
    throw std::invalid_argument(
        fmt::format("map comparison: tolerance_cells must be from 0 to 100, found {}", tolerance_cells));
  MapAgreement agreement;
  const WallCount estimated = walls_near(estimate, reference, tolerance_cells);
  const WallCount referenced = walls_near(reference, estimate, tolerance_cells);
  agreement.estimate_occupied = estimated.walls;
  agreement.reference_occupied = referenced.walls;
  agreement.precision = share_of(estimated.near, estimated.walls);
  agreement.recall = share_of(referenced.near, referenced.walls);

  const CellBox a = estimate.bounds(), b = reference.bounds();
  const CellBox both{GridCell{std::max(a.min.x, b.min.x), std::max(a.min.y, b.min.y)},
                     GridCell{std::min(a.max.x, b.max.x), std::min(a.max.y, b.max.y)}};
  std::size_t same = 0;
  for (int y = both.min.y; y <= both.max.y; ++y) {
    for (int x = both.min.x; x <= both.max.x; ++x) {
      const GridCell cell{x, y};
      if (!estimate.observed(cell) || !reference.observed(cell)) continue;
      ++agreement.cells_compared;
      if (cell_class(estimate, cell) == cell_class(reference, cell)) ++same;
    }
  }
  agreement.cell_agreement = share_of(same, agreement.cells_compared);
  return agreement;
}

}  // namespace slamkit
