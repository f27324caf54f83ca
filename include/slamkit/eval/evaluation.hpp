#pragma once
// Turns a run and the dataset's ground truth into the numbers metrics.json reports. Every accuracy
// figure names its metric:
//   ate_rmse_m              RMSE of position over the time-matched truth samples, after the SE(2)
//                           least-squares alignment of the per-step (filtered) estimates onto the
//                           truth; smoothed_ate_rmse_m the same for a smoothed trajectory. Matched
//                           by interpolating the estimate at each truth time, or as evo matches
//                           (TimeMatching)
//   unaligned_position_rmse_m  the same RMSE without the alignment, where the truth has headings:
//                           its frame is the map's (the start pose is known in it), as for NEES. An
//                           EKF that turned its whole map about the start keeps that error here
//   final_position_error_m  position error of the last matched sample, same alignment
//   map_rmse_m              RMSE of landmark position over landmarks paired with the truth, after
//                           the trajectory's alignment (map_alignment "trajectory"); with no
//                           trajectory truth, after the SE(2) least-squares alignment of the paired
//                           landmarks onto their true positions ("landmarks", at least 3 pairs), which
//                           scores the map's shape only. Each landmark is paired by its origin (below)
//                           where the truth names the landmark of every observation, else by its id
//                           with known association; without either there is no pairing and no
//                           map_rmse_m. Of several landmarks with one origin only the first counts.
//   nees_pose_*             normalised estimation error squared of the pose (3 dof), unaligned (the
//                           map frame is the truth frame at the start), where the truth has headings
//   association             where the truth names the landmark of every observation: each filter
//                           landmark's origin is the true landmark of the observation that started it
//                           (as RunResult::landmark_origins gives it, else as the "new" records show);
//                           a pairing is correct when the observation's true landmark is the origin of
//                           the landmark it updated, wrong otherwise (clutter paired with a landmark
//                           included); missed when an observation of a true landmark the filter already
//                           had was not paired (discarded, or started a duplicate). Spurious landmarks
//                           are final-map landmarks started by clutter or duplicating another's origin.
//   loop_closure_fraction   where the truth names the landmark of every observation: of the returns
//                           (observations of a true landmark last observed more than revisit_gap_s
//                           earlier, and the observations of it that follow), the share paired with
//                           a landmark that true landmark started before its return (not a duplicate
//                           started since). A loop is closed when it is at least kLoopClosedFraction.
#include <nlohmann/json_fwd.hpp>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "slamkit/eval/metrics.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/core/run_result.hpp"

namespace slamkit {

struct AssociationMetrics {
  std::size_t correct = 0, wrong = 0, missed = 0;
  std::size_t clutter_observations = 0, clutter_discarded = 0;
  std::size_t spurious_landmarks = 0;
  std::size_t landmarks_true_seen = 0;
  std::size_t return_observations = 0;       // see loop_closure_fraction in the header comment
  std::size_t return_observations_closed = 0;
  /// return_observations_closed / return_observations; unset without returns.
  std::optional<double> loop_closure_fraction() const;
};

/// loop_closure_fraction at or above which a run counts as having closed its loop: most returns
/// paired with the first lap's landmark, whatever missed detections and ambiguous discards cost.
inline constexpr double kLoopClosedFraction = 0.8;

struct Metrics {
  std::string filter;
  std::string dataset;
  std::size_t steps = 0, scans = 0, observations = 0, landmarks = 0;
  double wall_time_s = 0.0;

  std::size_t matched_poses = 0;
  std::optional<double> ate_rmse_m, final_position_error_m;  // of the per-step (filtered) estimates
  std::optional<double> unaligned_position_rmse_m;
  bool smoothed = false;                                       // the run's trajectory is smoothed
  std::optional<double> smoothed_ate_rmse_m;
  std::optional<double> dead_reckoning_ate_rmse_m, dead_reckoning_final_position_error_m;
  std::optional<double> map_rmse_m;
  std::size_t map_landmarks_paired = 0;
  /// Kuemmerle et al.'s relative error of the run's trajectory (eval::relative_pose_error).
  std::optional<eval::RelativePoseError> relative_error;
  /// An occupancy grid run's map against the map the dataset's scans draw from the true poses
  /// (grid/map_comparison.hpp): filled in by the pipeline, which has the scans.
  std::optional<double> grid_map_precision, grid_map_recall, grid_map_agreement;
  std::optional<eval::NeesSummary> nees_pose;
  /// (t, pose NEES) at every step nees_pose summarises, for the NEES-over-time pictures.
  std::vector<Vector2> nees_pose_series;
  std::optional<AssociationMetrics> association;
  std::string association_method;
  /// The run's history mode. With "none" only the start and the final estimate were kept: two poses
  /// that any SE(2) alignment fits, so the trajectory metrics (ATE, NEES, map after alignment) are
  /// left empty rather than reported near zero; "decimated" scores its evenly spread samples.
  std::string history = "full";
  double revisit_gap_s = 0.0;  // the EvaluationOptions' return gap the association metrics used
  std::map<std::string, double> filter_statistics;

