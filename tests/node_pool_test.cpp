// The node pool hands out blocks as aligned as the node type asks and no larger than its size rounded
// to that alignment: FastSLAM copies tree nodes at every step, so padding them all to the widest
// vector (64 bytes with AVX-512) made them bigger than they need to be.
#include "slamkit/filters/node_pool.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <vector>

#include "slamkit/filters/worker_pool.hpp"

namespace slamkit {
namespace {

std::uintptr_t address(const void* p) { return reinterpret_cast<std::uintptr_t>(p); }

/// The distinct distances between consecutive blocks of `count` allocations (fewer than a batch,
/// so they are neighbours in one fresh chunk) and whether each block is aligned to `alignment`.
std::set<std::uintptr_t> strides(NodePool& pool, std::size_t count, std::size_t alignment, bool& aligned) {
  std::vector<void*> blocks;
  for (std::size_t i = 0; i < count; ++i) blocks.push_back(pool.allocate());
  std::set<std::uintptr_t> out;
  aligned = true;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    aligned = aligned && address(blocks[i]) % alignment == 0;
    if (i > 0) {
      const std::uintptr_t a = address(blocks[i]), b = address(blocks[i - 1]);
      out.insert(a > b ? a - b : b - a);
    }
  }
  for (void* b : blocks) pool.deallocate(b);
  return out;
}

TEST(NodePool, BlocksAreTheNodesSizeAtItsOwnAlignment) {
  const WorkerPool threads(1);
  // A landmark tree's inner node at fan-out 8: a count and 8 pointers, 72 bytes aligned to 8.
  NodePool inner(72, 8, threads, 64);
  bool aligned = false;
  EXPECT_EQ(strides(inner, 50, 8, aligned), std::set<std::uintptr_t>{72});
  EXPECT_TRUE(aligned);
}

TEST(NodePool, BlocksMeetAnAlignmentAboveOperatorNewsDefault) {
  const WorkerPool threads(1);
  struct alignas(64) Wide {
    double lanes[8];
    int tag;
  };
  NodePool wide(sizeof(Wide), alignof(Wide), threads, 64);
  bool aligned = false;
  EXPECT_EQ(strides(wide, 50, 64, aligned), std::set<std::uintptr_t>{sizeof(Wide)});
  EXPECT_TRUE(aligned);
  // A block smaller than its alignment still takes a whole aligned slot.
  NodePool small(40, 32, threads, 64);
  EXPECT_EQ(strides(small, 50, 32, aligned), std::set<std::uintptr_t>{64});
  EXPECT_TRUE(aligned);
}

}  // namespace
}  // namespace slamkit
