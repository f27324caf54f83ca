// A particle's path shares its past with its relatives: what a filter may revise in place is only
// the part no other path holds.
#include <gtest/gtest.h>

#include <optional>
#include <vector>

#include "slamkit/filters/particle_path.hpp"
#include "slamkit/filters/worker_pool.hpp"

using namespace slamkit;

TEST(ParticlePath, OnlyTheStepsNoOtherPathSharesAreOwnedAfterATime) {
  WorkerPool threads(1);
  ParticlePath::NodeStorage storage(threads);
  ParticlePath parent(storage, 0.0, Pose2(0.0, 0.0, 0.0));
  parent.extend(1.0, Pose2(1.0, 0.0, 0.0));
  ParticlePath child = parent;  // drawn twice by resampling at t = 1
  child.extend(2.0, Pose2(2.0, 0.0, 0.0));
  child.extend(3.0, Pose2(3.0, 0.0, 0.0));

  std::vector<Pose2*> owned;
  const std::optional<Pose2> followed = child.own_poses_after(0.0, owned);
  ASSERT_TRUE(followed.has_value());
  EXPECT_EQ(followed->x(), 1.0);  // the shared node they follow
  ASSERT_EQ(owned.size(), 2u);  // t = 3 and 2, newest first; t = 1 is shared with `parent`
  EXPECT_EQ(owned[0]->x(), 3.0);
  EXPECT_EQ(owned[1]->x(), 2.0);

  owned.clear();
  child.own_poses_after(2.0, owned);
  ASSERT_EQ(owned.size(), 1u);
  owned[0]->x() = 3.5;  // revised in place: the child sees it, the parent's past is untouched
  EXPECT_EQ(child.poses().back().pose.x(), 3.5);
  EXPECT_EQ(parent.poses().back().pose.x(), 1.0);

  owned.clear();
  parent.own_poses_after(0.0, owned);
  EXPECT_TRUE(owned.empty());  // its newest node is the child's too
}
