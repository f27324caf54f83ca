#include "slamkit/gridslam/scan_matching_filter.hpp"

#include "slamkit/grid/grid_snapshot.hpp"
#include "slamkit/models/motion_model.hpp"

namespace slamkit {

ScanMatchingFilter::ScanMatchingFilter(std::shared_ptr<const MotionModel> motion, const Pose2& initial_pose,
                                       const GridSlamOptions& options)
    : motion_(std::move(motion)), options_(options), matcher_(options.matcher), map_(options.grid),
      pose_(initial_pose) {}

void ScanMatchingFilter::predict(const ControlEvent& control) {
  const Pose2 before = pose_;
  predict_pose(*motion_, control, pose_, covariance_);
  cadence_.moved(before, pose_);
}

void ScanMatchingFilter::update_range_scan(const RangeScanEvent& scan) {
  if (!cadence_.take(options_)) return;
  // The first scan has no map to be matched against: it makes the map, from the start pose.
  if (scans_++ > 0) {
    const PoseProposal proposal = scan_match_proposal(matcher_, map_, scan, pose_, covariance_, options_, nullptr);
    pose_ = proposal.mean;
    covariance_ = proposal.covariance;
    unmatched_scans_ += !proposal.matched;
  }
  map_.integrate(pose_, scan);
}

GridMap ScanMatchingFilter::grid_map() const { return to_grid_map(map_); }

std::map<std::string, double> ScanMatchingFilter::statistics() const {
  return {{"range_scans", static_cast<double>(scans_)},
          {"unmatched_scans", static_cast<double>(unmatched_scans_)},
          {"skipped_range_scans", static_cast<double>(cadence_.skipped())},
          {"grid_bytes", static_cast<double>(map_.bytes())}};
}

}  // namespace slamkit
