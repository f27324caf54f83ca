// The counting allocator must see every route to the heap the filters use, or the allocation-free
// tests built on it would pass vacuously.
#include "allocation_counter.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <new>
#include <vector>

namespace slamkit::test {
namespace {

TEST(AllocationCounter, SeesOperatorNewEigenAndAlignedNew) {
  {
    const AllocationCount count;
    std::vector<int> values(100);
    EXPECT_GE(count.count(), 1u);
    EXPECT_EQ(values.size(), 100u);
  }
  {
    const AllocationCount count;
    Eigen::MatrixXd matrix = Eigen::MatrixXd::Identity(20, 20);
    EXPECT_GE(count.count(), 1u);
    EXPECT_EQ(matrix.trace(), 20.0);
  }
  {
    struct alignas(128) Wide {
      double value[16];
    };
    const AllocationCount count;
    auto wide = std::make_unique<Wide>();
    EXPECT_GE(count.count(), 1u);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(wide.get()) % 128, 0u);
  }
}

TEST(AllocationCounter, CountsNothingWithoutAllocation) {
  std::vector<double> values(64, 1.0);
  const AllocationCount count;
  double sum = 0.0;
  for (double v : values) sum += v;
  values.assign(32, 2.0);  // shrinks in place: capacity is kept
  EXPECT_EQ(count.count(), 0u);
  EXPECT_EQ(sum, 64.0);
}

}  // namespace
}  // namespace slamkit::test
