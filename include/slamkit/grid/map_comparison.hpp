#pragma once
// How well an estimated occupancy grid agrees with a reference map (a floor plan, a map built from
// ground-truth poses, a map a user trusts), in the trinary classes of map_files.hpp.
//
// Walls: precision is the share of the estimate's occupied cells that have an occupied reference cell
// within `tolerance_cells` (Chebyshev distance: the square of side 2 * tolerance + 1 around the cell),
// recall the share of the reference's occupied cells that have an occupied estimate cell within the
// same distance. A map drawn with a pose error that grows (a loop not closed) doubles walls: the
// second copy has no reference wall near it, so precision drops, while recall may stay high. Walls
// missing from the estimate lower recall.
// Cells: cell agreement is the share of the cells observed in both maps that fall in the same class
// (free, unknown, occupied); most cells are free, so it mostly measures free space and is blind to
// thin wall errors that precision and recall catch.
// A share with nothing to count (no occupied cell in the estimate, for precision) is 0; the counts
// say when that is the case.
#include <cstddef>

#include "slamkit/grid/occupancy_grid.hpp"

namespace slamkit {

struct MapAgreement {
  std::size_t estimate_occupied = 0;   // occupied cells of the estimate
  std::size_t reference_occupied = 0;  // occupied cells of the reference
  double precision = 0.0;              // of the estimate's occupied cells, the share near a reference wall
  double recall = 0.0;                 // of the reference's occupied cells, the share near an estimated wall
  std::size_t cells_compared = 0;      // cells observed in both maps
  double cell_agreement = 0.0;         // of those, the share with the same class
};

/// Compares two grids cell by cell, in the world frame both share (the estimate is not aligned to the
/// reference: align its poses first if its frame differs). Throws std::invalid_argument when the
/// resolutions differ or tolerance_cells is outside 0 to 100.
MapAgreement compare_maps(const OccupancyGrid& estimate, const OccupancyGrid& reference, int tolerance_cells = 1);

}  // namespace slamkit
