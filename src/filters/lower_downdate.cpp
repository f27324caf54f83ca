#include "slamkit/filters/lower_downdate.hpp"

#include <algorithm>
#include <cmath>

#include "slamkit/filters/worker_pool.hpp"

namespace slamkit {

namespace {

// Eigen's widest packet for the build's instruction set: 8 doubles with AVX-512, 4 with AVX, 2 with SSE2.
using Packet = Eigen::internal::packet_traits<double>::type;
constexpr Eigen::Index kLanes = Eigen::internal::packet_traits<double>::size;
// The register block: 3 vectors of rows by 8 columns, 24 accumulators, which with the 3 row vectors
// and a broadcast fits AVX-512's 32 registers and keeps both FMA pipes fed (each loaded value feeds
// 8 or 3 multiply-adds).
constexpr int kBlockVectors = 3;
constexpr int kBlockCols = 8;
// Rows per tile: a multiple of every register block height, and small enough that the tile's packed A
// (96 x k doubles, 15 KB at k = 20) stays in the first-level cache while the columns go by.
constexpr Eigen::Index kTileRows = 96;
static_assert(kTileRows % (kBlockVectors * kLanes) == 0 && kBlockCols % kLanes == 0);
// Below this many multiply-adds (about 40 us on one core) waking the other threads costs more than
// it saves.
constexpr double kParallelMultiplyAdds = 2e6;

// The scalar edge cases round exactly as the vector kernel's pmadd does: fused where the build has
// FMA, a product then a sum where it has not.
inline double multiply_add(double a, double b, double acc) {
#ifdef __FMA__
  return std::fma(a, b, acc);
#else
  return a * b + acc;
#endif
}

// Panel layout: rows in groups of kLanes, each group k-major: element (i, l) at
// ((i / kLanes) * k + l) * kLanes + i % kLanes.
inline const double* panel_entry(const double* panels, Eigen::Index k, Eigen::Index i, Eigen::Index l) {
  return panels + ((i / kLanes) * k + l) * kLanes + i % kLanes;
}

// The k products of P(i..i + V kLanes, j..j + C), summed in registers from zero.
template <int V, int C>
inline void block_products(Packet (&acc)[V][C], const double* p, Eigen::Index ld, Eigen::Index i, Eigen::Index j,
                           const double* a, const double* b, Eigen::Index k) {
  using namespace Eigen::internal;
  // Each element of P is read once per downdate, so it comes from far away (L3 or memory): ask for
  // this block's lines and the next one's down the column now, to arrive while the k multiply-adds
  // run rather than after them (about twice the speed of leaving it to the hardware prefetcher).
  for (int c = 0; c < C; ++c) {
    const double* column = p + (j + c) * ld + i;
    for (Eigen::Index r = 0; r < 2 * V * kLanes; r += 8) __builtin_prefetch(column + r, 1);
  }
  for (int v = 0; v < V; ++v)
    for (int c = 0; c < C; ++c) acc[v][c] = pset1<Packet>(0.0);
  const double* rows[V];
  for (int v = 0; v < V; ++v) rows[v] = panel_entry(a, k, i + v * kLanes, 0);
  const double* cols[C];
  for (int c = 0; c < C; ++c) cols[c] = panel_entry(b, k, j + c, 0);
  for (Eigen::Index l = 0; l < k; ++l) {
    Packet x[V];
    for (int v = 0; v < V; ++v) x[v] = pload<Packet>(rows[v] + l * kLanes);
    for (int c = 0; c < C; ++c) {
      const Packet y = pset1<Packet>(cols[c][l * kLanes]);
      for (int v = 0; v < V; ++v) acc[v][c] = pmadd(x[v], y, acc[v][c]);
    }
  }
}

// P(i..i + V kLanes, j..j + C) -= A B^T over the k columns.
template <int V, int C>
inline void register_block(double* p, Eigen::Index ld, Eigen::Index i, Eigen::Index j, const double* a,
                           const double* b, Eigen::Index k) {
  using namespace Eigen::internal;
  Packet acc[V][C];
  block_products<V, C>(acc, p, ld, i, j, a, b, k);
  for (int c = 0; c < C; ++c)
    for (int v = 0; v < V; ++v) {
      double* dst = p + (j + c) * ld + i + v * kLanes;
      pstoreu(dst, psub(ploadu<Packet>(dst), acc[v][c]));
    }
}

// The same for the last `rows` (fewer than kLanes) rows of P from i. The state's dimension is odd, so
// every downdate has such rows; one by one (a chain of k dependent multiply-adds each) they took more
// time than the whole rest of the triangle at 150 landmarks. The vector of products is formed whole
// (the packed panels are zero past the last row) and only its first `rows` are subtracted.
template <int C>
inline void partial_block(double* p, Eigen::Index ld, Eigen::Index i, Eigen::Index j, Eigen::Index rows,
                          const double* a, const double* b, Eigen::Index k) {
  using namespace Eigen::internal;
  Packet acc[1][C];
  block_products<1, C>(acc, p, ld, i, j, a, b, k);
  for (int c = 0; c < C; ++c) {
    alignas(sizeof(Packet)) double products[kLanes];
    pstore(products, acc[0][c]);
    double* dst = p + (j + c) * ld + i;
    for (Eigen::Index r = 0; r < rows; ++r) dst[r] -= products[r];
  }
}

// Where part `part` of `parts` begins: row n sqrt(part / parts), on a tile boundary. Rows up to r hold
// r^2 / 2 of the triangle, so the parts are of about equal area.
Eigen::Index part_begin(Eigen::Index n, std::size_t part, std::size_t parts) {
  if (part >= parts) return n;
  const double r = static_cast<double>(n) * std::sqrt(static_cast<double>(part) / static_cast<double>(parts));
  return std::min(n, static_cast<Eigen::Index>(r) / kTileRows * kTileRows);
}

inline void single_entry(double* p, Eigen::Index ld, Eigen::Index i, Eigen::Index j, const double* a,
                         const double* b, Eigen::Index k) {
  double acc = 0.0;
  for (Eigen::Index l = 0; l < k; ++l) acc = multiply_add(*panel_entry(a, k, i, l), *panel_entry(b, k, j, l), acc);
  p[j * ld + i] -= acc;
}

void pack(const Eigen::Ref<const Eigen::MatrixXd>& m, Eigen::VectorXd& panels) {
  const Eigen::Index n = m.rows(), k = m.cols();
  const Eigen::Index size = (n + kLanes - 1) / kLanes * kLanes * k;
  // Doubling: a scan busier than any before, or a larger map, then rarely needs more.
  if (panels.size() < size) panels.resize(std::max(size, 2 * panels.size()));
  double* out = panels.data();
  // The last group's rows past n are zero: partial_block forms their products too.
  std::fill(out + n / kLanes * kLanes * k, out + size, 0.0);
  for (Eigen::Index l = 0; l < k; ++l)
    for (Eigen::Index i = 0; i < n; ++i) out[((i / kLanes) * k + l) * kLanes + i % kLanes] = m(i, l);
}

}  // namespace

void LowerDowndate::rows(Eigen::Ref<Eigen::MatrixXd> p, const double* a, const double* b, Eigen::Index k,
                         Eigen::Index begin, Eigen::Index end) {
  const Eigen::Index n = p.rows(), ld = p.outerStride();
  double* data = p.data();
  constexpr Eigen::Index block_rows = kBlockVectors * kLanes;
  for (Eigen::Index tile = begin; tile < end; tile += kTileRows) {
    const Eigen::Index tile_end = std::min(tile + kTileRows, end);
    for (Eigen::Index j = 0; j < tile_end; j += kBlockCols) {
      // Rows from the diagonal down (j is a multiple of the lanes, so vector loads stay aligned).
      Eigen::Index i = std::max(tile, j);
      if (j + kBlockCols <= n) {
        for (; i + block_rows <= tile_end; i += block_rows)
          register_block<kBlockVectors, kBlockCols>(data, ld, i, j, a, b, k);
        for (; i + kLanes <= tile_end; i += kLanes) register_block<1, kBlockCols>(data, ld, i, j, a, b, k);
        if (i < tile_end) {
          partial_block<kBlockCols>(data, ld, i, j, tile_end - i, a, b, k);
          i = tile_end;
        }
      }
      // The last columns (fewer than a block), one by one.
      for (; i < tile_end; ++i)
        for (Eigen::Index c = j; c < std::min(j + kBlockCols, i + 1); ++c) single_entry(data, ld, i, c, a, b, k);
    }
  }
}

void LowerDowndate::apply(Eigen::Ref<Eigen::MatrixXd> p, const Eigen::Ref<const Eigen::MatrixXd>& a,
                          const Eigen::Ref<const Eigen::MatrixXd>& b, WorkerPool* pool) {
  const Eigen::Index n = p.rows(), k = a.cols();
  if (n == 0 || k == 0) return;
  pack(a, packed_a_);
  const bool same = a.data() == b.data() && a.outerStride() == b.outerStride();
  if (!same) pack(b, packed_b_);
  const double* pa = packed_a_.data();
  const double* pb = same ? pa : packed_b_.data();

  const unsigned threads = pool ? pool->size() : 1;
  if (threads <= 1 || fused_multiply_adds(static_cast<double>(n), static_cast<double>(k)) < kParallelMultiplyAdds) {
    rows(p, pa, pb, k, 0, n);
    return;
  }
  struct Job {
    Eigen::Ref<Eigen::MatrixXd>& p;
    const double* pa;
    const double* pb;
    Eigen::Index k;
    std::size_t parts;
  } job{p, pa, pb, k, threads};
  // One reference captured: the std::function stores it in place, without allocating.
  pool->run(threads, 1, [&job](std::size_t first, std::size_t last) {
    const Eigen::Index n = job.p.rows();
    rows(job.p, job.pa, job.pb, job.k, part_begin(n, first, job.parts), part_begin(n, last, job.parts));
  });
}

}  // namespace slamkit
