#pragma once
// Dense helpers the thin junction tree filter's two files share (rows of landmarks, the checked
// factorisation of a separator's covariance).
#include <Eigen/Cholesky>
#include <stdexcept>
#include <string>
#include <vector>

namespace slamkit::tjtf_detail {

using Rows = std::vector<Eigen::Index>;

// Two rows for each landmark's first row.
inline Rows both_rows(const Rows& firsts) {
  Rows rows;
  rows.reserve(2 * firsts.size());
  for (const Eigen::Index r : firsts) {
    rows.push_back(r);
    rows.push_back(r + 1);
  }
  return rows;
}

inline Eigen::LLT<Eigen::MatrixXd> positive_definite(const Eigen::MatrixXd& m, const char* what) {
  Eigen::LLT<Eigen::MatrixXd> llt(m);
  if (llt.info() != Eigen::Success)
    throw std::logic_error(std::string("the thin junction tree met ") + what + " that is not positive definite");
  return llt;
}

inline void symmetrise(Eigen::MatrixXd& m) { m = (0.5 * (m + m.transpose())).eval(); }

// log det of a symmetric positive semi-definite block, its zero pivots taken as tiny.
inline double log_determinant(const Eigen::MatrixXd& m) {
  if (m.rows() == 0) return 0.0;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(m);
  return ldlt.vectorD().array().max(1e-300).log().sum();
}

}  // namespace slamkit::tjtf_detail
