#pragma once
// A uniform grid over landmark positions, so the landmarks that can be in view are found by looking
// at the cells near the vehicle instead of scanning the whole map. Landmarks are binned at the
// position they had when last (re)binned; callers re-bin the landmarks they touch and rebuild the
// grid after large corrections (a loop closure), and query with a margin that covers the drift
// in between. Cells keep their storage once created (a rebuild empties them), so re-binning and
// rebuilding over ground already mapped do not allocate.
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "slamkit/core/types.hpp"

namespace slamkit {

class LandmarkGrid {
 public:
  explicit LandmarkGrid(double cell_size = 10.0);

  /// Drops everything and bins landmarks 0..n-1 at `positions`.
  void rebuild(const std::vector<Vector2>& positions);
  /// Bins landmark `index` (the next index: landmarks are added in order) at p.
  void add(std::size_t index, const Vector2& p);
  /// Moves landmark `index` to the cell of p if it is not there already.
  void move(std::size_t index, const Vector2& p);
  /// Appends to `out` every landmark binned in a cell that intersects the disc (centre, radius).
  void query(const Vector2& centre, double radius, std::vector<std::size_t>& out) const;

  std::size_t size() const { return cell_of_.size(); }
  double cell_size() const { return cell_size_; }

 private:
  using Key = std::uint64_t;
  Key key_of(const Vector2& p) const;
  static Key key(std::int64_t cx, std::int64_t cy);
  void erase_from_cell(std::size_t index);

  double cell_size_;
  std::unordered_map<Key, std::vector<std::size_t>> cells_;
  std::vector<Key> cell_of_;
};

}  // namespace slamkit
