#include "slamkit/filters/information_graph.hpp"

#include <Eigen/OrderingMethods>
#include <algorithm>
#include <atomic>

namespace slamkit {

namespace {

// Unique across graphs, so that a graph built anew (a fusion's) never shows the version of the
// pattern another graph had, which a factorisation analysed for that one would take as its own.
std::uint64_t new_pattern_version() {
  static std::atomic<std::uint64_t> last{0};
  return ++last;
}

template <class Edges>
auto find_edge(Edges& edges, std::size_t landmark) {
  return std::lower_bound(edges.begin(), edges.end(), landmark,
                          [](const auto& edge, std::size_t l) { return edge.landmark < l; });
}

// Where each of `variables`' landmarks sits among them, for lookups while walking edges.
class Positions {
 public:
  explicit Positions(const InformationGraph::Variables& variables) {
    sorted_.reserve(variables.landmarks.size());
    for (std::size_t k = 0; k < variables.landmarks.size(); ++k) sorted_.emplace_back(variables.landmarks[k], k);
    std::sort(sorted_.begin(), sorted_.end());
  }
  /// The position of `landmark` in the list, or -1.
  std::ptrdiff_t operator()(std::size_t landmark) const {
    const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::make_pair(landmark, std::size_t{0}));
    return it != sorted_.end() && it->first == landmark ? static_cast<std::ptrdiff_t>(it->second) : -1;
  }

 private:
  std::vector<std::pair<std::size_t, std::size_t>> sorted_;
};

}  // namespace

std::size_t InformationGraph::link_entries() const {
  std::size_t links = 0;
  for (const Node& node : nodes_) links += node.links.size();
  return links;
}

std::size_t InformationGraph::nonzeros() const {
  return 9 + 4 * nodes_.size() + 12 * vehicle_links_.size() + 4 * link_entries();
}

const InformationGraph::VehicleBlock* InformationGraph::vehicle_link(std::size_t landmark) const {
  const auto it = find_edge(vehicle_links_, landmark);
  return it != vehicle_links_.end() && it->landmark == landmark ? &it->block : nullptr;
}

InformationGraph::VehicleLink* InformationGraph::find_vehicle_link(std::size_t landmark) {
  auto it = find_edge(vehicle_links_, landmark);
  if (it == vehicle_links_.end() || it->landmark != landmark) {
    it = vehicle_links_.insert(it, {static_cast<std::uint32_t>(landmark), VehicleBlock::Zero()});
    pattern_version_ = new_pattern_version();
  }
  return &*it;
}

Matrix2& InformationGraph::link_block(std::size_t a, std::size_t b) {
  std::vector<Link>& links = nodes_[a].links;
  auto it = find_edge(links, b);
  if (it == links.end() || it->landmark != b) {
    it = links.insert(it, {static_cast<std::uint32_t>(b), Matrix2::Zero()});
    pattern_version_ = new_pattern_version();
  }
  return it->block;
}

void InformationGraph::add_vehicle_link(std::size_t landmark, const VehicleBlock& block) {
  find_vehicle_link(landmark)->block += block;
}

void InformationGraph::add_link(std::size_t a, std::size_t b, const Matrix2& block) {
  link_block(a, b) += block;
  link_block(b, a) += block.transpose();
}

void InformationGraph::remove_vehicle_link(std::size_t landmark) {
  const auto it = find_edge(vehicle_links_, landmark);
  if (it == vehicle_links_.end() || it->landmark != landmark) return;
  vehicle_links_.erase(it);
  pattern_version_ = new_pattern_version();
}

void InformationGraph::isolate(std::size_t landmark) {
  remove_vehicle_link(landmark);
  for (const Link& link : nodes_[landmark].links) {
    std::vector<Link>& other = nodes_[link.landmark].links;
    other.erase(find_edge(other, landmark));
  }
  if (!nodes_[landmark].links.empty()) pattern_version_ = new_pattern_version();
  nodes_[landmark].links.clear();
}

void InformationGraph::isolate_vehicle() {
  if (vehicle_links_.empty()) return;
  vehicle_links_.clear();
  pattern_version_ = new_pattern_version();
}

