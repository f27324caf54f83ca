#include "slamkit/filters/information_graph.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <numeric>
#include <random>

#include "slamkit/filters/information_factor.hpp"

namespace slamkit {
namespace {

// A graph of `landmarks` landmarks with random symmetric blocks on a random set of edges, built
// through the public operations.
InformationGraph random_graph(std::size_t landmarks, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> value;
  std::bernoulli_distribution linked(0.3);
  InformationGraph graph(Matrix3::Identity() * 10.0);
  for (std::size_t i = 0; i < landmarks; ++i) {
    graph.append_landmark(Matrix2::Identity() * 5.0);
    if (linked(rng)) graph.add_vehicle_link(i, InformationGraph::VehicleBlock::NullaryExpr([&] { return value(rng); }));
    for (std::size_t j = 0; j < i; ++j)
      if (linked(rng)) graph.add_link(i, j, Matrix2::NullaryExpr([&] { return value(rng); }));
  }
  return graph;
}

Eigen::Index row(std::size_t landmark) { return static_cast<Eigen::Index>(3 + 2 * landmark); }

// The dense rows of `variables` in a full matrix, in the block's order.
std::vector<Eigen::Index> rows_of(const InformationGraph::Variables& variables) {
  std::vector<Eigen::Index> rows;
  if (variables.vehicle) rows = {0, 1, 2};
  for (const std::size_t l : variables.landmarks) rows.insert(rows.end(), {row(l), row(l) + 1});
  return rows;
}

TEST(InformationGraph, SparseRoundTripKeepsEveryEntryAndCountsThem) {
  const InformationGraph graph = random_graph(12, 1);
  const Eigen::SparseMatrix<double> omega = graph.to_sparse();
  EXPECT_EQ(static_cast<std::size_t>(omega.nonZeros()), graph.nonzeros());
  const Eigen::MatrixXd dense = omega.toDense();
  EXPECT_TRUE(dense.isApprox(dense.transpose(), 0.0));
  const InformationGraph back = InformationGraph::from_sparse(omega);
  EXPECT_EQ(back.to_sparse().toDense(), dense);
  EXPECT_EQ(back.nonzeros(), graph.nonzeros());
}

// Omega entry by entry from the graph's blocks: the reference the compressed export must equal.
Eigen::MatrixXd dense_from_blocks(const InformationGraph& graph) {
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(row(graph.landmarks()), row(graph.landmarks()));
  dense.topLeftCorner<3, 3>() = graph.vehicle();
  for (const InformationGraph::VehicleLink& link : graph.vehicle_links()) {
    dense.block<3, 2>(0, row(link.landmark)) = link.block;
    dense.block<2, 3>(row(link.landmark), 0) = link.block.transpose();
  }
  for (std::size_t l = 0; l < graph.landmarks(); ++l) {
    dense.block<2, 2>(row(l), row(l)) = graph.own(l);
    for (const InformationGraph::Link& link : graph.links(l)) dense.block<2, 2>(row(l), row(link.landmark)) = link.block;
  }
  return dense;
}

TEST(InformationGraph, ExportsSortedCompressedColumnsThatEqualItsBlocks) {
  for (const std::uint32_t seed : {4u, 5u, 6u}) {
    InformationGraph graph = random_graph(15, seed);
    graph.add_vehicle_link(14, InformationGraph::VehicleBlock::Constant(0.5));  // the last landmark's columns
    const Eigen::SparseMatrix<double> omega = graph.to_sparse();
    ASSERT_TRUE(omega.isCompressed());
    EXPECT_EQ(static_cast<std::size_t>(omega.nonZeros()), graph.nonzeros());
    for (Eigen::Index col = 0; col < omega.outerSize(); ++col)
      for (Eigen::Index k = omega.outerIndexPtr()[col] + 1; k < omega.outerIndexPtr()[col + 1]; ++k)
        ASSERT_LT(omega.innerIndexPtr()[k - 1], omega.innerIndexPtr()[k]) << "column " << col;
    EXPECT_EQ(omega.toDense(), dense_from_blocks(graph)) << "seed " << seed;
  }
}

// Rows of Omega in the order of its blocks `order` (0 the vehicle, 1 + i landmark i).
std::vector<Eigen::Index> rows_in(const std::vector<int>& order) {
  std::vector<Eigen::Index> rows;
  for (const int block : order) {
    if (block == 0)
      rows.insert(rows.end(), {0, 1, 2});
    else
      rows.insert(rows.end(), {row(static_cast<std::size_t>(block - 1)), row(static_cast<std::size_t>(block - 1)) + 1});
  }
  return rows;
}

TEST(InformationGraph, ExportsTheUpperTriangleInAnOrderOfItsBlocks) {
  for (const std::uint32_t seed : {7u, 8u}) {
    InformationGraph graph = random_graph(15, seed);
    graph.add_vehicle_link(14, InformationGraph::VehicleBlock::Constant(0.5));
    std::vector<int> fill_reducing = graph.fill_reducing_order();
    std::vector<int> reversed(graph.landmarks() + 1);
    std::iota(reversed.rbegin(), reversed.rend(), 0);  // the vehicle last
    for (const std::vector<int>& order : {fill_reducing, reversed}) {
      std::vector<int> sorted = order;
      std::sort(sorted.begin(), sorted.end());
      std::vector<int> blocks(graph.landmarks() + 1);
      std::iota(blocks.begin(), blocks.end(), 0);
      ASSERT_EQ(sorted, blocks) << "not an order of the blocks";
      const std::vector<Eigen::Index> rows = rows_in(order);
      const Eigen::MatrixXd dense = dense_from_blocks(graph);
      Eigen::MatrixXd permuted(dense.rows(), dense.cols());
      for (std::size_t i = 0; i < rows.size(); ++i)
        for (std::size_t j = 0; j < rows.size(); ++j)
          permuted(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = dense(rows[i], rows[j]);
      Eigen::SparseMatrix<double> upper(1, 1);
      upper.insert(0, 0) = 1.0;  // what was there before is replaced
      graph.to_sparse_upper(order, upper);
      ASSERT_TRUE(upper.isCompressed());
      for (Eigen::Index col = 0; col < upper.outerSize(); ++col)
        for (Eigen::Index k = upper.outerIndexPtr()[col]; k < upper.outerIndexPtr()[col + 1]; ++k) {
          ASSERT_LE(upper.innerIndexPtr()[k], col) << "below the diagonal";
          if (k > upper.outerIndexPtr()[col]) ASSERT_LT(upper.innerIndexPtr()[k - 1], upper.innerIndexPtr()[k]);
        }
      EXPECT_EQ(Eigen::MatrixXd(upper.toDense()), Eigen::MatrixXd(permuted.triangularView<Eigen::Upper>()))
          << "seed " << seed;
    }
  }
}

TEST(InformationFactor, SolvesAsTheDenseMatrixThroughChangesOfValuesAndPattern) {
  InformationGraph graph = random_graph(20, 9);
  // Diagonally dominant, so positive definite.
  graph.vehicle() += 40.0 * Matrix3::Identity();
  for (std::size_t l = 0; l < graph.landmarks(); ++l) graph.own(l) += 40.0 * Matrix2::Identity();
  InformationFactor factor;
  std::mt19937 rng(3);
  std::normal_distribution<double> value;
  const auto solves_as_dense = [&] {
    ASSERT_TRUE(factor.factorise(graph));
    const Eigen::MatrixXd dense = dense_from_blocks(graph);
    ASSERT_EQ(factor.rows(), dense.rows());
    const Eigen::MatrixXd b = Eigen::MatrixXd::NullaryExpr(dense.rows(), 3, [&] { return value(rng); });
    EXPECT_LT((factor.solve(b) - dense.llt().solve(b)).cwiseAbs().maxCoeff(), 1e-12);
  };
  solves_as_dense();
  graph.own(3) += Matrix2::Identity();  // values only: the order kept
  solves_as_dense();
  graph.add_link(0, 19, Matrix2::Constant(0.2));  // an edge: a new order
  solves_as_dense();
  graph.append_landmark(40.0 * Matrix2::Identity());
  graph.add_vehicle_link(20, InformationGraph::VehicleBlock::Constant(-0.3));
  solves_as_dense();
  graph.own(5) = -Matrix2::Identity();
  EXPECT_FALSE(factor.factorise(graph));
}

TEST(InformationGraph, GatherAndScatterAgreeWithTheDenseMatrix) {
  InformationGraph graph = random_graph(10, 2);
  Eigen::MatrixXd dense = graph.to_sparse().toDense();
  const InformationGraph::Variables variables{true, {7, 2, 5}};
  const std::vector<Eigen::Index> rows = rows_of(variables);
  const Eigen::MatrixXd block = graph.gather(variables);
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t j = 0; j < rows.size(); ++j)
      EXPECT_EQ(block(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)), dense(rows[i], rows[j]));

