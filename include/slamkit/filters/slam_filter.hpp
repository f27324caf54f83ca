#pragma once
// The interface every SLAM filter implements: the recursive time update (eq. 4) driven by control
// events and the measurement update (eq. 5) driven by observation scans, plus read access to the
// current estimate. The runner feeds a dataset's event stream through it and never needs to know
// which filter it drives.
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "slamkit/core/association_record.hpp"
#include "slamkit/core/grid_map.hpp"
#include "slamkit/core/information_matrix.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

/// Thrown by a filter whose numbers have broken down, such as an information matrix too
/// ill-conditioned to factorise: from there its estimate means no more than one that is not finite,
/// so the runner ends the run as diverged at that event, keeping what ran (RunResult::divergence).
class FilterBreakdown : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class SlamFilter {
 public:
  virtual ~SlamFilter() = default;

  virtual std::string name() const = 0;
  /// Time update with the control applied over the event's dt.
  virtual void predict(const ControlEvent& control) = 0;
  /// Measurement update with every observation of one scan; adds newly seen landmarks.
  virtual void update(const ScanEvent& scan) = 0;
  /// Whether the filter maps with whole range scans (occupancy grids, scan matching). The runner
  /// gives those filters the dataset's RangeScanEvents and the others its landmark scans, and refuses
  /// before running a dataset that holds nothing the filter can use.
  virtual bool maps_range_scans() const { return false; }
  /// Measurement update with one range scan; called only where maps_range_scans() says so.
  virtual void update_range_scan(const RangeScanEvent& /*scan*/) {}

  virtual Pose2 pose() const = 0;
  virtual Matrix3 pose_covariance() const = 0;
  /// Landmarks in the filter's state, provisional ones included.
  virtual std::size_t num_landmarks() const = 0;
  /// The current map of confirmed landmarks, each with its marginal 2x2 covariance.
  virtual std::vector<Landmark> landmarks() const = 0;
  /// One record per observation of the last scan given to update(), in the scan's order.
  virtual const std::vector<AssociationRecord>& last_associations() const = 0;
  /// Which observation started the landmark with this map id, for filters whose recorded decisions
  /// need not show it: a particle filter records the best particle's decisions, and a landmark of
  /// the final map may have been started in a particle that was not the best then. Filters whose
  /// records show every start (the Gaussian filters) return nothing.
  virtual std::optional<LandmarkOrigin> landmark_origin(int /*id*/) const { return std::nullopt; }

  /// The whole trajectory as the filter now believes it, where that differs from the sequence of
  /// its per-step estimates (FastSLAM: the highest-weight particle's path). Empty otherwise.
  virtual std::vector<StampedPose> smoothed_trajectory() const { return {}; }
  /// From now on keeps nothing for smoothed_trajectory(), which then returns nothing: a run that
  /// will not read it holds its memory flat however long it goes (FastSLAM's paths grow by a pose
  /// per step). Filters that keep nothing for it have nothing to do.
  virtual void forget_smoothed_trajectory() {}
  /// Pose samples with their normalised weights (particle filters); empty for Gaussian filters.
  virtual std::vector<WeightedPose> pose_samples() const { return {}; }
  /// Where the landmarks waiting to start may lie (a landmark initialiser's hypotheses: a range's
  /// ring, or the positions a bearing's or range's observations admit so far), relative to the
  /// current pose as they would start; empty where every landmark starts at once.
  virtual std::vector<LandmarkHypothesis> landmark_hypotheses() const { return {}; }
  /// Filter-specific figures for metrics.json, e.g. {"particles": 100, "ess_mean": 61.2}.
  virtual std::map<std::string, double> statistics() const { return {}; }
  /// The occupancy grid map of a filter that maps range scans (the best particle's, for a particle
  /// filter); empty for the others.
  virtual GridMap grid_map() const { return {}; }
  /// The information matrix of a filter in information form (EIF, SEIF), as its picture shows it;
  /// empty for the others.
  virtual std::vector<InformationMatrixPanel> information_panels() const { return {}; }
};

}  // namespace slamkit
