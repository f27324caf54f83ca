#pragma once
// A trajectory's pose at any time within it, as readers (a log's start pose from its truth) and the
// calibration (the truth at each command window and scan) read it.
#include <algorithm>
#include <iterator>
#include <limits>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

/// The pose of `poses` (sorted by time) at t: a sample's own at its time, else linear in position and
/// the short way round in heading between its neighbours. False outside their span, or when the
/// neighbours are more than max_gap seconds apart.
inline bool pose_at(const std::vector<StampedPose>& poses, double t, Pose2& out,
                    double max_gap = std::numeric_limits<double>::infinity()) {
  const auto after =
      std::lower_bound(poses.begin(), poses.end(), t, [](const StampedPose& p, double time) { return p.t < time; });
  if (after == poses.end()) return false;
  if (after->t == t) {
    out = after->pose;
    return true;
  }
  if (after == poses.begin()) return false;
  const StampedPose& before = *std::prev(after);
  if (after->t - before.t > max_gap) return false;
  const double s = (t - before.t) / (after->t - before.t);
  out.head<2>() = before.pose.head<2>() + s * (after->pose.head<2>() - before.pose.head<2>());
  out[2] = wrap_angle(before.pose[2] + s * wrap_angle(after->pose[2] - before.pose[2]));
  return true;
}

}  // namespace slamkit
