// FastSLAM's worker pool: every item runs once, errors reach the caller, and a pool the system
// refuses threads fails with a clear error instead of hanging.
#include "slamkit/filters/worker_pool.hpp"
#include "sanitizers.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace slamkit {
namespace {

TEST(WorkerPool, RunsEveryItemOnceOverItsThreads) {
  WorkerPool pool(4);
  EXPECT_EQ(pool.size(), 4u);
  std::vector<std::atomic<int>> hits(1000);
  pool.run(hits.size(), 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) ++hits[i];
  });
  for (const auto& h : hits) EXPECT_EQ(h.load(), 1);
}

TEST(WorkerPool, RethrowsAChunksErrorAfterEveryChunkHasFinished) {
  WorkerPool pool(3);
  std::atomic<std::size_t> done{0};
  EXPECT_THROW(pool.run(300, 1,
                        [&](std::size_t begin, std::size_t end) {
                          done += end - begin;
                          if (begin == 0) throw std::runtime_error("chunk failed");
                        }),
               std::runtime_error);
  EXPECT_EQ(done.load(), 300u);
  // The pool is still usable.
  done = 0;
  pool.run(300, 1, [&](std::size_t begin, std::size_t end) { done += end - begin; });
  EXPECT_EQ(done.load(), 300u);
}

#if !defined(SLAMKIT_ADDRESS_SANITIZER) && !defined(SLAMKIT_THREAD_SANITIZER)
// Bytes of address space this process holds.
long long address_space_in_use() {
  std::ifstream statm("/proc/self/statm");
  long long pages = 0;
  statm >> pages;
  return pages * sysconf(_SC_PAGESIZE);
}

// With the address space capped, the 300 threads' stacks (8 MiB each) cannot all be had: the
// constructor must stop the threads it did start and throw, where it used to block forever.
[[noreturn]] void start_300_threads_in_capped_memory() {
  alarm(60);  // a hang ends the child with SIGALRM, failing the expectation
  const auto cap = static_cast<rlim_t>(address_space_in_use() + (256LL << 20));
  const rlimit limit{cap, cap};
  if (setrlimit(RLIMIT_AS, &limit) != 0) std::_Exit(3);
  try {
    const WorkerPool pool(300);
    std::_Exit(4);  // the cap did not bite
  } catch (const std::runtime_error& e) {
    std::fputs(e.what(), stderr);
    std::_Exit(0);
  }
}

TEST(WorkerPoolDeathTest, RefusedThreadsGiveAClearErrorNotAHang) {
  EXPECT_EXIT(start_300_threads_in_capped_memory(), ::testing::ExitedWithCode(0),
              "could not start worker thread [0-9]+ of 300");
}
#endif

}  // namespace
}  // namespace slamkit
