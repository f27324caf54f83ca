#pragma once
// Matching a range scan against an occupancy grid: the likelihood of a scan at a pose (a
// likelihood field read off the grid near each beam's end point), and a search for the pose that
// maximises it from a guess. The scan-matching filter corrects odometry with it, and grid FastSLAM
// builds its proposal distribution around its result.
#include "slamkit/core/types.hpp"
#include "slamkit/grid/occupancy_grid.hpp"

namespace slamkit {

struct ScanMatcherOptions {
  /// Standard deviation of a beam end point's distance to the nearest obstacle [m].
  double sigma = 0.05;
  /// How far around an end point an obstacle is looked for [cells]; a beam with none there counts
  /// as an outlier.
  int search_cells = 2;
  /// Log-likelihood of an outlier beam relative to a perfect hit (a floor, so one beam that sees
  /// something new cannot veto a match).
  double outlier_log_likelihood = -2.0;
  /// Every beam_stride-th beam is used (beams of one scan are strongly correlated).
  int beam_stride = 1;
  /// Beams longer than this are not matched [m].
  double max_range = 30.0;
  /// Cells with log-odds above this count as obstacles.
  float occupied_log_odds = 0.5f;
  /// An obstacle cell counts for a beam only if its neighbour towards the sensor is not an obstacle
  /// too: the beam must reach the obstacle's surface from free space. Without it, an end point that
  /// overshoots into a thick wall, or lands behind a wall seen from the other side, matches as well
  /// as one on the surface.
  bool free_before_hit = true;
  /// The search: coordinate steps starting at these sizes, halved when no step improves, until
  /// `refinements` halvings are done.
  double linear_step = 0.05;   // m
  double angular_step = 0.02;  // rad
  int refinements = 5;
};

/// Throws std::invalid_argument naming the setting: sigma > 0, search_cells from 0 to 20,
/// outlier_log_likelihood <= 0, beam_stride >= 1, max_range > 0 and <= 10 km, linear_step > 0 and
/// <= 100 m, angular_step > 0 and <= pi, refinements from 0 to 40, all finite.
void validate(const ScanMatcherOptions& options);

struct ScanMatch {
  Pose2 pose = Pose2::Zero();
  double log_likelihood = 0.0;  // of the scan at `pose`
  /// Beams whose end point found an obstacle within search_cells, of `beams_used`.
  int beams_matched = 0;
  int beams_used = 0;
};

/// What was believed of the pose before the scan, for a search of the posterior's peak rather than the
/// likelihood's: where the scan is ambiguous (along a corridor longer than the laser's range) the
/// likelihood is nearly flat, and its peak wanders wherever a rounding error leads; the prior holds
/// the search where the odometry put the robot.
struct PosePrior {
  Pose2 mean = Pose2::Zero();
  Matrix3 information = Matrix3::Zero();  // the inverse of the prior's covariance
  /// The scan's log-likelihood is multiplied by this before it meets the prior (1 / temperature).
  double likelihood_scale = 1.0;

  /// The posterior's log at `pose`, up to a constant: likelihood_scale times the scan's
  /// log-likelihood there, minus half the squared Mahalanobis distance from the mean.
  double log_posterior(const Pose2& pose, double log_likelihood) const;
};

class ScanMatcher {
 public:
  /// Throws std::invalid_argument when `options` fail validate().
  explicit ScanMatcher(const ScanMatcherOptions& options = {});
  const ScanMatcherOptions& options() const { return options_; }

  /// Log-likelihood of `scan` taken with the vehicle at `vehicle_pose` given `map` (sum over the beams
  /// used of the per-beam term). A map with no obstacle near any beam gives beams_used outliers.
  /// Per beam: max(-d^2 / (2 sigma^2), outlier_log_likelihood), d the distance from the beam's end
  /// point to the centre of the nearest obstacle cell within +-search_cells cells.
  /// Throws std::invalid_argument for a pose that is not finite or beyond kMaxAbsCoordinate, or a scan
  /// whose angles are not finite. Allocates only when a thread meets more beams than ever before (its
  /// scratch is kept per thread).
  ScanMatch evaluate(const OccupancyGrid& map, const Pose2& vehicle_pose, const RangeScanEvent& scan) const;
  /// Hill-climbing from `guess` to a local maximum of evaluate()'s log-likelihood: the best of the six
  /// moves of one step along x, y or heading is taken while one improves; then the steps are halved,
  /// `refinements` times. Deterministic; at most 300 moves and halvings together.
  ScanMatch match(const OccupancyGrid& map, const Pose2& guess, const RangeScanEvent& scan) const;
  /// The same climb, from the prior's mean, of likelihood_scale times the scan's log-likelihood minus
  /// half the squared Mahalanobis distance from the prior's mean. The result's log_likelihood is the
  /// scan's own at the peak found.
  ScanMatch match(const OccupancyGrid& map, const PosePrior& prior, const RangeScanEvent& scan) const;

 private:
  template <typename Objective>
  ScanMatch climb(const OccupancyGrid& map, const Pose2& guess, const RangeScanEvent& scan,
                  const Objective& objective) const;

  ScanMatcherOptions options_;
};

}  // namespace slamkit
