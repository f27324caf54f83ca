#pragma once
// Counts heap allocations made anywhere in the test binary, so tests can prove that a filter's
// per-step hot path does not allocate. allocation_counter.cpp interposes glibc's malloc family
// (operator new and Eigen both end there), which is why it must be linked into the test executable;
// under AddressSanitizer, which owns malloc, it counts through the sanitizer's allocator hooks.

#include <cstdint>

namespace slamkit::test {

// Allocation calls (malloc, calloc, realloc, aligned variants) since the program started, all threads.
std::uint64_t allocations_so_far();

// Allocations made since construction.
class AllocationCount {
 public:
  AllocationCount() : start_(allocations_so_far()) {}
  std::uint64_t count() const { return allocations_so_far() - start_; }

 private:
  std::uint64_t start_;
};

}  // namespace slamkit::test
