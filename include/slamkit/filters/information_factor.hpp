#pragma once
// The sparse Cholesky factor of an information matrix, for the information filters' exact
// covariance and mean recovery: Omega = P^T L L^T P, with P the graph's fill-reducing order of its
// blocks (InformationGraph::fill_reducing_order), found when the graph's pattern changes and kept
// while it does not. The graph writes Omega in that order straight into the triangle the
// factorisation reads, so no copy of the whole matrix is made, and ordering blocks rather than rows
// orders a graph a quarter of the size (the city's measurements are in docs/filters.md).
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cstdint>
#include <vector>

#include "slamkit/filters/information_graph.hpp"

namespace slamkit {

class InformationFactor {
 public:
  /// Factorises `graph`'s Omega; false where it is not positive definite.
  bool factorise(const InformationGraph& graph);
  /// Omega^-1 b for the last factorisation, b's rows Omega's.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const;
  Eigen::Index rows() const { return ordered_.rows(); }

 private:
  std::vector<int> order_;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> to_ordered_;  // Omega's rows to P Omega P^T's
  Eigen::SparseMatrix<double> ordered_;  // the upper triangle of P Omega P^T
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Upper, Eigen::NaturalOrdering<int>> llt_;
  std::uint64_t analysed_pattern_ = ~std::uint64_t{0};
};

}  // namespace slamkit
