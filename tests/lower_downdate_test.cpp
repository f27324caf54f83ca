// The covariance downdate kernel: P -= A B^T on the lower triangle, against Eigen's product, at the
// sizes where its register blocks, row tiles and scalar edges meet, and the same bits on any number
// of threads.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>

#include "slamkit/filters/lower_downdate.hpp"
#include "slamkit/filters/worker_pool.hpp"

using namespace slamkit;

namespace {

struct DowndateCase {
  Eigen::MatrixXd p;  // with a margin of rows and columns beyond the n x n block downdated
  Eigen::MatrixXd a, b;
};

DowndateCase make_case(Eigen::Index n, Eigen::Index k, bool symmetric) {
  std::srand(static_cast<unsigned>(n * 131 + k));
  DowndateCase c;
  c.p = Eigen::MatrixXd::Random(n + 5, n + 3);
  c.a = Eigen::MatrixXd::Random(n, k);
  c.b = symmetric ? c.a : Eigen::MatrixXd::Random(n, k);
  return c;
}

}  // namespace

TEST(LowerDowndate, EqualsTheProductOnTheLowerTriangleAndLeavesTheRestAlone) {
  // Sizes around the vector width (2 to 8 lanes), the 3-vector register block, the 8-column block
  // and the 96-row tile; depths from one observation row to a busy scan.
  for (const Eigen::Index n : {1, 2, 7, 8, 9, 16, 23, 24, 25, 95, 96, 97, 200, 389})
    for (const Eigen::Index k : {1, 2, 3, 20, 33})
      for (const bool symmetric : {true, false}) {
        const DowndateCase c = make_case(n, k, symmetric);
        Eigen::MatrixXd expected = c.p;
        expected.topLeftCorner(n, n) -= c.a * c.b.transpose();
        Eigen::MatrixXd p = c.p;
        LowerDowndate downdate;
        downdate.apply(p.topLeftCorner(n, n), c.a, symmetric ? c.a : c.b);
        for (Eigen::Index j = 0; j < p.cols(); ++j)
          for (Eigen::Index i = 0; i < p.rows(); ++i) {
            if (i < n && j < n && i >= j)
              ASSERT_NEAR(p(i, j), expected(i, j), 1e-13 * static_cast<double>(k)) << n << " " << k << " " << i << " " << j;
            else if (i >= n || j >= n)
              ASSERT_EQ(p(i, j), c.p(i, j)) << "outside the block: " << n << " " << k << " " << i << " " << j;
          }
      }
}

TEST(LowerDowndate, SameBitsOnAnyNumberOfThreads) {
  // Large enough (about 9 million multiply-adds) that the work is shared out.
  const Eigen::Index n = 1003, k = 18;
  const DowndateCase c = make_case(n, k, false);
  Eigen::MatrixXd one = c.p;
  LowerDowndate serial;
  serial.apply(one.topLeftCorner(n, n), c.a, c.b);
  for (const unsigned threads : {2U, 3U, 5U}) {
    WorkerPool pool(threads);
    Eigen::MatrixXd shared = c.p;
    LowerDowndate downdate;
    downdate.apply(shared.topLeftCorner(n, n), c.a, c.b, &pool);
    for (Eigen::Index j = 0; j < n; ++j)
      for (Eigen::Index i = j; i < n; ++i) ASSERT_EQ(shared(i, j), one(i, j)) << threads << " threads, " << i << " " << j;
  }
}

TEST(LowerDowndate, EveryEntryIsItsProductsSummedInOrderFromZero) {
  // The header's promise, which the thread-count invariance rests on: wherever an entry falls (a
  // full register block, the diagonal, the last rows short of a vector, the last columns), it is
  // P(i, j) minus its k products summed in order by multiply-adds from zero, to the bit.
  for (const Eigen::Index n : {3, 9, 23, 97, 389}) {
    const Eigen::Index k = 20;
    const DowndateCase c = make_case(n, k, false);
    Eigen::MatrixXd p = c.p;
    LowerDowndate downdate;
    downdate.apply(p.topLeftCorner(n, n), c.a, c.b);
    for (Eigen::Index j = 0; j < n; ++j)
      for (Eigen::Index i = j; i < n; ++i) {
        double sum = 0.0;
        for (Eigen::Index l = 0; l < k; ++l)
#ifdef __FMA__
          sum = std::fma(c.a(i, l), c.b(j, l), sum);
#else
          sum = c.a(i, l) * c.b(j, l) + sum;
#endif
        ASSERT_EQ(p(i, j), c.p(i, j) - sum) << n << ": " << i << " " << j;
      }
  }
}

TEST(LowerDowndate, ReusesItsWorkspaceAcrossShapes) {
  // Larger, then smaller, then wider operands through one object: the packed panels of an earlier
  // call must not leak into a later one.
  LowerDowndate downdate;
  for (const auto& [n, k] : {std::pair<Eigen::Index, Eigen::Index>{300, 20}, {50, 4}, {120, 40}}) {
    const DowndateCase c = make_case(n, k, false);
    Eigen::MatrixXd p = c.p;
    downdate.apply(p.topLeftCorner(n, n), c.a, c.b);
    const Eigen::MatrixXd expected = c.p.topLeftCorner(n, n) - c.a * c.b.transpose();
    const Eigen::MatrixXd difference =
        (p.topLeftCorner(n, n) - expected).triangularView<Eigen::Lower>().toDenseMatrix();
    EXPECT_LT(difference.cwiseAbs().maxCoeff(), 1e-12) << n << " x " << k;
  }
}
