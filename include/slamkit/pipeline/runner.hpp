#pragma once
// Drives a filter over a dataset's event stream and records what a run produces: the estimated
// trajectory with its pose covariance, the final map, and the landmark standard deviations over
// time (the data of the tutorial's Figure 3). Also integrates dead reckoning from the same controls
// for contrast.
#include <atomic>
#include <cstddef>
#include <string>
#include <vector>

#include "slamkit/core/dataset.hpp"
#include "slamkit/core/run_result.hpp"
#include "slamkit/filters/slam_filter.hpp"

namespace slamkit {

/// Told about a run as it goes, after each scan the filter has processed: how progress is shown,
/// and how a replay records the filter's state scan by scan. Called on the runner's thread.
class RunObserver {
 public:
  virtual ~RunObserver() = default;
  /// `scan` has just been applied; `events_done` of the dataset's `events_total` are processed.
  virtual void on_scan(const SlamFilter& filter, const ScanEvent& scan, std::size_t events_done,
                       std::size_t events_total) = 0;
};

struct RunOptions {
  /// Landmark standard deviations and particle clouds are sampled at most this often [s] (every
  /// scan if 0).
  double std_interval_s = 1.0;
  std::vector<RunObserver*> observers;
  /// When set (e.g. by a SIGINT handler), the run stops after the current event and its result is
  /// marked partial: everything up to there, written like a whole run.
  const std::atomic<bool>* stop = nullptr;
};

/// Runs `filter` over every event of `dataset`. One trajectory sample per distinct event time,
/// taken after all events at that time (control, then scan) are applied.
RunResult run_filter(SlamFilter& filter, const Dataset& dataset, const RunOptions& options = {});

/// The trajectory the controls alone give: the motion model integrated from the initial pose.
std::vector<StampedPose> dead_reckoning(const Dataset& dataset);

}  // namespace slamkit
