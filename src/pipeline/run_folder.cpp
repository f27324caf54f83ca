#include "slamkit/pipeline/run_folder.hpp"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>

#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/grid/grid_snapshot.hpp"
#include "slamkit/grid/map_comparison.hpp"
#include "slamkit/grid/reference_map.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/io/trajectory_io.hpp"
#include "slamkit/plot/replay_html.hpp"
#include "slamkit/plot/report.hpp"

namespace slamkit {

namespace fs = std::filesystem;

void add_dataset_provenance(nlohmann::json& provenance, const std::string& absolute_spec, const Dataset& dataset) {
  if (absolute_spec.starts_with("sim:"))
    provenance["simulator"] = read_json_file((fs::path(absolute_spec.substr(4)) / "params.json").string());
  // Exact decimal text: a double would lose the sub-microsecond digits of a Unix time.
  if (dataset.time_origin_s != 0 || dataset.time_origin_fraction_s != 0.0)
    provenance["time_origin_s"] =
        fmt::format("{}.{:09}", dataset.time_origin_s, std::llround(dataset.time_origin_fraction_s * 1e9));
}

namespace {

/// The grid map against the one the dataset's scans draw from the true poses, at the map's resolution.
void score_grid_map(const RunResult& run, const Dataset& dataset, Metrics& metrics) {
  GridOptions options;
  options.resolution = run.grid.resolution;
  const std::optional<OccupancyGrid> reference = reference_map(dataset, options);
  if (!reference) return;
  const MapAgreement agreement = compare_maps(from_grid_map(run.grid, options), *reference);
  metrics.grid_map_precision = agreement.precision;
  metrics.grid_map_recall = agreement.recall;
  metrics.grid_map_agreement = agreement.cell_agreement;
}

}  // namespace

Metrics evaluate_run(const RunResult& run, const Dataset& dataset, const EvaluationOptions& options) {
  Metrics metrics = evaluate_run(run, dataset.truth, options);
  if (!run.grid.empty()) score_grid_map(run, dataset, metrics);
  return metrics;
}

Metrics write_evaluation(const std::string& dir, const RunResult& run, const Dataset& dataset,
                         const EvaluationOptions& options) {
  // The truth in TUM format beside the estimate (same times), so tools such as evo compare them as
  // they are. A truth of positions only (GPS) gets heading 0.
  const std::string truth_path = (fs::path(dir) / "truth.tum").string();
  if (dataset.truth.poses.empty())
    fs::remove(truth_path);
  else
    write_tum(truth_path, dataset.truth.poses);
  const Metrics metrics = evaluate_run(run, dataset, options);
  write_metrics(dir, metrics);
  write_run_plots(dir, run, dataset.truth, metrics);
  return metrics;
}

nlohmann::json replay_recording(const ReplayRecorder& recorder, const RunResult& run, const Dataset& dataset,
                                const Metrics& metrics) {
  if (dataset.truth.poses_have_heading) return recorder.to_json(run.filter);
  const eval::Se2Transform& a = metrics.alignment;
  return recorder.to_json(run.filter, Pose2(a.translation.x(), a.translation.y(), a.theta));
}

Metrics write_run_folder_files(const std::string& dir, const RunResult& run, const Dataset& dataset,
                               const ReplayRecorder* replay) {
  write_run_files(dir, run);
  const Metrics metrics = write_evaluation(dir, run, dataset);
  if (replay != nullptr) {
    const nlohmann::json recording = replay_recording(*replay, run, dataset, metrics);
    write_file_atomically((fs::path(dir) / "replay.json").string(), recording.dump() + "\n");
    plot::write_replay_html((fs::path(dir) / "replay.html").string(), recording);
  }
  return metrics;
}

Metrics write_run_folder(const std::string& dir, const RunResult& run, const Dataset& dataset,
                         const ReplayRecorder* replay) {
  AtomicFolder folder = stage_run_folder(dir);
  const Metrics metrics = write_run_folder_files(folder.path(), run, dataset, replay);
  folder.commit();
  return metrics;
}

}  // namespace slamkit
