#pragma once
// The information matrix of a landmark SLAM state, stored by blocks as the graph it is: a node for
// the vehicle (3 rows) and one per landmark (2 rows, in map order), an edge wherever two variables
// share information. The information filters' steps each touch the vehicle, the landmarks linked to
// it and the landmarks observed, so that a step costs what those few blocks cost, however large the
// map, which a compressed sparse matrix cannot give: inserting one entry into it moves every entry
// after it.
//
// Rows: the vehicle's first, then each landmark's two in map order (3 + 2 i), as the filters' states.
#include <Eigen/SparseCore>
#include <cstdint>
#include <span>
#include <vector>

#include "slamkit/core/types.hpp"

namespace slamkit {

class InformationGraph {
 public:
  using VehicleBlock = Eigen::Matrix<double, 3, 2>;  // Omega(vehicle, landmark)
  struct VehicleLink {
    std::uint32_t landmark;
    VehicleBlock block;
  };
  struct Link {
    std::uint32_t landmark;
    Matrix2 block;  // Omega(this landmark, that one)
  };
  /// Variables of a dense block, in its row order: the vehicle's 3 rows (if `vehicle`), then 2 rows
  /// for each landmark in the order listed.
  struct Variables {
    bool vehicle = false;
    std::vector<std::size_t> landmarks;
    Eigen::Index rows() const { return (vehicle ? 3 : 0) + 2 * static_cast<Eigen::Index>(landmarks.size()); }
    /// The first row of `landmarks[k]` within the block.
    Eigen::Index row(std::size_t k) const { return (vehicle ? 3 : 0) + 2 * static_cast<Eigen::Index>(k); }
  };

  explicit InformationGraph(const Matrix3& vehicle = Matrix3::Zero()) : vehicle_(vehicle) {}

  std::size_t landmarks() const { return nodes_.size(); }
  /// Entries a sparse matrix holding both triangles would store.
  std::size_t nonzeros() const;
  /// Changes whenever an edge or a node comes or goes (not when only values change), to a value no
  /// other graph's pattern has had: what a sparse factorisation's analysis depends on.
  std::uint64_t pattern_version() const { return pattern_version_; }

  Matrix3& vehicle() { return vehicle_; }
  const Matrix3& vehicle() const { return vehicle_; }
  Matrix2& own(std::size_t landmark) { return nodes_[landmark].own; }
  const Matrix2& own(std::size_t landmark) const { return nodes_[landmark].own; }
  /// The landmarks linked to the vehicle, by landmark index.
  std::vector<VehicleLink>& vehicle_links() { return vehicle_links_; }
  const std::vector<VehicleLink>& vehicle_links() const { return vehicle_links_; }
  /// The landmarks linked to `landmark`, by index.
  const std::vector<Link>& links(std::size_t landmark) const { return nodes_[landmark].links; }
  /// Omega(vehicle, landmark), or nullptr where there is no edge.
  const VehicleBlock* vehicle_link(std::size_t landmark) const;

  /// Omega(vehicle, landmark) += block (and its transpose below the diagonal).
  void add_vehicle_link(std::size_t landmark, const VehicleBlock& block);
  /// Omega(a, b) += block and Omega(b, a) += block^T, for a != b.
  void add_link(std::size_t a, std::size_t b, const Matrix2& block);
  /// Drops the vehicle's edge to `landmark` (its value taken as zero).
  void remove_vehicle_link(std::size_t landmark);
  /// Drops every edge of `landmark`, keeping the node with its own block.
  void isolate(std::size_t landmark);
  /// Drops every edge of the vehicle, keeping its own block.
  void isolate_vehicle();
  /// A new landmark with information `own` and no edges; returns its index.
  std::size_t append_landmark(const Matrix2& own);
  /// Drops landmark `index` (and its edges); the landmarks after it move down by one.
  void remove_landmark(std::size_t index);

  /// `variables` and the variables linked to any of them (each once, in index order).
  Variables neighbourhood(const Variables& variables) const;
  /// Omega over `variables`, dense.
  Eigen::MatrixXd gather(const Variables& variables) const;
  /// Omega over `variables` += change (symmetric), creating the edges it needs. Exact zeros off the
  /// diagonal create none.
  void scatter_add(const Variables& variables, const Eigen::MatrixXd& change);

  /// Omega as a sparse matrix, both triangles stored.
  Eigen::SparseMatrix<double> to_sparse() const;
  /// Block `block` of the variables (0 the vehicle, 1 + i landmark i): its first row in Omega, and
  /// how many rows it has.
  static Eigen::Index block_row(int block) { return block == 0 ? 0 : 1 + 2 * static_cast<Eigen::Index>(block); }
  static int block_rows(int block) { return block == 0 ? 3 : 2; }
  /// A fill-reducing elimination order of the variables, by block (0 the vehicle, 1 + i landmark i):
  /// approximate minimum degree on the graph of blocks. A block's rows have the same neighbours, so
  /// ordering blocks loses nothing against ordering rows, and the graph is a quarter of the size.
  std::vector<int> fill_reducing_order() const;
  /// Writes the upper triangle of P Omega P^T into `out`, where P puts block order[k] k-th (a
  /// block's rows together, in their order), each column's rows sorted: what a Cholesky
  /// factorisation in that order reads. `out`'s storage is reused where it is large enough (a
  /// factorisation per scan writes tens of megabytes each time on a city's map).
  void to_sparse_upper(std::span<const int> order, Eigen::SparseMatrix<double>& out) const;
  /// The graph of a sparse matrix holding both triangles of a symmetric one (3 + 2 n rows).
  static InformationGraph from_sparse(const Eigen::SparseMatrix<double>& omega);

 private:
  struct Node {
    Matrix2 own = Matrix2::Zero();
    std::vector<Link> links;  // sorted by landmark
  };
  VehicleLink* find_vehicle_link(std::size_t landmark);
  std::size_t link_entries() const;  // every landmark's links, each pair counted from both ends
  Matrix2& link_block(std::size_t a, std::size_t b);  // created as zero if missing

  Matrix3 vehicle_;
  std::vector<VehicleLink> vehicle_links_;  // sorted by landmark
  std::vector<Node> nodes_;
  std::uint64_t pattern_version_ = 0;
};

}  // namespace slamkit
