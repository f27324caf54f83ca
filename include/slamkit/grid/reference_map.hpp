#pragma once
// The map a dataset's range scans draw from its true (or reference) poses: what a grid map is
// scored against (grid/map_comparison.hpp), the truth's counterpart of the map a filter built from
// its own poses.
#include <optional>

#include "slamkit/core/dataset.hpp"
#include "slamkit/grid/occupancy_grid.hpp"

namespace slamkit {

/// Every RangeScanEvent of `dataset` integrated at the truth's pose at its time (interpolated between
/// truth samples). Empty where the dataset has no truth poses with headings, or no scan falls within
/// them.
std::optional<OccupancyGrid> reference_map(const Dataset& dataset, const GridOptions& options);

}  // namespace slamkit
