#pragma once
// A run as data, and the one function that carries it out: read the dataset, make the filter, run
// it, write the run folder and evaluate it. `slamkit run` (flags or --config), the Python module and
// the campaign runner all call execute(), so a run folder means the same whoever wrote it.
#include <atomic>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "slamkit/core/run_result.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/pipeline/settings.hpp"

namespace slamkit {

/// What run.json records of a run, and all that is needed to repeat it.
struct RunSpec {
  std::string dataset;  // "kind:PATH" as given; execute() records it made absolute
  /// The dataset settings' contents (null for the reader's defaults), the file they were read from
  /// ("" for none), and how errors in them name them (defaults to the file).
  nlohmann::json dataset_settings;
  std::string dataset_settings_path;
  std::string dataset_settings_source;
  FilterConfig filter;
  /// {"source": ..., "applied": {...}}: the dataset's recommended settings that took effect; null for none.
  nlohmann::json recommendation;
  History history = History::kFull;
};

/// The spec of a new run: `dataset` read with the settings file `dataset_settings_path` ("" for the
/// defaults), filter settings layered as pipeline/settings.hpp says (the dataset's recommendation
/// filled in here from its settings). Throws InputError for a settings file that cannot be read,
/// std::invalid_argument for settings that do not go together (a usage error).
RunSpec make_run_spec(const std::string& dataset, const std::string& dataset_settings_path, SettingsSources sources);
/// The same with the dataset settings given as JSON, named `dataset_settings_source` in errors.
RunSpec make_run_spec(const std::string& dataset, nlohmann::json dataset_settings,
                      const std::string& dataset_settings_source, SettingsSources sources);

/// The spec a run.json records (`slamkit run --config`); InputError naming `source` and the key.
RunSpec run_spec_from_run_json(const nlohmann::json& run_json, const std::string& source);

enum class RunOutputs {
  kFolder,   // every file of a run folder: trajectories, map, pictures, ...
  kMetrics,  // run.json and metrics.json only: a campaign of thousands of runs
};

struct ExecuteOptions {
  /// Entries run.json's provenance gets besides the spec's (the command line, the working folder,
  /// a campaign's job).
  nlohmann::json provenance = nlohmann::json::object();
  std::vector<RunObserver*> observers;
  /// Read between events (RunOptions::stop); a run stopped by it is written as partial.
  const std::atomic<bool>* stop = nullptr;
  /// Catch SIGINT, SIGTERM and SIGHUP while the filter runs (pipeline/stop_signals.hpp), for a
  /// process that runs one run; `stop` is then ignored.
  bool catch_stop_signals = false;
  /// Record the run for the replay page (replay.json and replay.html); needs History::kFull.
  bool replay = false;
  RunOutputs outputs = RunOutputs::kFolder;
  /// The memory the run may use, in bytes (0: the machine's); a run estimated to need more is refused
  /// before its filter is built (pipeline/run_memory.hpp).
  double memory_budget_bytes = 0.0;
  /// Told of each stage as it ends ("dataset read", "filter run", "written and evaluated").
  std::function<void(std::string_view)> on_stage;
};

struct RunRecord {
  RunResult run;
  Metrics metrics;
  int stop_signal = 0;  // the signal that stopped the run, with catch_stop_signals
};

/// Carries out `spec` into the run folder `out_dir`, which is replaced as a whole when every file is
/// written (io/run_io.hpp's stage_run_folder: a second writer is refused before the data is read).
/// Throws InputError for data that cannot be read or a dataset the filter cannot use, MemoryError
/// (core/memory_budget.hpp) for a run the machine cannot hold. A diverged or stopped run is written
/// and returned (run.diverged_at_s, run.partial).
RunRecord execute(const RunSpec& spec, const std::string& out_dir, const ExecuteOptions& options = {});

}  // namespace slamkit
