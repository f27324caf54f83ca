#pragma once
// A uniform grid of landmark indices by position, so that the landmarks that can be in view are
// found by looking at the cells near the vehicle instead of scanning the whole map.
//
// A cell lists landmark indices, each at most once; an index may be listed in several cells. The
// EKF lists each landmark once, in the cell of the position it was last binned at, re-bins the
// landmarks a scan moved and starts over after a large correction (a loop closure). FastSLAM lists
// every particle's version of a landmark in the cell of its mean, adding an entry when a version is
// created in a cell or moves into it and pruning the entries no version needs any more, so the
// grid costs O(changes) per scan, not O(map size).
//
// Entries are linked lists through one pool of nodes that only grows, and a query creates the cells
// of its square and a ring around it (where a scan's new and moved landmarks land), so listing,
// moving and clearing over ground already seen do not allocate. A query whose square is larger than
// 256 x 256 cells and four times the cells the grid holds (a search region grown with a diverged
// estimate) walks the existing cells instead and creates none, so its cost and memory stay bounded by the map's. Not thread-safe;
// cell_of may be called concurrently with itself.
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "slamkit/core/types.hpp"

namespace slamkit {

class LandmarkGrid {
 public:
  using Cell = std::uint64_t;

  /// Throws std::invalid_argument unless cell_size > 0.
  explicit LandmarkGrid(double cell_size);

  double cell_size() const { return cell_size_; }
  /// Cells created so far, empty ones included: the grid's memory.
  std::size_t cells() const { return cells_.size(); }
  Cell cell_of(const Vector2& p) const { return pack(column(p.x()), column(p.y())); }
  /// At least the number of entries listed, the most a query can return; it changes only when the
  /// grid's own storage grows.
  std::size_t max_entries() const { return nodes_.capacity(); }

  /// Lists landmark `index` in `cell`, unless it is listed there already.
  void insert(Cell cell, std::uint32_t index);
  /// Stops listing landmark `index` in `cell`; nothing happens if it is not listed there.
  void erase(Cell cell, std::uint32_t index);
  /// Empties every cell.
  void clear();
  /// Replaces `out` with the landmarks listed in the cells that touch the square around the disc
  /// (centre, radius), cell by cell: an index listed in several of them comes once per cell. The
  /// next prune() visits those cells.
  void query(const Vector2& centre, double radius, std::vector<std::uint32_t>& out);
  /// What query() would return, without creating a cell or changing the cells prune() visits.
  void list(const Vector2& centre, double radius, std::vector<std::uint32_t>& out) const;
  /// Drops the entries of the last query's cells for which needed(cell, index) is false: they are
  /// where stale entries cost, and where map management has just been at work.
  template <class Needed>
  void prune(Needed&& needed) {
    for_each_queried_cell([&](Cell cell, std::uint32_t& head) {
      for (std::uint32_t* link = &head; *link != kNone;) {
        Node& node = nodes_[*link];
        if (needed(cell, node.index)) {
          link = &node.next;
          continue;
        }
        const std::uint32_t freed = *link;
        *link = node.next;
        release(freed);
      }
    });
  }

 private:
  struct Node {
    std::uint32_t index;
    std::uint32_t next;
  };
  static constexpr std::uint32_t kNone = 0xffffffffU;

  // Columns saturate at +-2^30 cells (billions of metres at any useful cell size), so that a
  // position, even a diverged or infinite one, converts without overflow, a column and its
  // neighbours fit in 32 bits, and pack() is one-to-one. NaN, which no estimate should hold, goes to
  // column 0.
  static constexpr std::int64_t kMaxColumn = std::int64_t{1} << 30;
  std::int64_t column(double v) const {
    const double c = std::floor(v / cell_size_);
    if (!(c > -static_cast<double>(kMaxColumn))) return std::isnan(c) ? 0 : -kMaxColumn;
    return c < static_cast<double>(kMaxColumn) ? static_cast<std::int64_t>(c) : kMaxColumn;
  }
  static Cell pack(std::int64_t ix, std::int64_t iy) {
    return (static_cast<Cell>(static_cast<std::uint32_t>(ix)) << 32) | static_cast<std::uint32_t>(iy);
  }
  static std::int64_t column_x(Cell cell) { return static_cast<std::int32_t>(static_cast<std::uint32_t>(cell >> 32)); }
  static std::int64_t column_y(Cell cell) { return static_cast<std::int32_t>(static_cast<std::uint32_t>(cell)); }
  std::uint32_t acquire(std::uint32_t index, std::uint32_t next);
  void release(std::uint32_t node);
  /// f(cell, head) for each existing cell of the last query's square.
  template <class F>
  void for_each_queried_cell(F&& f) {
    if (wide_) {
      for (auto& [cell, head] : cells_)
        if (in_last_query(cell)) f(cell, head);
      return;
    }
    for (std::int64_t ix = lo_x_; ix <= hi_x_; ++ix)
      for (std::int64_t iy = lo_y_; iy <= hi_y_; ++iy)
        if (const auto it = cells_.find(pack(ix, iy)); it != cells_.end()) f(it->first, it->second);
  }
  bool in_last_query(Cell cell) const {
    const std::int64_t ix = column_x(cell), iy = column_y(cell);
    return ix >= lo_x_ && ix <= hi_x_ && iy >= lo_y_ && iy <= hi_y_;
  }

  double cell_size_;
  std::unordered_map<Cell, std::uint32_t> cells_;  // the head of each cell's list
  std::vector<Node> nodes_;
  std::uint32_t free_ = kNone;  // the list of unused nodes
  std::int64_t lo_x_ = 0, lo_y_ = 0, hi_x_ = -1, hi_y_ = -1;  // the last query's cells; none yet
  bool wide_ = false;  // the last query walked the existing cells
};

}  // namespace slamkit