  /// How the map was brought into the truth's frame for map_rmse_m: "trajectory" (the trajectory's
  /// alignment), "landmarks" (its own, onto the paired true landmarks; no trajectory truth), or empty
  /// when there is no map_rmse_m.
  std::string map_alignment;
  /// "interpolate" or "evo" (EvaluationOptions::time_matching), and evo's largest time difference.
  std::string time_matching = "interpolate";
  double max_time_difference_s = 0.0;

  eval::Se2Transform alignment;                // estimate -> truth, used for the map and the pictures
  eval::Se2Transform dead_reckoning_alignment; // dead reckoning -> truth
};

/// How estimate and truth samples are paired for the trajectory metrics.
enum class TimeMatching {
  /// The estimate interpolated at each truth time (eval::match_by_time): every truth sample inside
  /// the estimate's span scores, at its own time.
  kInterpolate,
  /// As evo pairs them (eval::match_nearest): nearest samples at most max_time_difference_s apart,
  /// nothing interpolated; reproduces evo_ape's numbers on slamkit's files.
  kEvo,
};
/// "interpolate" or "evo"; throws std::invalid_argument naming the accepted values.
TimeMatching parse_time_matching(const std::string& name);
std::string to_string(TimeMatching matching);

/// The least number of landmarks a map must pair with the truth to be aligned on them: two fit
/// rotation and translation to within the error of the distance between them, one exactly.
inline constexpr std::size_t kMinLandmarksToAlign = 3;

struct EvaluationOptions {
  TimeMatching time_matching = TimeMatching::kInterpolate;
  /// Estimate samples further apart than this [s] are not interpolated between (kInterpolate).
  double max_interpolation_gap_s = 1.0;
  /// Samples further apart in time are not paired (kEvo); evo's default.
  double max_time_difference_s = 0.01;
  /// A true landmark observed again after this long without an observation [s] is a return: longer
  /// than any one pass by a landmark in the simulator's worlds, shorter than a lap.
  double revisit_gap_s = 60.0;
};

Metrics evaluate_run(const RunResult& run, const GroundTruth& truth, const EvaluationOptions& options = {});

/// Whether the pose NEES of `filter`'s runs is a particle cloud's (FastSLAM's): the NEES of the
/// Gaussian with the particles' weighted mean and covariance, which resampling collapses, so it is
/// no consistency test. metrics.json says so in nees_pose_note, nees.svg under its title.
bool pose_nees_of_particle_cloud(const std::string& filter);
/// What that NEES is and why it is no consistency test: metrics.json's nees_pose_note.
inline constexpr std::string_view kParticleCloudNeesNote =
    "the NEES of the particle cloud's Gaussian (the particles' weighted mean and covariance), not of a posterior "
    "the filter keeps, and no consistency test: resampling depletes the cloud's history and collapses it (Bailey, "
    "Nieto and Nebot, 'Consistency of the FastSLAM algorithm', the tutorial's reference [2]), so a NEES far above 3 "
    "says the cloud is over-confident, not that the estimate diverged; judge accuracy by ate_rmse_m";

nlohmann::json to_json(const Metrics& metrics);
/// Writes metrics.json into `dir`.
void write_metrics(const std::string& dir, const Metrics& metrics);

/// One line with the headline numbers, for titles and the console; a number that needs a caveat
/// carries it (a map aligned on its own landmarks, FastSLAM's collapsed-cloud NEES, evo's matching).
std::string headline(const Metrics& metrics);

}  // namespace slamkit
