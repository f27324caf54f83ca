#include "slamkit/assoc/map_matching.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <limits>

#include "slamkit/core/chi_square.hpp"

namespace slamkit {

namespace {

constexpr double kInfiniteDistance = std::numeric_limits<double>::infinity();

/// nu^T S^-1 nu for a 2x2 covariance, infinite unless S is positive definite.
double mahalanobis2(const Vector2& nu, const Matrix2& s) {
  const double det = s(0, 0) * s(1, 1) - s(0, 1) * s(1, 0);
  if (!(s(0, 0) > 0.0 && det > 0.0)) return kInfiniteDistance;
  return (s(1, 1) * nu[0] * nu[0] - (s(0, 1) + s(1, 0)) * nu[0] * nu[1] + s(0, 0) * nu[1] * nu[1]) / det;
}

}  // namespace

const std::vector<LandmarkPair>& MapMatcher::match(std::span<const std::size_t> recent,
                                                   std::span<const std::size_t> old, const GaussianMapView& map,
                                                   double probability, std::size_t max_nodes, MapMatchStats* stats) {
  map_ = &map;
  max_nodes_ = max_nodes;
  nodes_ = 0;
  if (probability != gate_probability_) {
    joint_gate_.assign(1, 0.0);
    gate_probability_ = probability;
  }
  if (joint_gate_.size() < 2) joint_gate_.push_back(eval::chi_square_quantile(probability, 2.0));
  options_.clear();
  begin_.assign(1, 0);
  for (const std::size_t r : recent) {
    const std::size_t first = options_.size();
    for (const std::size_t o : old) {
      const LandmarkPair pair{r, o};
      const double d2 = mahalanobis2(discrepancy(pair), covariance(pair, pair));
      if (d2 < joint_gate_[1]) options_.push_back({pair, d2});
    }
    if (stats) stats->pairs_tested += old.size();
    if (options_.size() == first) continue;
    std::sort(options_.begin() + static_cast<std::ptrdiff_t>(first), options_.end(),
              [](const Option& a, const Option& b) { return a.d2 < b.d2; });
    begin_.push_back(options_.size());
  }
  const std::size_t with_options = begin_.size() - 1;
  // Landmarks with fewer options first: their branches are decided early and prune the most.
  order_.resize(with_options);
  for (std::size_t i = 0; i < with_options; ++i) order_[i] = i;
  std::stable_sort(order_.begin(), order_.end(), [&](std::size_t a, std::size_t b) {
    return begin_[a + 1] - begin_[a] < begin_[b + 1] - begin_[b];
  });
  for (std::size_t k = joint_gate_.size(); k <= with_options; ++k)
    joint_gate_.push_back(eval::chi_square_quantile(probability, 2.0 * double(k)));
  const auto rows = 2 * static_cast<Eigen::Index>(with_options);
  if (s_.rows() < rows) {
    s_.resize(rows, rows);
    nu_.resize(rows);
  }
  current_.clear();
  current_d2_.clear();
  best_.clear();
  best_d2_ = kInfiniteDistance;
  search(0);
  if (stats) stats->nodes += nodes_;
  return best_;
}

Vector2 MapMatcher::discrepancy(const LandmarkPair& p) const {
  return map_->landmark_position(p.original) - map_->landmark_position(p.duplicate);
}

Matrix2 MapMatcher::covariance(const LandmarkPair& a, const LandmarkPair& b) const {
  return map_->landmark_cross_covariance(a.original, b.original) -
         map_->landmark_cross_covariance(a.original, b.duplicate) -
         map_->landmark_cross_covariance(a.duplicate, b.original) +
         map_->landmark_cross_covariance(a.duplicate, b.duplicate);
}

// Hypotheses hold a handful of pairs, so the joint distance is recomputed rather than extended.
double MapMatcher::joint_d2() {
  const auto k = static_cast<Eigen::Index>(current_.size());
  auto s = s_.topLeftCorner(2 * k, 2 * k);
  auto nu = nu_.head(2 * k);
  for (Eigen::Index i = 0; i < k; ++i) {
    nu.segment<2>(2 * i) = discrepancy(current_[i]);
    for (Eigen::Index j = 0; j <= i; ++j) s.block<2, 2>(2 * i, 2 * j) = covariance(current_[i], current_[j]);
  }
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(s);  // in place, from the lower triangle
  if (llt.info() != Eigen::Success) return kInfiniteDistance;
  llt.matrixL().solveInPlace(nu);
  return nu.squaredNorm();
}

bool MapMatcher::better(std::size_t pairs, double d2) const {
  return pairs > best_.size() || (pairs == best_.size() && pairs > 0 && d2 < best_d2_);
}

void MapMatcher::search(std::size_t depth) {
  if (nodes_ >= max_nodes_) return;
  ++nodes_;
  const double d2 = current_d2_.empty() ? 0.0 : current_d2_.back();
  if (depth == order_.size()) {
    if (better(current_.size(), d2)) {
      best_ = current_;
      best_d2_ = d2;
    }
    return;
  }
  const std::size_t remaining = order_.size() - depth - 1, landmark = order_[depth];
  for (std::size_t i = begin_[landmark]; i < begin_[landmark + 1]; ++i) {
    const LandmarkPair& pair = options_[i].pair;
    if (!better(current_.size() + 1 + remaining, d2)) break;
    if (std::any_of(current_.begin(), current_.end(), [&](const LandmarkPair& p) { return p.original == pair.original; }))
      continue;
    current_.push_back(pair);
    const double extended = joint_d2();
    if (extended < joint_gate_[current_.size()]) {
      current_d2_.push_back(extended);
      search(depth + 1);
      current_d2_.pop_back();
    }
    current_.pop_back();
  }
  if (better(current_.size() + remaining, d2)) search(depth + 1);  // this landmark left unpaired
}

}  // namespace slamkit