std::size_t InformationGraph::append_landmark(const Matrix2& own) {
  nodes_.push_back({own, {}});
  pattern_version_ = new_pattern_version();
  return nodes_.size() - 1;
}

void InformationGraph::remove_landmark(std::size_t index) {
  isolate(index);
  nodes_.erase(nodes_.begin() + static_cast<std::ptrdiff_t>(index));
  // Renumbering keeps every list sorted: only indices above the removed one move, all by one.
  const auto renumber = [index](auto& edges) {
    for (auto& edge : edges)
      if (edge.landmark > index) --edge.landmark;
  };
  renumber(vehicle_links_);
  for (Node& node : nodes_) renumber(node.links);
  pattern_version_ = new_pattern_version();
}

InformationGraph::Variables InformationGraph::neighbourhood(const Variables& variables) const {
  Variables out;
  out.vehicle = variables.vehicle;
  out.landmarks = variables.landmarks;
  if (variables.vehicle)
    for (const VehicleLink& link : vehicle_links_) out.landmarks.push_back(link.landmark);
  for (const std::size_t l : variables.landmarks) {
    for (const Link& link : nodes_[l].links) out.landmarks.push_back(link.landmark);
    if (vehicle_link(l) != nullptr) out.vehicle = true;
  }
  std::sort(out.landmarks.begin(), out.landmarks.end());
  out.landmarks.erase(std::unique(out.landmarks.begin(), out.landmarks.end()), out.landmarks.end());
  return out;
}

Eigen::MatrixXd InformationGraph::gather(const Variables& variables) const {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(variables.rows(), variables.rows());
  const Positions position(variables);
  if (variables.vehicle) {
    m.topLeftCorner<3, 3>() = vehicle_;
    for (const VehicleLink& link : vehicle_links_)
      if (const std::ptrdiff_t k = position(link.landmark); k >= 0) {
        const Eigen::Index r = variables.row(static_cast<std::size_t>(k));
        m.block<3, 2>(0, r) = link.block;
        m.block<2, 3>(r, 0) = link.block.transpose();
      }
  }
  for (std::size_t k = 0; k < variables.landmarks.size(); ++k) {
    const Eigen::Index r = variables.row(k);
    const Node& node = nodes_[variables.landmarks[k]];
    m.block<2, 2>(r, r) = node.own;
    for (const Link& link : node.links)
      if (const std::ptrdiff_t j = position(link.landmark); j >= 0)
        m.block<2, 2>(r, variables.row(static_cast<std::size_t>(j))) = link.block;
  }
  return m;
}

void InformationGraph::scatter_add(const Variables& variables, const Eigen::MatrixXd& change) {
  const std::size_t count = variables.landmarks.size();
  if (variables.vehicle) {
    vehicle_ += change.topLeftCorner<3, 3>();
    for (std::size_t k = 0; k < count; ++k) {
      const VehicleBlock block = change.block<3, 2>(0, variables.row(k));
      if (!block.isZero(0.0)) find_vehicle_link(variables.landmarks[k])->block += block;
    }
  }
  for (std::size_t a = 0; a < count; ++a) {
    const Eigen::Index ra = variables.row(a);
    nodes_[variables.landmarks[a]].own += change.block<2, 2>(ra, ra);
    for (std::size_t b = a + 1; b < count; ++b) {
      const Matrix2 block = change.block<2, 2>(ra, variables.row(b));
      if (!block.isZero(0.0)) add_link(variables.landmarks[a], variables.landmarks[b], block);
    }
  }
}

