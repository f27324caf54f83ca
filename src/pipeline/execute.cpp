#include "slamkit/pipeline/execute.hpp"

#include <fmt/format.h>

#include <filesystem>
#include <optional>
#include <utility>
#include <variant>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/version.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/pipeline/replay.hpp"
#include "slamkit/pipeline/run_folder.hpp"
#include "slamkit/pipeline/run_memory.hpp"
#include "slamkit/pipeline/stop_signals.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

bool has_landmark_ids(const Dataset& dataset) {
  for (const Event& e : dataset.events)
    if (const auto* scan = std::get_if<ScanEvent>(&e))
      for (const Observation& o : scan->observations)
        if (o.id != kUnknownId) return true;
  return false;
}

/// The name of a dataset kind in a spec, for messages.
std::string kind_of(const std::string& spec) { return spec.substr(0, spec.find(':')); }

}  // namespace

RunSpec make_run_spec(const std::string& dataset, const std::string& dataset_settings_path, SettingsSources sources) {
  RunSpec spec =
      make_run_spec(dataset, dataset_settings_path.empty() ? nlohmann::json() : read_json_file(dataset_settings_path),
                    dataset_settings_path, std::move(sources));
  if (!dataset_settings_path.empty())
    spec.dataset_settings_path = fs::absolute(dataset_settings_path).lexically_normal().string();
  return spec;
}

RunSpec make_run_spec(const std::string& dataset, nlohmann::json dataset_settings,
                      const std::string& dataset_settings_source, SettingsSources sources) {
  check_dataset_spec(dataset);
  RunSpec spec;
  spec.dataset = dataset;
  spec.dataset_settings_source = dataset_settings_source;
  sources.recommended_source = dataset_settings.is_null() ? fmt::format("the built-in settings of {}", kind_of(dataset))
                                                          : dataset_settings_source;
  sources.recommended = recommended_settings(dataset, dataset_settings, sources.recommended_source);
  const LayeredSettings layered = layer_settings(sources);
  spec.filter = layered.config;
  if (!layered.recommendation_applied.empty())
    spec.recommendation = {{"source", sources.recommended_source}, {"applied", layered.recommendation_applied}};
  spec.dataset_settings = std::move(dataset_settings);
  return spec;
}

RunSpec run_spec_from_run_json(const nlohmann::json& run_json, const std::string& source) {
  RunSettings previous = run_settings_from_json(run_json, source);
  RunSpec spec;
  spec.dataset = std::move(previous.dataset);
  spec.dataset_settings = std::move(previous.dataset_settings_contents);
  spec.dataset_settings_path = std::move(previous.dataset_settings);
  spec.dataset_settings_source = std::move(previous.dataset_settings_source);
  spec.filter = previous.filter;
  spec.recommendation = std::move(previous.recommended_settings);
  return spec;
}

RunRecord execute(const RunSpec& spec, const std::string& out_dir, const ExecuteOptions& options) {
  if (options.replay && spec.history != History::kFull)
    throw std::invalid_argument("the replay records every scan; it needs --history full");
  const auto stage = [&](std::string_view what) {
    if (options.on_stage) options.on_stage(what);
  };
  // Everything needed to repeat the run from any folder: absolute paths, the dataset settings'
  // contents (the file may change or move), every filter setting by name, and which of them the
  // dataset recommended.
  nlohmann::json provenance = options.provenance;
  provenance.update({{"slamkit_version", version()},
                     {"build", build_description()},
                     {"dataset_as_given", spec.dataset},
                     {"dataset_settings_contents", spec.dataset_settings},
                     {"settings", to_json(spec.filter)}});
  if (!spec.recommendation.is_null()) provenance["recommended_settings"] = spec.recommendation;
  const std::string dataset_spec = absolute_dataset_spec(spec.dataset);

  // Staged before the data is read, so that a second run into the folder fails at once; the folder
  // keeps its previous run until it is committed.
  AtomicFolder out = stage_run_folder(out_dir);
  const Dataset dataset =
      load_dataset(dataset_spec, spec.dataset_settings,
                   spec.dataset_settings_source.empty() ? spec.dataset_settings_path : spec.dataset_settings_source);
  stage("dataset read");
  add_dataset_provenance(provenance, dataset_spec, dataset);

  RunOptions run_options;
  run_options.history = spec.history;
  run_options.observers = options.observers;
  run_options.stop = options.stop;
  require_run_memory(spec.filter, dataset, run_options, options.memory_budget_bytes);
  auto filter = make_filter(spec.filter, dataset);
  check_filter_fits(*filter, dataset);
  if (!filter->maps_range_scans() && spec.filter.association.method == AssociationMethod::kKnown &&
      !has_landmark_ids(dataset))
    throw InputError(spec.dataset, 0, "the log's observations carry no landmark ids; use --assoc nn or --assoc jcbb");
  std::optional<ReplayRecorder> recorder;
  if (options.replay)
    run_options.observers.push_back(&recorder.emplace(dataset, ReplayOptions{}, filter->maps_range_scans()));

  RunRecord record;
  if (options.catch_stop_signals) {  // only while the filter runs: before or after, a signal ends the process
    const StopSignals stop_signals;
    run_options.stop = stop_signals.flag();
    record.run = run_filter(*filter, dataset, run_options);
    record.stop_signal = stop_signals.received();
  } else {
    record.run = run_filter(*filter, dataset, run_options);
  }
  stage("filter run");

  RunResult& run = record.run;
  run.association = to_string(spec.filter.association.method);
  run.dataset = dataset_spec;
  run.dataset_settings = spec.dataset_settings_path;
  run.provenance = std::move(provenance);
  if (options.outputs == RunOutputs::kFolder) {
    record.metrics = write_run_folder_files(out.path(), run, dataset, recorder ? &*recorder : nullptr);
  } else {
    write_run_json(out.path(), run);
    record.metrics = evaluate_run(run, dataset);
    write_metrics(out.path(), record.metrics);
  }
  out.commit();
  stage("written and evaluated");
  return record;
}

}  // namespace slamkit