  const Eigen::MatrixXd random = Eigen::MatrixXd::Random(variables.rows(), variables.rows());
  const Eigen::MatrixXd change = random + random.transpose();
  graph.scatter_add(variables, change);
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t j = 0; j < rows.size(); ++j)
      dense(rows[i], rows[j]) += change(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
  EXPECT_LT((graph.to_sparse().toDense() - dense).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(InformationGraph, RemovingALandmarkDropsItsRowsAndRenumbersTheRest) {
  InformationGraph graph = random_graph(9, 3);
  const Eigen::MatrixXd dense = graph.to_sparse().toDense();
  graph.remove_landmark(4);
  std::vector<Eigen::Index> kept;
  for (Eigen::Index r = 0; r < dense.rows(); ++r)
    if (r != row(4) && r != row(4) + 1) kept.push_back(r);
  Eigen::MatrixXd expected(kept.size(), kept.size());
  for (std::size_t i = 0; i < kept.size(); ++i)
    for (std::size_t j = 0; j < kept.size(); ++j)
      expected(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = dense(kept[i], kept[j]);
  EXPECT_EQ(graph.landmarks(), 8u);
  EXPECT_EQ(graph.to_sparse().toDense(), expected);
}

TEST(InformationGraph, NeighbourhoodIsTheMarkovBlanket) {
  InformationGraph graph(Matrix3::Identity());
  for (int i = 0; i < 6; ++i) graph.append_landmark(Matrix2::Identity());
  graph.add_vehicle_link(1, InformationGraph::VehicleBlock::Ones());
  graph.add_link(1, 3, Matrix2::Ones());
  graph.add_link(3, 5, Matrix2::Ones());
  const InformationGraph::Variables of_vehicle = graph.neighbourhood({true, {}});
  EXPECT_TRUE(of_vehicle.vehicle);
  EXPECT_EQ(of_vehicle.landmarks, (std::vector<std::size_t>{1}));
  const InformationGraph::Variables of_three = graph.neighbourhood({false, {3}});
  EXPECT_FALSE(of_three.vehicle);
  EXPECT_EQ(of_three.landmarks, (std::vector<std::size_t>{1, 3, 5}));
  EXPECT_TRUE(graph.neighbourhood({false, {1}}).vehicle);
}

TEST(InformationGraph, PatternVersionChangesWithEdgesNotValues) {
  InformationGraph graph = random_graph(5, 4);
  const std::uint64_t before = graph.pattern_version();
  graph.own(2) += Matrix2::Identity();
  graph.vehicle() += Matrix3::Identity();
  graph.scatter_add({false, {0}}, Eigen::MatrixXd::Identity(2, 2));  // a diagonal block only
  EXPECT_EQ(graph.pattern_version(), before);
  graph.isolate(0);
  graph.add_link(0, 1, Matrix2::Identity());
  EXPECT_NE(graph.pattern_version(), before);
  // An exact zero off the diagonal creates no edge.
  const std::size_t edges = graph.nonzeros();
  graph.scatter_add({true, {3, 4}}, Eigen::MatrixXd::Identity(7, 7));
  EXPECT_EQ(graph.nonzeros(), edges);
}

}  // namespace
}  // namespace slamkit