Eigen::SparseMatrix<double> InformationGraph::to_sparse() const {
  // Written straight into compressed columns: every edge list is sorted by landmark, so each
  // column's rows come out in order. Through triplets, their sort cost more than the numerical
  // factorisation that follows it (docs/filters.md, the city).
  using Index = Eigen::SparseMatrix<double>::StorageIndex;
  const auto row = [](std::size_t landmark) { return static_cast<Eigen::Index>(3 + 2 * landmark); };
  const Eigen::Index n = row(nodes_.size());
  Eigen::SparseMatrix<double> m(n, n);
  m.resizeNonZeros(static_cast<Eigen::Index>(nonzeros()));
  Index* const outer = m.outerIndexPtr();
  Index* const inner = m.innerIndexPtr();
  double* const value = m.valuePtr();
  Index at = 0;
  const auto put = [&](Eigen::Index r, double v) {
    inner[at] = static_cast<Index>(r);
    value[at++] = v;
  };
  for (Eigen::Index c = 0; c < 3; ++c) {
    outer[c] = at;
    for (Eigen::Index r = 0; r < 3; ++r) put(r, vehicle_(r, c));
    for (const VehicleLink& link : vehicle_links_)
      for (Eigen::Index i = 0; i < 2; ++i) put(row(link.landmark) + i, link.block(c, i));
  }
  auto to_vehicle = vehicle_links_.begin();
  for (std::size_t l = 0; l < nodes_.size(); ++l) {
    const Node& node = nodes_[l];
    const bool linked = to_vehicle != vehicle_links_.end() && to_vehicle->landmark == l;
    const auto later = find_edge(node.links, l);  // the first link to a landmark after this one
    for (Eigen::Index j = 0; j < 2; ++j) {
      outer[row(l) + j] = at;
      if (linked)
        for (Eigen::Index r = 0; r < 3; ++r) put(r, to_vehicle->block(r, j));
      // Omega(that landmark, this one) = the stored Omega(this, that) transposed.
      const auto put_link = [&](const Link& link) {
        for (Eigen::Index i = 0; i < 2; ++i) put(row(link.landmark) + i, link.block(j, i));
      };
      std::for_each(node.links.begin(), later, put_link);
      for (Eigen::Index i = 0; i < 2; ++i) put(row(l) + i, node.own(i, j));
      std::for_each(later, node.links.end(), put_link);
    }
    if (linked) ++to_vehicle;
  }
  outer[n] = at;
  return m;
}

std::vector<int> InformationGraph::fill_reducing_order() const {
  // Block 0 the vehicle, 1 + i landmark i; both triangles, each column's rows sorted.
  using Pattern = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
  const std::size_t entries = 1 + 2 * vehicle_links_.size() + nodes_.size() + link_entries();
  const auto blocks = static_cast<Eigen::Index>(nodes_.size() + 1);
  Pattern pattern(blocks, blocks);
  pattern.resizeNonZeros(static_cast<Eigen::Index>(entries));
  int* const outer = pattern.outerIndexPtr();
  int* const inner = pattern.innerIndexPtr();
  std::fill(pattern.valuePtr(), pattern.valuePtr() + entries, 1.0);
  int at = 0;
  outer[0] = at;
  inner[at++] = 0;
  for (const VehicleLink& link : vehicle_links_) inner[at++] = static_cast<int>(link.landmark) + 1;
  auto to_vehicle = vehicle_links_.begin();
  for (std::size_t l = 0; l < nodes_.size(); ++l) {
    outer[l + 1] = at;
    if (to_vehicle != vehicle_links_.end() && to_vehicle->landmark == l) {
      inner[at++] = 0;
      ++to_vehicle;
    }
    const std::vector<Link>& links = nodes_[l].links;
    const auto later = find_edge(links, l);
    for (auto it = links.begin(); it != later; ++it) inner[at++] = static_cast<int>(it->landmark) + 1;
    inner[at++] = static_cast<int>(l) + 1;
    for (auto it = later; it != links.end(); ++it) inner[at++] = static_cast<int>(it->landmark) + 1;
  }
  outer[blocks] = at;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> order;
  Eigen::AMDOrdering<int>()(pattern, order);
  return {order.indices().data(), order.indices().data() + order.size()};
}

