#pragma once
// Grid-based FastSLAM (Haehnel, Burgard, Fox and Thrun 2003; Grisetti, Stachniss and Burgard 2007,
// the method GMapping implements): a Rao-Blackwellised particle filter whose particles each carry a
// sampled path and the occupancy grid mapped along it. Given the path the map is known, so each
// particle's map is built by integrating every scan at the particle's poses.
//
// - Between scans a particle keeps a Gaussian of its pose, the odometry's prediction from its last
//   drawn pose (mean and covariance through the motion model's Jacobians).
// - At a scan each particle draws its pose from the improved proposal (gridslam/
//   scan_match_proposal.hpp: the scan matched against the particle's own map, times the odometry
//   prior), and its weight is multiplied by the proposal's normalising constant. It then integrates
//   the scan into its map at the drawn pose. With proposal_sample_fraction f < 1 it draws from f
//   times the proposal's covariance and carries the rest into its next prior, as FastSLAM 2.0's
//   pose_sample_fraction does: what a particle draws it maps, so a draw's error stays in its map.
// - Weights are kept as logarithms. Resampling (filters/resampling.hpp) happens when the effective
//   sample size falls below half the particles by default, which keeps the particles' diversity
//   between loop closures (resampling at every scan would deplete it).
// - Maps are OccupancyGrids of copy-on-write tiles: a particle drawn twice by resampling shares
//   its parent's tiles, and a scan copies only the tiles it writes. Memory grows with what the
//   particles' maps do not share; statistics report the bytes per particle.
// - Each particle slot has its own random stream from (seed, slot), so the result does not depend on
//   the number of threads.
#include <cstdint>
#include <memory>
#include <vector>

#include "slamkit/filters/resampling.hpp"
#include "slamkit/filters/slam_filter.hpp"
#include "slamkit/gridslam/scan_match_proposal.hpp"

namespace slamkit {

struct GridFastSlamConfig {
  GridSlamOptions slam;
  int particles = 30;
  std::uint64_t seed = 1;
  ResampleMethod resample = ResampleMethod::kSystematic;
  ResamplePolicy resample_when;
  unsigned threads = 0;  // 0: all cores
};

class GridFastSlam final : public SlamFilter {
 public:
  GridFastSlam(std::shared_ptr<const MotionModel> motion, const Pose2& initial_pose, const GridFastSlamConfig& config);
  ~GridFastSlam() override;

  std::string name() const override { return "grid-fastslam"; }
  void predict(const ControlEvent& control) override;
  void update(const ScanEvent& /*scan*/) override {}
  bool maps_range_scans() const override { return true; }
  void update_range_scan(const RangeScanEvent& scan) override;

  /// The weighted mean of the particles' predicted poses, and their spread plus the mean of their
  /// own covariances (the mixture's covariance).
  Pose2 pose() const override;
  Matrix3 pose_covariance() const override;
  std::size_t num_landmarks() const override { return 0; }
  std::vector<Landmark> landmarks() const override { return {}; }
  const std::vector<AssociationRecord>& last_associations() const override;
  /// The highest-weight particle's path.
  std::vector<StampedPose> smoothed_trajectory() const override;
  void forget_smoothed_trajectory() override;
  std::vector<WeightedPose> pose_samples() const override;
  /// The highest-weight particle's map.
  GridMap grid_map() const override;
  std::map<std::string, double> statistics() const override;

  /// The highest-weight particle's map, without the copy to a raster.
  const OccupancyGrid& best_map() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace slamkit
