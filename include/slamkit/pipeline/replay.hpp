#pragma once
// Records a run scan by scan for `slamkit run --replay`: the filter's pose and covariance, its map
// with covariance ellipses, the scan's observations with what the filter did with each (and, where
// the truth names every observation's landmark, whether that was wrong), particles, and the pose
// error against the truth. The recording is JSON (replay.json in the run folder), which
// plot/replay_html.hpp turns into a self-contained page that plays it back.
#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <unordered_map>
#include <vector>

#include "slamkit/core/dataset.hpp"
#include "slamkit/pipeline/runner.hpp"

namespace slamkit {

struct ReplayOptions {
  /// Long runs are decimated to about this many frames (every k-th scan), so the page stays smooth;
  /// the page says so.
  std::size_t max_frames = 600;
  /// At most this many particles are drawn per frame (evenly spaced through the filter's set).
  std::size_t max_particles = 200;
  /// Grid filters: the map (the best particle's) is pictured in this many frames at most, evenly
  /// spread and always the last, each picture at most grid_image_side pixels a side; the page shows
  /// the latest picture at or before the frame it draws.
  std::size_t max_grid_images = 40;
  int grid_image_side = 600;
  /// Grid filters: at most this many of a scan's beam end points per frame.
  std::size_t max_beam_ends = 180;
};

class ReplayRecorder : public RunObserver {
 public:
  /// Keeps a reference to `dataset`, which must outlive the recorder. Frames are taken at the scans
  /// the filter maps with: the landmark scans, or with `range_scans` the laser scans.
  explicit ReplayRecorder(const Dataset& dataset, ReplayOptions options = {}, bool range_scans = false);

  void on_scan(const SlamFilter& filter, const ScanEvent& scan, std::size_t events_done,
               std::size_t events_total) override;
  void on_range_scan(const SlamFilter& filter, const RangeScanEvent& scan, std::size_t events_done,
                     std::size_t events_total) override;

  /// The recording. With `truth_from_estimate` (x, y, theta: rotate by theta, then translate), the
  /// evaluation's alignment of the estimate onto the truth, the truth is drawn in the estimate's
  /// frame through its inverse and the pose error is taken after it, so a truth in a frame of its
  /// own (Victoria Park's GPS) lines up. Without it the frames are taken to agree (a truth with
  /// headings starts at the map's origin) and the error is unaligned, as for pose NEES; the page
  /// says which ("error_aligned" in "meta").
  /// {"meta": {...}, "truth": [[t, x, y], ...], "true_landmarks": [[x, y], ...],
  /// "frames": [{"t", "pose": [x, y, theta], "cov": [xx, xy, yy, tt], "landmarks": [id, x, y, cxx,
  /// cxy, cyy, ...], "rays": [x, y, decision, ...], "rings": [sensor x, y, range, decision, ...]
  /// (a range alone), "hypotheses": [id, x, y, cxx, cxy, cyy, weight, ...] (landmarks waiting to
  /// start: SlamFilter::landmark_hypotheses), "particles": [x, y, ...], "error": [ex, ey, etheta]
  /// (only with a truth)}]}; rings, hypotheses and particles only where there are any. Decisions:
  /// 0 update, 1 new, 2 discard, 3 wrong update, 4 pending. A grid filter's frames have no
  /// landmarks or rays but "beam_ends": [x, y, ...] (where the scan's returns end, from the pose)
  /// and, in some frames, "grid": {"png": base64, "x", "y", "w", "h"} (the map's picture, its
  /// lower-left corner and extent in metres: GridImage).
  nlohmann::json to_json(const std::string& filter_name,
                         const std::optional<Pose2>& truth_from_estimate = std::nullopt) const;

 private:
  /// Adds the filter's particles (at most max_particles) to `frame` and keeps it, with its pose.
  void keep_frame(const SlamFilter& filter, double t, const Pose2& pose, nlohmann::json frame);

  const Dataset& dataset_;
  ReplayOptions options_;
  std::size_t scans_total_ = 0;
  std::size_t stride_ = 1;
  std::size_t scan_index_ = 0;
  std::size_t grid_frame_stride_ = 1;  // frames between two pictures of the grid
  /// Each filter landmark's origin: the true landmark of the observation that started it.
  std::unordered_map<int, int> origin_;
  nlohmann::json frames_ = nlohmann::json::array();
  std::vector<StampedPose> frame_poses_;  // for the pose error, taken once the alignment is known
};

}  // namespace slamkit
