#pragma once
// Persistent landmark storage for particle filters (FastSLAM's "balanced binary tree" of landmark
// Gaussians, Montemerlo et al. 2002, generalised to a wider fan-out).
//
// A map is a radix tree over landmark indices 0..size-1 (creation order): inner nodes hold FanOut
// children, leaves hold FanOut landmarks, every leaf is at the same depth, so the tree is balanced by
// construction and its height is ceil(log_FanOut(size)). Nodes are reference counted and shared:
//
//   - copying a map (a particle being duplicated by resampling) copies the root pointer: O(1);
//   - changing a landmark copies the nodes on its root-to-leaf path that are shared with another map,
//     O(height) of them, and leaves every other subtree shared;
//   - appending is the same walk, plus a new root when the tree is full.
//
// A node reachable only through nodes this map owns alone is changed in place, without a copy (the
// "transient" optimisation of persistent vectors): a particle that updates ten landmarks under one
// parent copies the shared upper path once, not ten times, and a particle that has not been
// duplicated since its last update copies nothing at all. Uniqueness is read with acquire ordering,
// pairing with the releasing decrement of whichever map dropped the last other reference, so writing to
// a node another thread has just finished reading is not a data race.
//
// Thread safety: distinct maps may be read, copied, changed and destroyed concurrently even when they
// share nodes (the reference counts are atomic). One map object is like a standard container: no
// concurrent change together with any other access to that same object.
//
// Node memory: a map made with a NodeStorage takes its nodes from that storage's pools (NodePool) and
// gives them back when their last reference goes, so a filter whose maps copy paths every step
// reuses the same memory instead of calling the heap; copies of the map use the same storage, which
// must outlive them all. A map made without one uses operator new and delete.
//
// Fan-out: 2 is the binary tree of the FastSLAM papers. Wider nodes make the tree shallower (fewer
// dependent pointer loads per lookup and fewer nodes per path copy) at the price of copying wider
// nodes; leaves of 64-byte landmarks dominate that price. bench/bench_fastslam.cpp measures it: a
// particle's scan after resampling (copy the map, change 15 landmarks) costs 1.9 / 1.1 / 0.88 /
// 0.76 us at fan-out 2 / 4 / 8 / 16 for 100 landmarks and 3.2 / 2.3 / 1.2 / 1.2 us for 20000; a
// lookup in 20000 takes 22 / 8 / 7 / 7 ns. LandmarkTree uses 8: as fast as 16 within noise, with
// half the bytes copied per leaf, which is the memory each particle's changes hold on to.
//
// Removal is a tombstone (LandmarkGaussian::removed), so indices, and with them the sharing between
// maps, stay stable.
#include <array>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <new>
#include <span>
#include <type_traits>
#include <unordered_set>
#include <utility>

#include "slamkit/assoc/landmark_existence.hpp"
#include "slamkit/core/types.hpp"
#include "slamkit/filters/node_pool.hpp"

namespace slamkit {

/// One landmark of a particle's map: its 2-D Gaussian and the bookkeeping of map management.
struct LandmarkGaussian {
  Vector2 mean = Vector2::Zero();
  Matrix2 covariance = Matrix2::Zero();
  int id = kUnknownId;  // the map id the filter reports
  // The scans that started it and last observed it: FastSLAM's relocalisation tells by them the
  // landmarks mapped since a window of recent scans from those mapped before it.
  std::uint32_t started = 0;
  std::uint32_t last_seen = 0;
  LandmarkExistence existence;
  bool removed = false;  // tombstone
  // FastSLAM's test for a copy of an older landmark of the same map: that landmark's index, and the
  // log odds that this one is its copy (FastSlam::Impl::weigh_duplicates).
  float duplicate_log_odds = 0.0f;
  std::uint32_t duplicate_of = kNotADuplicate;
  static constexpr std::uint32_t kNotADuplicate = 0xffffffffu;
};

/// Item: what each index holds (LandmarkGaussian for a map; FastSLAM keeps a second tree of the
/// same shape beside a map for what only some runs need per landmark).
template <int FanOut, class Item = LandmarkGaussian>
class BasicLandmarkTree {
  static_assert(FanOut >= 2 && (FanOut & (FanOut - 1)) == 0, "the fan-out must be a power of two >= 2");

