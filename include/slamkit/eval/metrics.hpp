#pragma once
// Accuracy and consistency metrics of an estimate against ground truth: trajectory and map error after
// rigid alignment, and the normalized estimation error squared (NEES) with its chi-square bounds.
//
// Alignment is needed because SLAM fixes its own frame: an estimate can be perfect up to the rigid
// transform between its frame and the truth's, and that transform says nothing about accuracy.
#include <cstddef>
#include <optional>
#include <vector>

#include "slamkit/core/chi_square.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit::eval {

/// A rigid planar transform: rotate by theta about the origin, then translate.
struct Se2Transform {
  double theta = 0.0;
  Vector2 translation = Vector2::Zero();

  Vector2 apply(const Vector2& p) const;
  /// Moves the position and adds theta to the heading (wrapped).
  Pose2 apply(const Pose2& pose) const;
};

/// The rotation and translation (no scale) minimising sum_i |T(source_i) - target_i|^2, in closed
/// form: with both point sets centred on their centroids, theta = atan2(sum s_i x t_i, sum s_i . t_i)
/// and the translation maps the source centroid onto the target centroid.
///
/// One point fixes only the translation, and so does a source whose points all coincide: theta is then
/// 0. Throws std::invalid_argument if the sizes differ or the sets are empty.
Se2Transform align_se2(const std::vector<Vector2>& source, const std::vector<Vector2>& target);

/// An estimated pose and the true pose at the same instant.
struct PosePair {
  double t = 0.0;
  Pose2 estimate = Pose2::Zero();
  Pose2 truth = Pose2::Zero();
  /// Index into the estimate trajectory of the last sample at or before t.
  int estimate_index = 0;
};

/// Pairs every truth sample whose time lies within the estimate's time span with the estimate at that
/// time. An estimate sample with exactly the truth's timestamp is used as is (the last one, if several
/// share it); otherwise the estimate is interpolated between its two neighbouring samples, linearly in
/// position and the short way round in heading, provided they are at most max_gap seconds apart; truth
/// samples falling in a longer gap are skipped. Both inputs must be sorted by time (non-decreasing);
/// the pairing is a single merge, O(n + m). Throws std::invalid_argument if an input is unsorted or
/// max_gap is negative or NaN.
std::vector<PosePair> match_by_time(const std::vector<StampedPose>& estimate,
                                    const std::vector<StampedPose>& truth, double max_gap);

/// Pairs samples of the two trajectories as evo does (evo.core.sync.associate_trajectories, which
/// evo_ape and evo_rpe use): the shorter trajectory (the estimate when both are as long) is walked,
/// and each of its samples is paired with the other's sample nearest in time, the first of equally
/// near ones, if that is at most max_difference seconds away. Nothing is interpolated, samples
/// without a partner that near are left out, and a sample of the longer trajectory may be paired
/// more than once. evo's default max_difference is 0.01 s. Both inputs must be sorted by time;
/// throws std::invalid_argument if one is not or max_difference is negative or NaN.
std::vector<PosePair> match_nearest(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& truth,
                                    double max_difference);

/// Position RMSE, sqrt(mean |align(estimate_i) - truth_i|^2), over the pairs; headings are ignored.
/// Throws std::invalid_argument if there are no pairs.
double ate_rmse(const std::vector<PosePair>& pairs, const Se2Transform& align);

struct AteResult {
  double rmse = 0.0;
  /// Position error of the last pair after alignment: where the estimate ends up, i.e. drift.
  double final_error = 0.0;
  std::size_t matched = 0;
  /// The estimate-to-truth alignment used, for aligning the map or plotting with the same transform.
  Se2Transform align;
};

/// Absolute trajectory error: the position RMSE over the pairs after the SE(2) least-squares alignment
/// of the estimated positions onto the true ones (align_se2), i.e. the trajectory's shape error with
/// the arbitrary choice of frame removed. Throws std::invalid_argument if there are no pairs.
AteResult absolute_trajectory_error(const std::vector<PosePair>& pairs);

struct RelativePoseError {
  std::size_t pairs = 0;
  double translation_mean_m = 0.0, translation_std_m = 0.0;
  double rotation_mean_rad = 0.0, rotation_std_rad = 0.0;
};

/// Where the relative error takes its pose pairs: a truth sample starts a new pair once the truth has
/// moved this far or turned this much since the last one. These are the Radish logs' own scan
/// spacings, so on them the pairs are the consecutive scans, as in the benchmark's relations.
inline constexpr double kRelativePairDistance = 0.5;  // m
inline constexpr double kRelativePairRotation = 0.5;  // rad

/// The relative error of Kuemmerle et al. 2009 ("On measuring the accuracy of SLAM algorithms"):
/// for consecutive pose pairs (i, j) along the truth (spaced as above), the motion the estimate makes
/// from i to j, d_est = est_i^-1 est_j, against the truth's, d_ref = ref_i^-1 ref_j; the error is
/// e = d_ref^-1 d_est, its translation |e_xy| and rotation |e_theta| averaged (with their standard
/// deviations) over the pairs. Needs no alignment: it scores the local shape of the trajectory, which
/// an error made once (a wrong turn far back) does not dominate. Empty with fewer than one pair.
std::optional<RelativePoseError> relative_pose_error(const std::vector<PosePair>& pairs);

struct MapError {
  /// Position RMSE over the paired landmarks; empty when no landmark could be paired.
  std::optional<double> rmse;
  std::size_t paired = 0;
};

/// Map error: estimated and true landmarks are paired by equal id (estimates with no true counterpart,
/// and landmarks with kUnknownId, are not counted) and the RMSE of align(estimate position) - true
/// position is taken over the pairs. Pass the trajectory alignment (AteResult::align) so the map is
/// judged in the same frame as the path. Throws std::invalid_argument if an id other than kUnknownId
/// occurs twice in either map.
MapError map_rmse(const std::vector<Landmark>& estimate, const std::vector<Landmark>& truth,
                  const Se2Transform& align);

/// NEES of a pose, e^T P^-1 e with e = estimate - truth and its heading component wrapped. Solved via
/// a Cholesky factorisation of P (only its lower triangle is read; P is a covariance, so symmetric).
/// Returns +infinity if P is not numerically positive definite or any input is not finite: such an
/// estimate is inconsistent beyond measure, and an infinity falls outside every interval where a NaN
/// would silently compare false.
double pose_nees(const Pose2& estimate, const Matrix3& covariance, const Pose2& truth);

struct NeesSummary {
  /// Mean NEES; for a consistent filter it is close to dof.
  double mean = 0.0;
  /// Share of values inside `interval`; for a consistent filter it is close to the confidence.
  double in_interval_fraction = 0.0;
  Interval interval;
  std::size_t steps = 0;
};

/// Mean of the NEES values and the share of them inside the two-sided chi-square interval of `dof`
/// degrees of freedom at `confidence` (bounds inclusive). Infinite values count as outside and make
/// the mean infinite. Throws std::invalid_argument if `nees` is empty or holds a NaN or a negative
/// value, or if dof or confidence is out of range (see chi_square_interval).
NeesSummary summarize_nees(const std::vector<double>& nees, int dof, double confidence = 0.95);

}  // namespace slamkit::eval
