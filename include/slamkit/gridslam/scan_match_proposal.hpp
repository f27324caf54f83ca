#pragma once
// The improved proposal of grid-based FastSLAM (Grisetti, Stachniss and Burgard, "Improved
// techniques for grid mapping with Rao-Blackwellized particle filters", IEEE T-RO 23(1), 2007): a
// particle's pose after a scan is drawn from p(x | m, z, x', u) ~ p(z | m, x) p(x | x', u), which a
// laser makes far narrower than the odometry's prior. The scan matcher climbs to the product's peak
// from the odometry's prediction; the product is evaluated on a pattern of 19 poses around it,
// whose finite differences give the curvature of a Laplace approximation: the Gaussian the pose is
// drawn from, as wide as the product is along every direction (along a corridor, the odometry's
// spread), however fine the pattern. Its integral (the proposal's normalising constant) is the
// particle's weight factor. Where the match cannot be trusted (too few beams found an obstacle, as
// in a corridor's open end or before there is a map), the odometry's prior is the proposal and the
// likelihood at the drawn pose the weight factor. The scan-matching filter uses the same Gaussian with one particle.
#include <random>

#include "slamkit/core/types.hpp"
#include "slamkit/grid/occupancy_grid.hpp"
#include "slamkit/grid/scan_matcher.hpp"

namespace slamkit {

class MotionModel;

/// The settings the scan-matching filter and grid FastSLAM share.
struct GridSlamOptions {
  GridOptions grid;
  ScanMatcherOptions matcher;
  /// The log-likelihood of a scan is divided by this before it meets the odometry's prior: beams of
  /// one scan are not independent (a map error or an unmapped object moves many together), so their
  /// product would be far too sure of itself. GMapping divides by 3 for the same reason.
  double likelihood_temperature = 3.0;
  /// Grid FastSLAM divides a particle's log weight factor by this as well: it flattens the weights
  /// without widening the proposal. The temperature above shapes where a particle goes, this one how
  /// fast the lineages die out; with 1 the particles resample after four scans of five and one
  /// lineage is left when a loop closes. It goes with update_distance: the fewer scans are weighed
  /// per metre, the more each weighs. 30 was chosen with 1 m between mapped scans on ring seeds
  /// 11-20 and ACES and CSAIL with odometry seed 1 (10 was, when every scan was weighed;
  /// docs/grid-mapping.md). GMapping divides by three times the particle count.
  double weight_temperature = 30.0;
  /// A match is trusted when at least this share of the beams used found an obstacle near its end.
  double min_matched_fraction = 0.3;
  /// The pattern the proposal's curvature is measured on: the peak and the poses +-these along one or
  /// two of x, y and heading (19 poses).
  double proposal_spread_m = 0.02;
  double proposal_spread_rad = 0.01;
  /// A particle draws its pose from N(mean, f covariance) of the proposal: f = 1 is the textbook
  /// proposal, f = 0 takes its mean (GMapping's implementation moves a particle to its match). What a
  /// particle draws it maps: with the whole covariance drawn each particle's map is drawn from a path
  /// as noisy as the proposal is wide, and matching against that blurs the next proposal; 0.3 was
  /// chosen on the ring's seeds 1-3 (docs/grid-mapping.md).
  double proposal_sample_fraction = 0.3;
  /// A scan is matched and mapped only when the odometry has moved the robot this far, or turned it
  /// this much, since the last scan that was; the scans between are skipped (and counted). Every
  /// match leaves a small error in the map the next scan is matched against, and the errors of
  /// scans a few centimetres apart are alike (the same walls seen from nearly the same place), so
  /// the map drifts with the number of scans matched as well as with the distance driven. GMapping's
  /// defaults (linearUpdate 1 m, angularUpdate 0.5 rad) are kept; docs/grid-mapping.md compares
  /// every scan, 0.5 and 1 m on ring seeds 11-20, which the results do not use. 0 and 0 match every
  /// scan.
  double update_distance = 1.0;  // m
  double update_rotation = 0.5;  // rad
};

/// Whether a scan is due to be matched and mapped (GridSlamOptions::update_distance): the odometry's
/// travel and turning since the last scan that was, summed over the controls between.
class ScanCadence {
 public:
  /// The prediction of one control moved the pose from `before` to `after`.
  void moved(const Pose2& before, const Pose2& after);
  /// The first scan is always due (it starts the map); later ones once the robot has moved enough.
  bool due(const GridSlamOptions& options) const;
  /// Called for each scan: true (and the travel restarts) when the scan is due, false when skipped.
  bool take(const GridSlamOptions& options);
  std::size_t skipped() const { return skipped_; }

 private:
  double travelled_ = 0.0;  // m
  double turned_ = 0.0;     // rad
  bool started_ = false;
  std::size_t skipped_ = 0;
};

/// Throws std::invalid_argument, one line naming the setting (as run.json's settings.grid names it)
/// and its range, for settings no grid filter could run with.
void validate(const GridSlamOptions& options);

struct PoseProposal {
  Pose2 mean = Pose2::Zero();
  Matrix3 covariance = Matrix3::Zero();
  /// log of the weight factor: the proposal's normalising constant, or the likelihood at the draw.
  double log_weight = 0.0;
  bool matched = false;  // the scan matcher's peak was trusted
};

/// The proposal for a pose predicted by odometry as N(prior_mean, prior_covariance), given the map
/// so far. With `rng` the pose is drawn from N(mean, f covariance), f = proposal_sample_fraction:
/// `mean` then holds the draw and `covariance` the (1 - f) covariance the particle carries about it,
/// as FastSLAM 2.0's pose_sample_fraction does. Without, they are the proposal's own.
PoseProposal scan_match_proposal(const ScanMatcher& matcher, const OccupancyGrid& map, const RangeScanEvent& scan,
                                 const Pose2& prior_mean, const Matrix3& prior_covariance,
                                 const GridSlamOptions& options, std::mt19937_64* rng);

/// Adds the motion over one control to a pose prediction N(mean, covariance): the odometry's prior
/// between scans.
void predict_pose(const MotionModel& motion, const ControlEvent& control, Pose2& mean, Matrix3& covariance);

}  // namespace slamkit