 public:
  static constexpr int kFanOut = FanOut;

  /// Pools for the nodes of the maps made with it, for the threads of `threads` (see NodePool).
  class NodeStorage {
   public:
    explicit NodeStorage(const WorkerPool& threads)
        : leaves_(sizeof(Leaf), alignof(Leaf), threads, kChunkNodes),
          inners_(sizeof(Inner), alignof(Inner), threads, kChunkNodes) {}

   private:
    friend class BasicLandmarkTree;
    // A chunk of leaves is about 1 MB at fan-out 8: growth is rare and its cost amortised.
    static constexpr std::size_t kChunkNodes = 2048;
    NodePool leaves_;
    NodePool inners_;
  };

  BasicLandmarkTree() noexcept = default;
  explicit BasicLandmarkTree(NodeStorage* storage) noexcept : storage_(storage) {}
  BasicLandmarkTree(const BasicLandmarkTree& other) noexcept
      : root_(other.root_), size_(other.size_), height_(other.height_), storage_(other.storage_) {
    retain(root_);
  }
  BasicLandmarkTree(BasicLandmarkTree&& other) noexcept
      : root_(std::exchange(other.root_, nullptr)),
        size_(std::exchange(other.size_, 0)),
        height_(std::exchange(other.height_, 0)),
        storage_(other.storage_) {}
  BasicLandmarkTree& operator=(const BasicLandmarkTree& other) noexcept {
    if (this != &other) BasicLandmarkTree(other).swap(*this);
    return *this;
  }
  BasicLandmarkTree& operator=(BasicLandmarkTree&& other) noexcept {
    BasicLandmarkTree(std::move(other)).swap(*this);
    return *this;
  }
  ~BasicLandmarkTree() { release(root_, height_); }

  void swap(BasicLandmarkTree& other) noexcept {
    std::swap(root_, other.root_);
    std::swap(size_, other.size_);
    std::swap(height_, other.height_);
    std::swap(storage_, other.storage_);
  }

  /// Number of landmarks ever appended, tombstones included.
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  /// Node levels from the root to the leaves (0 when empty): the nodes a change may have to copy.
  int height() const { return height_; }

  /// The landmark at `index` (< size()). O(height).
  const Item& operator[](std::size_t index) const {
    const Node* node = root_;
    for (int level = height_; level > 1; --level)
      node = static_cast<const Inner*>(node)->children[digit(index, level)];
    return static_cast<const Leaf*>(node)->items[index & kMask];
  }

  /// Writable access to the landmark at `index` (< size()), copying the shared part of its path
  /// first. The reference is valid until this map is next changed, copied or assigned to.
  Item& mutate(std::size_t index) {
    Node** slot = &root_;
    for (int level = height_; level > 1; --level)
      slot = &static_cast<Inner*>(make_unique(*slot, level))->children[digit(index, level)];
    return static_cast<Leaf*>(make_unique(*slot, 1))->items[index & kMask];
  }

  /// Appends a landmark at index size(). O(height).
  void push_back(const Item& landmark) {
    if (size_ == capacity()) {
      if (root_ == nullptr) {
        root_ = make<Leaf>();
      } else {
        auto* grown = make<Inner>();
        grown->children[0] = root_;
        root_ = grown;
      }
      ++height_;
    }
    const std::size_t index = size_;
    Node** slot = &root_;
    for (int level = height_; level > 1; --level) {
      Inner* inner = static_cast<Inner*>(make_unique(*slot, level));
      slot = &inner->children[digit(index, level)];
      if (*slot == nullptr) *slot = level == 2 ? static_cast<Node*>(make<Leaf>()) : make<Inner>();
    }
    static_cast<Leaf*>(make_unique(*slot, 1))->items[index & kMask] = landmark;
    ++size_;
  }

  /// Calls f(index, landmark) for every landmark in index order, tombstones included.
  template <class F>
  void for_each(F&& f) const {
    if (root_ != nullptr) visit(root_, height_, 0, size_, f);
  }

  /// Distinct nodes reachable from `trees`: the memory a set of maps really occupies.
  static std::size_t count_distinct_nodes(std::span<const BasicLandmarkTree* const> trees) {
    std::unordered_set<const Node*> seen;
    for (const BasicLandmarkTree* tree : trees) count_nodes(tree->root_, tree->height_, seen);
    return seen.size();
  }

