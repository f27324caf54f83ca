#pragma once
// P -= A B^T on the lower triangle of a column-major P: the EKF's covariance downdate (A = B = C, with
// C C^T = W S W^T) and the compressed EKF's flush (A = U, B = U psi). With k columns in A and B it
// does k fused multiply-adds per stored element for 16 bytes of P read and written, so for the k ~ 20
// of a scan it is bound by the floating-point units, not by memory (docs/performance.md).
//
// How: A and B are first packed into panels of one SIMD vector's worth of rows, k-major, so that the
// register kernel reads them contiguously; the triangle is then cut into row tiles whose packed A
// stays in the first-level cache while the kernel sweeps the columns left of the tile's end, holding
// a block of 3 vectors x 8 columns of P in registers over all k. Row tiles are independent, so a
// WorkerPool shares them out, split so that each thread gets an equal part of the triangle's area.
//
// Every element is computed the same way whichever tile, thread or kernel edge case it falls in: its
// k products summed in order by fused multiply-adds from zero, then subtracted from P. The result is
// therefore the same bit for bit for any number of threads. Entries just above the diagonal (within
// a register block of it) are written too: the upper triangle is not meaningful in this storage.
//
// The workspace (the packed panels) only grows, so once the sizes stop growing apply() allocates
// nothing.
#include <Eigen/Core>

namespace slamkit {

class WorkerPool;

class LowerDowndate {
 public:
  /// P(i, j) -= sum_l A(i, l) B(j, l) for i >= j; `a` and `b` have p.rows() rows and the same number
  /// of columns. Passing the same matrix as both packs it once. `pool` (may be null) shares the row
  /// tiles out when the work is large enough to be worth waking the threads.
  void apply(Eigen::Ref<Eigen::MatrixXd> p, const Eigen::Ref<const Eigen::MatrixXd>& a,
             const Eigen::Ref<const Eigen::MatrixXd>& b, WorkerPool* pool = nullptr);

  /// Multiply-adds of one apply() for dimension n and k columns (the lower triangle's n (n + 1) / 2
  /// elements times k): half the floating-point operations.
  static double fused_multiply_adds(double n, double k) { return 0.5 * n * (n + 1.0) * k; }

 private:
  /// Rows [begin, end) of the triangle (begin a multiple of the row tile) from the packed panels.
  static void rows(Eigen::Ref<Eigen::MatrixXd> p, const double* a, const double* b, Eigen::Index k,
                   Eigen::Index begin, Eigen::Index end);

  Eigen::VectorXd packed_a_, packed_b_;  // aligned for the vector loads
};

}  // namespace slamkit
