#include "slamkit/grid/reference_map.hpp"

#include "slamkit/core/pose_at.hpp"

namespace slamkit {

std::optional<OccupancyGrid> reference_map(const Dataset& dataset, const GridOptions& options) {
  if (dataset.truth.poses.empty() || !dataset.truth.poses_have_heading) return std::nullopt;
  OccupancyGrid map(options);
  bool any = false;
  for (const Event& event : dataset.events) {
    const auto* scan = std::get_if<RangeScanEvent>(&event);
    Pose2 pose;
    if (scan == nullptr || !pose_at(dataset.truth.poses, scan->t, pose)) continue;
    map.integrate(pose, *scan);
    any = true;
  }
  if (!any) return std::nullopt;
  return map;
}

}  // namespace slamkit
