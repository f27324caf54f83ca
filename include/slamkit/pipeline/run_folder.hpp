#pragma once
// A run folder as `slamkit run` leaves it, written from a run and the dataset it ran on: the run's
// own files (io/run_io.hpp), truth.tum, metrics.json and the pictures (plot/report.hpp), and, for a
// run recorded with a ReplayRecorder, replay.json and replay.html. Every front end (the command
// line, the Python module) writes its folders through these, so `slamkit evaluate` and `slamkit
// run --config` read them all the same way.
#include <nlohmann/json.hpp>
#include <string>

#include "slamkit/core/dataset.hpp"
#include "slamkit/core/run_result.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/replay.hpp"

namespace slamkit {

/// What run.json records of the dataset beyond its spec, added to `provenance`: a simulator log's
/// params.json (under "simulator"), and the source's time of t = 0 as exact decimal text (under
/// "time_origin_s": trajectory.tum and truth.tum times plus it are the source's times).
/// `absolute_spec` is absolute_dataset_spec() of the spec the dataset was loaded from.
void add_dataset_provenance(nlohmann::json& provenance, const std::string& absolute_spec, const Dataset& dataset);

/// evaluate_run against the dataset's truth, and for a grid map the map score against the map the
/// dataset's scans draw from the true poses (Metrics::grid_map_precision, ...), which needs the scans.
Metrics evaluate_run(const RunResult& run, const Dataset& dataset, const EvaluationOptions& options = {});

/// Evaluates `run` against `dataset`'s truth and writes truth.tum (removed where there is no truth
/// trajectory), metrics.json and the pictures into `dir`: what `slamkit evaluate` rewrites.
Metrics write_evaluation(const std::string& dir, const RunResult& run, const Dataset& dataset,
                         const EvaluationOptions& options = {});

/// The replay recording of `run`, with the pose error taken as the page says: in the map's frame
/// where the truth has headings (it shares the start pose, as pose NEES assumes), after the
/// evaluation's SE(2) alignment where it has positions only (GPS, in a frame of its own).
nlohmann::json replay_recording(const ReplayRecorder& recorder, const RunResult& run, const Dataset& dataset,
                                const Metrics& metrics);

/// Writes every file of a run folder into `dir`, a staged folder (io/run_io.hpp, stage_run_folder)
/// that the caller commits: write_run_files(), write_evaluation() and, with a `replay` that
/// recorded the run, replay.json and replay.html. Returns the evaluation. Throws InputError if a
/// file cannot be written. The command line stages its folder before it reads the data, so that a
/// second writer of the folder is refused at once.
Metrics write_run_folder_files(const std::string& dir, const RunResult& run, const Dataset& dataset,
                               const ReplayRecorder* replay = nullptr);

/// Replaces the run folder `dir` as a whole by the run's (stage_run_folder, write_run_folder_files,
/// commit): the previous one stays until every file of the new one is written.
Metrics write_run_folder(const std::string& dir, const RunResult& run, const Dataset& dataset,
                         const ReplayRecorder* replay = nullptr);

}  // namespace slamkit
