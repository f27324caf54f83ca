#pragma once
// The output folder of a run. Files (all plain text a person or another tool can read):
//   trajectory.tum       estimated trajectory, TUM format `t x y z qx qy qz qw`
//   pose_covariance.txt  `t c_xx c_xy c_xt c_yy c_yt c_tt`, one per trajectory sample
//   dead_reckoning.tum   the controls integrated without any observation, for contrast
//   map.txt              final map `id x y c_xx c_xy c_yy`
//   map.pgm, map.yaml    a grid-mapping filter's occupancy grid, in ROS map_server's convention
//   landmark_std.txt     `t id std_x std_y`: landmark standard deviations over time (Figure 3)
//   associations.txt     `scan t observation decision landmark_id`, every observation's decision
//   landmark_origins.txt `landmark_id scan observation`: where the filter reports it (particle
//                        filters), the observation each landmark named above was started from
//   run.json             filter, dataset spec, counts, wall time, "partial" (true if interrupted),
//                        and the run's provenance (RunResult::provenance) alongside
//   metrics.json         the evaluation (written by the evaluation, see eval/evaluation.hpp)
// Beside them the command line writes truth.tum (the ground truth, same time base), the plots, and
// with --replay replay.json and replay.html (pipeline/replay.hpp, plot/replay_html.hpp).
//
// A run folder is replaced as a whole (core/atomic_folder.hpp): a new run is written into a staging
// folder beside it, which takes its place when complete, so a run that fails or is killed half-way
// leaves the previous run as it was, never new files beside old ones.
#include <string>

#include "slamkit/core/atomic_folder.hpp"
#include "slamkit/core/run_result.hpp"

namespace slamkit {

/// The replacement of run folder `dir` (which may not exist yet): write the run's files into
/// path(), then commit(). Refuses, with an InputError, a folder another process is writing and an
/// existing folder that is not empty and holds no run.json.
AtomicFolder stage_run_folder(const std::string& dir);

/// Writes every file of a run except metrics.json into `dir`, a new folder such as
/// stage_run_folder(...).path(). Throws InputError if it cannot.
void write_run_files(const std::string& dir, const RunResult& run);

/// Writes run.json alone (what the run was and its provenance): the one file of a run that a campaign
/// keeping only metrics writes besides metrics.json.
void write_run_json(const std::string& dir, const RunResult& run);

/// Replaces the run folder `dir` by one holding `run` (stage_run_folder, write_run_files, commit).
void write_run(const std::string& dir, const RunResult& run);

/// Throws InputError naming `dir` unless it is a folder and not one being written (see AtomicFolder).
void require_run_folder(const std::string& dir);

/// Reads a run folder back. Throws InputError naming the file and line of any problem, or naming
/// the folder if it is the incomplete staging folder of a run being written or killed.
RunResult read_run(const std::string& dir);

}  // namespace slamkit
