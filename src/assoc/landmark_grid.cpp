#include "slamkit/assoc/landmark_grid.hpp"

#include <algorithm>
#include <stdexcept>

namespace slamkit {

namespace {
// The node pool's first allocation: the entries of a few hundred cells.
constexpr std::size_t kInitialNodes = 4096;
// A query square up to this many cells (256 x 256) is visited cell by cell, whatever the grid holds.
constexpr double kWideQueryCells = 65536.0;
}  // namespace

LandmarkGrid::LandmarkGrid(double cell_size) : cell_size_(cell_size) {
  if (!(cell_size > 0.0)) throw std::invalid_argument("LandmarkGrid needs a positive cell size");
  nodes_.reserve(kInitialNodes);
}

std::uint32_t LandmarkGrid::acquire(std::uint32_t index, std::uint32_t next) {
  if (free_ == kNone) {
    nodes_.push_back({index, next});
    return static_cast<std::uint32_t>(nodes_.size() - 1);
  }
  const std::uint32_t node = free_;
  free_ = nodes_[node].next;
  nodes_[node] = {index, next};
  return node;
}

void LandmarkGrid::release(std::uint32_t node) {
  nodes_[node].next = free_;
  free_ = node;
}

void LandmarkGrid::insert(Cell cell, std::uint32_t index) {
  std::uint32_t& head = cells_.try_emplace(cell, kNone).first->second;
  for (std::uint32_t n = head; n != kNone; n = nodes_[n].next)
    if (nodes_[n].index == index) return;
  head = acquire(index, head);
}

void LandmarkGrid::erase(Cell cell, std::uint32_t index) {
  const auto it = cells_.find(cell);
  if (it == cells_.end()) return;
  for (std::uint32_t* link = &it->second; *link != kNone; link = &nodes_[*link].next) {
    if (nodes_[*link].index != index) continue;
    const std::uint32_t freed = *link;
    *link = nodes_[freed].next;
    release(freed);
    return;
  }
}

void LandmarkGrid::clear() {
  for (auto& [cell, head] : cells_)
    while (head != kNone) {
      const std::uint32_t freed = head;
      head = nodes_[freed].next;
      release(freed);
    }
}

void LandmarkGrid::query(const Vector2& centre, double radius, std::vector<std::uint32_t>& out) {
  out.clear();
  lo_x_ = column(centre.x() - radius);
  lo_y_ = column(centre.y() - radius);
  hi_x_ = column(centre.x() + radius);
  hi_y_ = column(centre.y() + radius);
  // Cells as doubles: the square may span 2^31 columns each way. Walking the grid's cells costs
  // about what visiting as many cells of the square would, and creates none.
  const double square_cells = static_cast<double>(hi_x_ - lo_x_ + 3) * static_cast<double>(hi_y_ - lo_y_ + 3);
  wide_ = square_cells > std::max(kWideQueryCells, 4.0 * static_cast<double>(cells_.size()));
  if (wide_) {
    for (const auto& [cell, head] : cells_)
      if (in_last_query(cell))
        for (std::uint32_t n = head; n != kNone; n = nodes_[n].next) out.push_back(nodes_[n].index);
    return;
  }
  // One pass over the square and the ring around it: the ring's cells are only created.
  for (std::int64_t ix = lo_x_ - 1; ix <= hi_x_ + 1; ++ix)
    for (std::int64_t iy = lo_y_ - 1; iy <= hi_y_ + 1; ++iy) {
      const std::uint32_t head = cells_.try_emplace(pack(ix, iy), kNone).first->second;
      if (ix < lo_x_ || ix > hi_x_ || iy < lo_y_ || iy > hi_y_) continue;
      for (std::uint32_t n = head; n != kNone; n = nodes_[n].next) out.push_back(nodes_[n].index);
    }
}

void LandmarkGrid::list(const Vector2& centre, double radius, std::vector<std::uint32_t>& out) const {
  out.clear();
  const std::int64_t lo_x = column(centre.x() - radius), lo_y = column(centre.y() - radius);
  const std::int64_t hi_x = column(centre.x() + radius), hi_y = column(centre.y() + radius);
  const auto walk = [&](std::uint32_t head) {
    for (std::uint32_t n = head; n != kNone; n = nodes_[n].next) out.push_back(nodes_[n].index);
  };
  const double square_cells = static_cast<double>(hi_x - lo_x + 1) * static_cast<double>(hi_y - lo_y + 1);
  if (square_cells > static_cast<double>(cells_.size())) {
    for (const auto& [cell, head] : cells_) {
      const std::int64_t ix = column_x(cell), iy = column_y(cell);
      if (ix >= lo_x && ix <= hi_x && iy >= lo_y && iy <= hi_y) walk(head);
    }
    return;
  }
  for (std::int64_t ix = lo_x; ix <= hi_x; ++ix)
    for (std::int64_t iy = lo_y; iy <= hi_y; ++iy)
      if (const auto it = cells_.find(pack(ix, iy)); it != cells_.end()) walk(it->second);
}

}  // namespace slamkit