void InformationGraph::to_sparse_upper(std::span<const int> order, Eigen::SparseMatrix<double>& m) const {
  using Index = Eigen::SparseMatrix<double>::StorageIndex;
  const std::size_t blocks = nodes_.size() + 1;
  std::vector<int> position(blocks);
  for (std::size_t k = 0; k < blocks; ++k) position[static_cast<std::size_t>(order[k])] = static_cast<int>(k);
  std::vector<Index> first_row(blocks + 1, 0);  // by position
  for (std::size_t k = 0; k < blocks; ++k) first_row[k + 1] = first_row[k] + block_rows(order[k]);
  const Eigen::Index n = first_row[blocks];
  m.resize(n, n);
  // Half of the entries between two blocks, and each diagonal block's upper triangle (6 and 3).
  m.resizeNonZeros(static_cast<Eigen::Index>((nonzeros() - 9 - 4 * nodes_.size()) / 2 + 6 + 3 * nodes_.size()));
  Index* const outer = m.outerIndexPtr();
  Index* const inner = m.innerIndexPtr();
  double* const value = m.valuePtr();
  Index at = 0;
  // Omega(a, b) for a block a placed before b: `height` rows, entry (i, j) at data[i * di + j * dj].
  struct Piece {
    int position;
    int height;
    const double* data;
    int di, dj;
  };
  std::vector<Piece> pieces;
  const auto write = [&](std::size_t p, int width, const double* diagonal, int dj) {
    std::sort(pieces.begin(), pieces.end(), [](const Piece& a, const Piece& b) { return a.position < b.position; });
    for (int j = 0; j < width; ++j) {
      outer[first_row[p] + j] = at;
      for (const Piece& piece : pieces)
        for (int i = 0; i < piece.height; ++i) {
          inner[at] = first_row[static_cast<std::size_t>(piece.position)] + i;
          value[at++] = piece.data[i * piece.di + j * piece.dj];
        }
      for (int i = 0; i <= j; ++i) {
        inner[at] = first_row[p] + i;
        value[at++] = diagonal[i + j * dj];
      }
    }
  };
  for (std::size_t p = 0; p < blocks; ++p) {
    pieces.clear();
    const int before = static_cast<int>(p);
    if (order[p] == 0) {
      // Omega(landmark, vehicle) = the stored Omega(vehicle, landmark) transposed.
      for (const VehicleLink& link : vehicle_links_)
        if (const int q = position[link.landmark + 1]; q < before) pieces.push_back({q, 2, link.block.data(), 3, 1});
      write(p, 3, vehicle_.data(), 3);
      continue;
    }
    const auto l = static_cast<std::size_t>(order[p] - 1);
    if (const VehicleBlock* link = vehicle_link(l); link && position[0] < before)
      pieces.push_back({position[0], 3, link->data(), 1, 3});
    // Omega(that landmark, this one) = the stored Omega(this, that) transposed.
    for (const Link& link : nodes_[l].links)
      if (const int q = position[link.landmark + 1]; q < before) pieces.push_back({q, 2, link.block.data(), 2, 1});
    write(p, 2, nodes_[l].own.data(), 2);
  }
  outer[n] = at;
}

InformationGraph InformationGraph::from_sparse(const Eigen::SparseMatrix<double>& omega) {
  InformationGraph graph;
  graph.nodes_.resize(static_cast<std::size_t>((omega.rows() - 3) / 2));
  graph.pattern_version_ = new_pattern_version();
  for (Eigen::Index col = 0; col < omega.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(omega, col); it; ++it) {
      const Eigen::Index row = it.row();
      if (row < 3 && col < 3) {
        graph.vehicle_(row, col) = it.value();
      } else if (row < 3) {
        graph.find_vehicle_link(static_cast<std::size_t>((col - 3) / 2))->block(row, (col - 3) % 2) = it.value();
      } else if (col >= 3) {
        const auto a = static_cast<std::size_t>((row - 3) / 2), b = static_cast<std::size_t>((col - 3) / 2);
        Matrix2& block = a == b ? graph.nodes_[a].own : graph.link_block(a, b);
        block((row - 3) % 2, (col - 3) % 2) = it.value();
      }  // the vehicle's column below the diagonal: the transpose of its row, read there
    }
  return graph;
}

}  // namespace slamkit
