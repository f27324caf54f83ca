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
  /// The same for a range scan, for the filters that map with them.
  virtual void on_range_scan(const SlamFilter& /*filter*/, const RangeScanEvent& /*scan*/,
                             std::size_t /*events_done*/, std::size_t /*events_total*/) {}
};

/// What a run keeps of its course, beyond the final map and estimate.
enum class History {
  kFull,       // every per-step estimate, every scan's associations, every sample (the default)
  kDecimated,  // at most RunOptions::decimated_samples sample times per series, evenly spread; no
               // associations (they are scored per scan, so a thinned list would score nothing)
  kNone,       // the start and the latest estimate only: memory stays flat however long the run
};

/// "full", "decimated" or "none"; throws std::invalid_argument naming the accepted values.
History parse_history(const std::string& name);
std::string to_string(History history);

struct RunOptions {
  /// Landmark standard deviations and particle clouds are sampled at most this often [s] (every
  /// scan if 0).
  double std_interval_s = 1.0;
  History history = History::kFull;
  /// With History::kDecimated: the most sample times each series keeps. When a series reaches it,
  /// every other time is dropped and from then on only every other one is taken.
  std::size_t decimated_samples = 10'000;
  std::vector<RunObserver*> observers;
  /// When set (e.g. by a SIGINT handler), the run stops after the current event and its result is
  /// marked partial: everything up to there, written like a whole run.
  const std::atomic<bool>* stop = nullptr;
};

/// Runs `filter` over every event of `dataset`. One trajectory sample per distinct event time,
/// taken after all events at that time (control, then scan) are applied (thinned as
/// options.history says). Without full history the filter is told to forget its smoothed trajectory
/// (SlamFilter::forget_smoothed_trajectory), which such a run never reads. Throws InputError, before
/// running, for an event stream check_events refuses.
RunResult run_filter(SlamFilter& filter, const Dataset& dataset, const RunOptions& options = {});

/// Throws InputError naming the dataset when it holds nothing `filter` maps with: no range scans for
/// a filter that maps range scans, or range scans only for one that maps landmarks.
void check_filter_fits(const SlamFilter& filter, const Dataset& dataset);

/// Throws InputError naming the dataset for an initial pose beyond kMaxAbsCoordinate (core/coordinates.hpp)
/// or with a heading that is not finite, and the first event no filter can be fed: a time that is not
/// finite, beyond kMaxAbsTime or earlier than the event before; a control interval dt that is
/// negative or not finite; a control of the wrong size for the motion model; or a control or
/// observation component that is not finite or beyond kMaxAbsValue. The readers check their files
/// more closely; this is the runner's guard for datasets built in code.
void check_events(const Dataset& dataset);
/// Beyond any clock a log is kept in (Unix time is 1.8e9 s), and far enough below 2^53 that time
/// differences keep sub-millisecond resolution.
inline constexpr double kMaxAbsTime = 1e12;  // s
/// A control or observation component (m, m/s, rad, rad/s) beyond anything a vehicle or sensor
/// measures; below it, the squares and products of the filters' Jacobians cannot overflow.
inline constexpr double kMaxAbsValue = 1e6;

/// The trajectory the controls alone give: the motion model integrated from the initial pose.
std::vector<StampedPose> dead_reckoning(const Dataset& dataset);

}  // namespace slamkit
