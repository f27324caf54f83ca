#include "slamkit/assoc/landmark_grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace slamkit {

LandmarkGrid::LandmarkGrid(double cell_size) : cell_size_(cell_size) {
  if (!(cell_size > 0.0)) throw std::invalid_argument("LandmarkGrid needs a positive cell size");
}

LandmarkGrid::Key LandmarkGrid::key(std::int64_t cx, std::int64_t cy) {
  return (static_cast<Key>(static_cast<std::uint32_t>(cx)) << 32) | static_cast<std::uint32_t>(cy);
}

LandmarkGrid::Key LandmarkGrid::key_of(const Vector2& p) const {
  return key(static_cast<std::int64_t>(std::floor(p.x() / cell_size_)),
             static_cast<std::int64_t>(std::floor(p.y() / cell_size_)));
}

void LandmarkGrid::rebuild(const std::vector<Vector2>& positions) {
  for (auto& [key, cell] : cells_) cell.clear();
  cell_of_.clear();
  for (std::size_t i = 0; i < positions.size(); ++i) add(i, positions[i]);
}

void LandmarkGrid::add(std::size_t index, const Vector2& p) {
  if (index != cell_of_.size()) throw std::invalid_argument("LandmarkGrid::add: landmarks are added in order");
  const Key k = key_of(p);
  cell_of_.push_back(k);
  cells_[k].push_back(index);
}

void LandmarkGrid::erase_from_cell(std::size_t index) {
  auto& cell = cells_[cell_of_[index]];
  cell.erase(std::find(cell.begin(), cell.end(), index));
}

void LandmarkGrid::move(std::size_t index, const Vector2& p) {
  const Key k = key_of(p);
  if (k == cell_of_[index]) return;
  erase_from_cell(index);
  cell_of_[index] = k;
  cells_[k].push_back(index);
}

void LandmarkGrid::query(const Vector2& centre, double radius, std::vector<std::size_t>& out) const {
  const auto x0 = static_cast<std::int64_t>(std::floor((centre.x() - radius) / cell_size_));
  const auto x1 = static_cast<std::int64_t>(std::floor((centre.x() + radius) / cell_size_));
  const auto y0 = static_cast<std::int64_t>(std::floor((centre.y() - radius) / cell_size_));
  const auto y1 = static_cast<std::int64_t>(std::floor((centre.y() + radius) / cell_size_));
  for (std::int64_t cx = x0; cx <= x1; ++cx)
    for (std::int64_t cy = y0; cy <= y1; ++cy) {
      const auto it = cells_.find(key(cx, cy));
      if (it != cells_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
    }
}

}  // namespace slamkit
