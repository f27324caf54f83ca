#pragma once
// What a run produces, as the runner records it, the run folder stores it and evaluation reads it:
// the estimated trajectory with its pose covariance, the final map, the landmark standard deviations
// over time (the data of the tutorial's Figure 3) and what the filter did with each observation.
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "slamkit/core/association_record.hpp"
#include "slamkit/core/grid_map.hpp"
#include "slamkit/core/information_matrix.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

/// One particle at one time, for pictures of the cloud.
struct ParticleSample {
  double t = 0.0;
  WeightedPose particle;
};

struct LandmarkStdSample {
  double t = 0.0;
  int id = 0;
  double std_x = 0.0;
  double std_y = 0.0;
};

/// Everything a run writes to its output folder (and `slamkit evaluate` reads back).
struct RunResult {
  std::string filter;
  std::string dataset;
  std::string dataset_settings;  // the JSON settings file the dataset was read with; empty: defaults
  std::string association;  // "known", "nn" or "jcbb"
  /// The estimated trajectory: the filter's smoothed trajectory where it has one (FastSLAM's best
  /// particle), else the per-step estimates.
  std::vector<StampedPose> trajectory;
  /// Whether `trajectory` is a smoothed one, not the per-step estimates.
  bool smoothed = false;
  /// The per-step (filtering) estimates with their covariances: what ATE and NEES are computed on.
  std::vector<StampedPose> filtered;
  std::vector<Matrix3> pose_covariances;  // one per filtered sample
  /// An information filter's information matrix at the end (SlamFilter::information_panels).
  std::vector<InformationMatrixPanel> information;
  std::vector<StampedPose> dead_reckoning;
  std::vector<Landmark> map;
  /// The occupancy grid of a filter that maps range scans; empty for the landmark filters.
  GridMap grid;
  std::vector<LandmarkStdSample> landmark_std;
  /// Per scan, in stream order, what the filter did with each observation.
  std::vector<double> scan_times;
  std::vector<std::vector<AssociationRecord>> associations;
  /// The origins of the landmarks named in `associations` and `map`, where the filter reports them
  /// (SlamFilter::landmark_origin); evaluation prefers them to the "new" records.
  std::map<int, LandmarkOrigin> landmark_origins;
  /// Particle clouds (particle filters only), sampled like landmark_std.
  std::vector<ParticleSample> particles;
  /// Filter-specific figures (SlamFilter::statistics at the end of the run).
  std::map<std::string, double> statistics;
  std::size_t steps = 0;         // control events
  std::size_t scans = 0;         // observation scans
  std::size_t observations = 0;  // individual landmark observations
  double wall_time_s = 0.0;      // filter time only, not reading or writing files
  /// What the run kept of its course: "full", "decimated" (series thinned, no associations) or
  /// "none" (the start and the final estimate only); see pipeline/runner.hpp.
  std::string history = "full";
  /// The run stopped before the end of the dataset (interrupted, or diverged); everything above
  /// covers the part that ran.
  bool partial = false;
  /// Set when the run stopped because the filter's pose estimate stopped being finite, or its numbers
  /// broke down (FilterBreakdown): the time of the event after which it was not to be trusted. The
  /// trajectories end at the last estimate before it, and the map holds only its finite landmarks.
  std::optional<double> diverged_at_s;
  /// Why, with diverged_at_s: "its pose estimate was no longer finite", or what broke down.
  std::string divergence;
  /// Where the run came from, as the front end describes it for run.json: the version, the command
  /// line, every effective setting, the dataset settings' contents (see io/run_io.hpp). Kept as JSON
  /// so that a new setting reaches run.json without a change here.
  nlohmann::json provenance = nlohmann::json::object();
};

}  // namespace slamkit
