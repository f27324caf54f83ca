#include "slamkit/filters/information_factor.hpp"

namespace slamkit {

bool InformationFactor::factorise(const InformationGraph& graph) {
  const bool reorder = graph.pattern_version() != analysed_pattern_;
  if (reorder) {
    order_ = graph.fill_reducing_order();
    to_ordered_.resize(static_cast<Eigen::Index>(3 + 2 * graph.landmarks()));
    int row = 0;
    for (const int block : order_)
      for (int i = 0; i < InformationGraph::block_rows(block); ++i)
        to_ordered_.indices()[InformationGraph::block_row(block) + i] = row++;
  }
  graph.to_sparse_upper(order_, ordered_);
  if (reorder) {
    llt_.analyzePattern(ordered_);
    analysed_pattern_ = graph.pattern_version();
  }
  llt_.factorize(ordered_);
  return llt_.info() == Eigen::Success;
}

Eigen::MatrixXd InformationFactor::solve(const Eigen::MatrixXd& b) const {
  return to_ordered_.transpose() * llt_.solve(to_ordered_ * b);
}

}  // namespace slamkit
