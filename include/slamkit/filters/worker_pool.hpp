#pragma once
// A small pool of persistent threads that runs a loop body over [0, n) in contiguous chunks, the
// calling thread taking part: FastSLAM's per-particle work. Handing work over costs a wake-up and a
// join (some microseconds), so run() keeps work on the calling thread unless there is enough of it.
//
// Every thread has an index in the pool: the workers 1..size()-1, and 0 for the one thread that
// calls run() (the pool's owner). A NodePool made for the pool keeps a free list per index
// (node_pool.hpp), so the threads allocate nodes without taking a lock.
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace slamkit {

class WorkerPool {
 public:
  using Body = std::function<void(std::size_t begin, std::size_t end)>;

  /// `threads` threads in all, the calling one included (0 is taken as 1). Throws
  /// std::runtime_error, with every thread it started stopped, when the system refuses a thread.
  explicit WorkerPool(unsigned threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  unsigned size() const { return static_cast<unsigned>(workers_.size()) + 1; }
  /// The calling thread's index: its number if it is one of this pool's workers, else 0.
  unsigned thread_index() const { return current_pool_ == this ? current_index_ : 0; }

  /// Calls body on at most size() chunks of at least `grain` items; one chunk runs inline with no
  /// hand-over. Rethrows the first exception a chunk threw, after every chunk has finished.
  void run(std::size_t n, std::size_t grain, const Body& body);

 private:
  void work();
  void loop(unsigned index);
  void stop_workers();

  // Which pool's worker the running thread is, and its index there.
  static inline thread_local const WorkerPool* current_pool_ = nullptr;
  static inline thread_local unsigned current_index_ = 0;

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  // Set under the mutex before a generation starts and read-only until every worker is done.
  const Body* body_ = nullptr;
  std::size_t n_ = 0, chunks_ = 0;
  std::atomic<std::size_t> next_{0};
  std::size_t busy_ = 0;
  std::uint64_t generation_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
};

}  // namespace slamkit
