#pragma once
// A particle's trajectory as a list of poses, newest first, that shares its past with the paths of
// the particles it descends from: copying a path (a particle drawn by resampling) copies a pointer,
// and a prediction adds one node in front. So the particles' histories form a tree whose branches
// die with the particles resampling does not draw, and the memory they take is the surviving past
// plus one node per particle and step.
//
// Nodes come from a NodeStorage (a NodePool the filter owns, for the threads of its WorkerPool):
// each step adds a node per particle and resampling drops the nodes of the paths it does not draw,
// so the pool recycles all but the one node per step by which the surviving past grows.
#include <atomic>
#include <cstddef>
#include <new>
#include <optional>
#include <utility>
#include <vector>

#include "slamkit/core/types.hpp"
#include "slamkit/filters/node_pool.hpp"

namespace slamkit {

class ParticlePath {
  struct Node;

 public:
  /// The nodes of the paths made with it; it must outlive them.
  class NodeStorage {
   public:
    explicit NodeStorage(const WorkerPool& threads);
    /// Makes sure `nodes` more nodes can be made without growing the pool.
    void reserve(std::size_t nodes) { pool_.reserve(nodes); }

   private:
    friend class ParticlePath;
    NodePool pool_;
  };

  /// No poses.
  ParticlePath() = default;
  /// A path of one pose.
  ParticlePath(NodeStorage& storage, double t, const Pose2& pose) : ParticlePath(storage, t, pose, ParticlePath()) {}
  ParticlePath(const ParticlePath& other) noexcept : storage_(other.storage_), node_(other.node_) {
    if (node_ != nullptr) node_->refs.fetch_add(1, std::memory_order_relaxed);
  }
  ParticlePath(ParticlePath&& other) noexcept : storage_(other.storage_), node_(std::exchange(other.node_, nullptr)) {}
  ParticlePath& operator=(ParticlePath other) noexcept {
    std::swap(storage_, other.storage_);
    std::swap(node_, other.node_);
    return *this;
  }
  ~ParticlePath();

  bool empty() const { return node_ == nullptr; }
  /// Adds a pose at time t in front (a non-empty path's storage takes it).
  void extend(double t, const Pose2& pose) { *this = ParticlePath(*storage_, t, pose, std::move(*this)); }
  /// Replaces the newest pose (same time): in place when no other path shares the node, which is
  /// the rule, since resampling shares paths only after a scan and a prediction adds an unshared node.
  void replace_newest(const Pose2& pose);
  /// Appends to `out`, newest first, the poses of the nodes newer than time `t` that no other path
  /// shares, for the caller to revise in place: the steps a particle predicted since its last scan
  /// at t, which resampling (at scans only) has not shared. Stops at the first shared node. Returns
  /// the pose of the node they follow (the scan's at t), or nullopt where they reach the path's start.
  std::optional<Pose2> own_poses_after(double t, std::vector<Pose2*>& out);
  /// The poses, oldest first.
  std::vector<StampedPose> poses() const;

 private:
  struct Node {
    std::atomic<std::size_t> refs{1};
    double t;
    Pose2 pose;
    Node* parent;
  };
  /// A new newest node after `parent`, whose reference it takes over.
  ParticlePath(NodeStorage& storage, double t, const Pose2& pose, ParticlePath&& parent)
      : storage_(&storage),
        node_(new (storage.pool_.allocate()) Node{{1}, t, pose, std::exchange(parent.node_, nullptr)}) {}

  NodeStorage* storage_ = nullptr;
  Node* node_ = nullptr;
};

}  // namespace slamkit
