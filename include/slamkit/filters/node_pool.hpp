#pragma once
// A pool of fixed-size memory blocks for the nodes of persistent structures (FastSLAM's landmark
// trees and particle paths), so that the per-step churn of node copies and releases recycles memory
// instead of calling the heap allocator.
//
// Blocks come from chunks allocated with operator new and are never returned to the heap before the
// pool is destroyed: a filter's working set of nodes is roughly constant from step to step, so the
// blocks freed by one step are the ones the next step takes. Chunks grow geometrically (each at
// least half the capacity so far, and at least `min_chunk_blocks`), so a structure that keeps
// growing, such as the surviving trajectory, allocates once per large chunk.
//
// Thread safety: a pool serves the threads of one WorkerPool, given when it is made: its workers and
// the one thread that calls WorkerPool::run (index 0, as is any thread outside the pool, so at most
// one of those may use the pool at a time). allocate and deallocate may be called concurrently from
// those threads. Each thread index has its own free list that needs no lock; a list hands surplus
// blocks to a shared list, and an empty one refills from it, in batches under a mutex, so the lock
// is taken once per kBatch blocks.
#include <algorithm>
#include <cstddef>
#include <memory>
#include <mutex>
#include <new>
#include <vector>

#include "slamkit/filters/worker_pool.hpp"

namespace slamkit {

class NodePool {
 public:
  /// Blocks of `block_size` bytes aligned to `alignment` (a node type's size and alignof: Eigen's
  /// fixed-size members may need up to 64 bytes with AVX-512), for the threads of `threads`, which
  /// must outlive the pool.
  NodePool(std::size_t block_size, std::size_t alignment, const WorkerPool& threads, std::size_t min_chunk_blocks)
      : align_(std::max(alignment, alignof(FreeBlock))),
        block_size_(round_up(std::max(block_size, sizeof(FreeBlock)), align_)),
        min_chunk_(std::max<std::size_t>(min_chunk_blocks, kBatch)),
        threads_(&threads),
        slots_(std::make_unique<Slot[]>(threads.size())) {}
  NodePool(const NodePool&) = delete;
  NodePool& operator=(const NodePool&) = delete;

  void* allocate() {
    Slot& slot = slots_[threads_->thread_index()];
    if (slot.head == nullptr) refill(slot);
    return pop(slot.head, slot.count);
  }

  void deallocate(void* block) noexcept {
    auto* free = static_cast<FreeBlock*>(block);
    Slot& slot = slots_[threads_->thread_index()];
    push(slot.head, slot.count, free);
    if (slot.count >= 2 * kBatch) spill(slot);
  }

  /// Makes sure `blocks` more blocks can be allocated without growing: adds one chunk for the
  /// shortfall of the free blocks on the shared list.
  void reserve(std::size_t blocks) {
    const std::lock_guard lock(mutex_);
    if (shared_count_ < blocks) grow(blocks - shared_count_);
  }

 private:
  struct FreeBlock {
    FreeBlock* next;
  };
  // Own cache lines, so that threads pushing to their own lists do not contend.
  struct alignas(64) Slot {
    FreeBlock* head = nullptr;
    std::size_t count = 0;
  };
  // Blocks are as aligned as the node type needs and no more: rounding every block up to the widest
  // vector (64 bytes with AVX-512) made an inner node of a landmark tree 128 bytes instead of 72,
  // and FastSLAM copies those nodes at every step.
  struct ChunkDelete {
    std::align_val_t align;
    void operator()(std::byte* chunk) const { ::operator delete[](chunk, align); }
  };
  using Chunk = std::unique_ptr<std::byte[], ChunkDelete>;
  static constexpr std::size_t kBatch = 64;

  static std::size_t round_up(std::size_t size, std::size_t align) { return (size + align - 1) / align * align; }
  static void push(FreeBlock*& head, std::size_t& count, FreeBlock* block) {
    block->next = head;
    head = block;
    ++count;
  }
  static void* pop(FreeBlock*& head, std::size_t& count) {
    FreeBlock* block = head;
    head = block->next;
    --count;
    return block;
  }

  void refill(Slot& slot) {
    const std::lock_guard lock(mutex_);
    if (shared_count_ < kBatch) grow(kBatch);
    for (std::size_t i = 0; i < kBatch; ++i) push(slot.head, slot.count, static_cast<FreeBlock*>(pop(shared_, shared_count_)));
  }
  void spill(Slot& slot) {
    // Unlink a batch outside the lock, then splice it onto the shared list.
    FreeBlock* first = slot.head;
    FreeBlock* last = first;
    for (std::size_t i = 1; i < kBatch; ++i) last = last->next;
    slot.head = last->next;
    slot.count -= kBatch;
    const std::lock_guard lock(mutex_);
    last->next = shared_;
    shared_ = first;
    shared_count_ += kBatch;
  }
  /// Adds a chunk of at least `blocks` blocks to the shared list; the caller holds the mutex.
  void grow(std::size_t blocks) {
    const std::size_t n = std::max({blocks, min_chunk_, capacity_ / 2});
    const std::align_val_t align{align_};
    Chunk chunk(static_cast<std::byte*>(::operator new[](n * block_size_, align)), ChunkDelete{align});
    chunks_.push_back(std::move(chunk));
    std::byte* base = chunks_.back().get();
    // Pushed in reverse so that blocks are handed out in address order.
    for (std::size_t i = n; i-- > 0;) push(shared_, shared_count_, reinterpret_cast<FreeBlock*>(base + i * block_size_));
    capacity_ += n;
  }

  const std::size_t align_;
  const std::size_t block_size_;
  const std::size_t min_chunk_;
  const WorkerPool* const threads_;
  const std::unique_ptr<Slot[]> slots_;
  std::mutex mutex_;
  FreeBlock* shared_ = nullptr;
  std::size_t shared_count_ = 0;
  std::size_t capacity_ = 0;
  std::vector<Chunk> chunks_;
};

}  // namespace slamkit
