#include "slamkit/filters/worker_pool.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <system_error>
#include <utility>

namespace slamkit {

WorkerPool::WorkerPool(unsigned threads) {
  // A constructor that throws gets no destructor call, and destroying the condition variables with
  // the started workers still waiting on them never returns: those workers are stopped first.
  try {
    workers_.reserve(threads);
    for (unsigned i = 1; i < threads; ++i) workers_.emplace_back([this, i] { loop(i); });
  } catch (const std::system_error& e) {
    stop_workers();
    throw std::runtime_error(fmt::format("could not start worker thread {} of {} ({}); ask for fewer threads",
                                         workers_.size() + 1, threads, e.what()));
  } catch (...) {
    stop_workers();
    throw;
  }
}

WorkerPool::~WorkerPool() { stop_workers(); }

void WorkerPool::stop_workers() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : workers_) t.join();
}

void WorkerPool::run(std::size_t n, std::size_t grain, const Body& body) {
  const std::size_t chunks = std::min<std::size_t>(size(), std::max<std::size_t>(1, n / grain));
  if (chunks <= 1) {
    if (n > 0) body(0, n);
    return;
  }
  {
    const std::lock_guard lock(mutex_);
    body_ = &body;
    n_ = n;
    chunks_ = chunks;
    next_.store(0, std::memory_order_relaxed);
    busy_ = workers_.size();
    ++generation_;
  }
  wake_.notify_all();
  work();
  std::unique_lock lock(mutex_);
  done_.wait(lock, [this] { return busy_ == 0; });
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void WorkerPool::work() {
  for (std::size_t c; (c = next_.fetch_add(1, std::memory_order_relaxed)) < chunks_;) {
    try {
      (*body_)(c * n_ / chunks_, (c + 1) * n_ / chunks_);
    } catch (...) {
      const std::lock_guard lock(mutex_);
      if (!error_) error_ = std::current_exception();
    }
  }
}

void WorkerPool::loop(unsigned index) {
  current_pool_ = this;
  current_index_ = index;
  std::uint64_t seen = 0;
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
    if (stop_) return;
    seen = generation_;
    lock.unlock();
    work();
    lock.lock();
    if (--busy_ == 0) done_.notify_one();
  }
}

}  // namespace slamkit
