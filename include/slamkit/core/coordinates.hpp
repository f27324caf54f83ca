#pragma once
// The bound on the positions slamkit reads (landmarks, poses, routes, start poses), checked where
// they are read so that a value like 1e300 is an error naming its file and line, not a filter run
// that ends in an unplottable map or a map error of 1e20 m.
#include <cmath>

#include "slamkit/core/types.hpp"

namespace slamkit {

/// The largest coordinate [m]: two thousand kilometres, the reach of the largest generated world
/// with its band (sim/world.hpp), far beyond any map a range-bearing sensor builds, and small enough
/// that differences of positions keep nanometre resolution and their squares stay far from overflow.
inline constexpr double kMaxAbsCoordinate = 2e6;

/// Whether both coordinates of `p` are within +-kMaxAbsCoordinate (false for NaN).
inline bool within_coordinates(const Vector2& p) {
  return std::abs(p.x()) <= kMaxAbsCoordinate && std::abs(p.y()) <= kMaxAbsCoordinate;
}

}  // namespace slamkit
