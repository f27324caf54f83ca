#pragma once
// Scan matching as a SLAM method of its own, the baseline of laser SLAM: one occupancy grid, and
// odometry corrected at each scan by matching the scan against the grid so far (the proposal of
// gridslam/scan_match_proposal.hpp with one hypothesis: the mean of the scan likelihood times the
// odometry prior). With nothing to re-close a loop, its error grows with the distance driven.
#include <memory>
#include <vector>

#include "slamkit/filters/slam_filter.hpp"
#include "slamkit/gridslam/scan_match_proposal.hpp"

namespace slamkit {

class ScanMatchingFilter final : public SlamFilter {
 public:
  ScanMatchingFilter(std::shared_ptr<const MotionModel> motion, const Pose2& initial_pose,
                     const GridSlamOptions& options = {});

  std::string name() const override { return "scan-matching"; }
  void predict(const ControlEvent& control) override;
  void update(const ScanEvent& /*scan*/) override {}
  bool maps_range_scans() const override { return true; }
  void update_range_scan(const RangeScanEvent& scan) override;

  Pose2 pose() const override { return pose_; }
  Matrix3 pose_covariance() const override { return covariance_; }
  std::size_t num_landmarks() const override { return 0; }
  std::vector<Landmark> landmarks() const override { return {}; }
  const std::vector<AssociationRecord>& last_associations() const override { return no_associations_; }
  GridMap grid_map() const override;
  std::map<std::string, double> statistics() const override;

  const OccupancyGrid& map() const { return map_; }

 private:
  std::shared_ptr<const MotionModel> motion_;
  GridSlamOptions options_;
  ScanMatcher matcher_;
  OccupancyGrid map_;
  Pose2 pose_;
  Matrix3 covariance_ = Matrix3::Zero();
  std::size_t scans_ = 0;
  std::size_t unmatched_scans_ = 0;
  ScanCadence cadence_;
  std::vector<AssociationRecord> no_associations_;
};

}  // namespace slamkit