 private:
  static constexpr int kBits = std::countr_zero(static_cast<unsigned>(FanOut));
  static constexpr std::size_t kMask = FanOut - 1;

  // A node's level says what it is (1: leaf), so the node needs no type tag or virtual functions.
  struct Node {
    std::atomic<std::size_t> refs{1};
  };
  struct Inner : Node {
    Inner() = default;
    // Copying shares every child, hence the extra references.
    Inner(const Inner& other) : Node(), children(other.children) {
      for (Node* child : children) retain(child);
    }
    std::array<Node*, FanOut> children{};
  };
  struct Leaf : Node {
    Leaf() = default;
    Leaf(const Leaf& other) : Node(), items(other.items) {}
    std::array<Item, FanOut> items;
  };

  static std::size_t digit(std::size_t index, int level) {
    return (index >> (kBits * (level - 1))) & kMask;
  }
  std::size_t capacity() const { return height_ == 0 ? 0 : std::size_t{1} << (kBits * height_); }

  static void retain(Node* node) {
    if (node != nullptr) node->refs.fetch_add(1, std::memory_order_relaxed);
  }
  template <class T>
  NodePool& pool() const {
    if constexpr (std::is_same_v<T, Leaf>)
      return storage_->leaves_;
    else
      return storage_->inners_;
  }
  template <class T, class... Args>
  T* make(Args&&... args) const {
    if (storage_ == nullptr) return new T(std::forward<Args>(args)...);
    void* block = pool<T>().allocate();
    return new (block) T(std::forward<Args>(args)...);
  }
  template <class T>
  void destroy(T* node) const {
    if (storage_ == nullptr) {
      delete node;
      return;
    }
    node->~T();
    pool<T>().deallocate(node);
  }

  void release(Node* node, int level) const {
    // acq_rel: the last owner must see every other owner's accesses before it frees the node.
    if (node == nullptr || node->refs.fetch_sub(1, std::memory_order_acq_rel) != 1) return;
    if (level == 1) {
      destroy(static_cast<Leaf*>(node));
      return;
    }
    auto* inner = static_cast<Inner*>(node);
    for (Node* child : inner->children) release(child, level - 1);
    destroy(inner);
  }
  /// Makes *slot a node only this map reaches (the caller owns the path to slot) and returns it.
  Node* make_unique(Node*& slot, int level) const {
    if (slot->refs.load(std::memory_order_acquire) == 1) return slot;
    Node* copy = level == 1 ? static_cast<Node*>(make<Leaf>(*static_cast<const Leaf*>(slot)))
                            : make<Inner>(*static_cast<const Inner*>(slot));
    release(slot, level);
    slot = copy;
    return copy;
  }

  /// Visits the landmarks under `node` (whose first index is `first`) in index order, up to `size`.
  template <class F>
  static void visit(const Node* node, int level, std::size_t first, std::size_t size, F& f) {
    if (level == 1) {
      const auto* leaf = static_cast<const Leaf*>(node);
      for (std::size_t i = 0; i < FanOut && first + i < size; ++i) f(first + i, leaf->items[i]);
      return;
    }
    const auto* inner = static_cast<const Inner*>(node);
    const std::size_t span = std::size_t{1} << (kBits * (level - 1));
    for (std::size_t c = 0; c < FanOut && inner->children[c] != nullptr; ++c)
      visit(inner->children[c], level - 1, first + c * span, size, f);
  }
  static void count_nodes(const Node* node, int level, std::unordered_set<const Node*>& seen) {
    if (node == nullptr || !seen.insert(node).second || level == 1) return;
    for (const Node* child : static_cast<const Inner*>(node)->children) count_nodes(child, level - 1, seen);
  }

  Node* root_ = nullptr;
  std::size_t size_ = 0;
  int height_ = 0;
  NodeStorage* storage_ = nullptr;
};

/// The fan-out FastSLAM uses; see the header comment and bench/bench_fastslam.cpp.
inline constexpr int kLandmarkTreeFanOut = 8;
using LandmarkTree = BasicLandmarkTree<kLandmarkTreeFanOut>;

}  // namespace slamkit
