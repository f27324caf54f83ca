#include "slamkit/filters/particle_path.hpp"

#include <algorithm>
#include <new>

namespace slamkit {

namespace {
// Poses per chunk of path storage: the surviving trajectory grows by one pose per control, so its
// storage grows once per this many controls at first and ever more rarely as the chunks grow.
constexpr std::size_t kChunkNodes = 8192;
}  // namespace

ParticlePath::NodeStorage::NodeStorage(const WorkerPool& threads) : pool_(sizeof(Node), alignof(Node), threads, kChunkNodes) {}

// Releases the nodes this path alone keeps alive one at a time: a recursive release would nest one
// call per step of a path thousands of steps long.
ParticlePath::~ParticlePath() {
  for (Node* node = node_; node != nullptr && node->refs.fetch_sub(1, std::memory_order_acq_rel) == 1;) {
    Node* parent = node->parent;
    node->~Node();
    storage_->pool_.deallocate(node);
    node = parent;
  }
}

void ParticlePath::replace_newest(const Pose2& pose) {
  if (node_->refs.load(std::memory_order_acquire) == 1) {
    node_->pose = pose;
    return;
  }
  ParticlePath parent;
  parent.storage_ = storage_;
  parent.node_ = node_->parent;
  if (parent.node_ != nullptr) parent.node_->refs.fetch_add(1, std::memory_order_relaxed);
  *this = ParticlePath(*storage_, node_->t, pose, std::move(parent));
}

std::optional<Pose2> ParticlePath::own_poses_after(double t, std::vector<Pose2*>& out) {
  Node* node = node_;
  for (; node != nullptr && node->t > t && node->refs.load(std::memory_order_acquire) == 1; node = node->parent)
    out.push_back(&node->pose);
  return node == nullptr ? std::nullopt : std::optional<Pose2>(node->pose);
}

std::vector<StampedPose> ParticlePath::poses() const {
  std::vector<StampedPose> out;
  for (const Node* node = node_; node != nullptr; node = node->parent) out.push_back({node->t, node->pose});
  std::reverse(out.begin(), out.end());
  return out;
}

}  // namespace slamkit
