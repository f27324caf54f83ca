#pragma once
// A campaign: many runs described once. A spec file names datasets (simulated scenarios and world
// families with ranges of seeds, or real logs) and filters (each with its settings), each with
// settings to vary over lists of values, and expands into jobs: one run each, every combination
// once. docs/campaigns.md documents the file; campaigns/ holds examples.
//
// A job's folder and its configuration (what the report groups by: the filter and dataset with the
// values varied, without the seeds) are functions of the spec alone, so a campaign rerun into its
// folder finds the jobs already done and a report puts the seeds of one configuration together.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "slamkit/campaign/tables.hpp"
#include "slamkit/pipeline/execute.hpp"

namespace slamkit::campaign {

struct Job {
  /// The run folder, relative to the campaign folder: runs/<configuration>/<seeds>, in file-name
  /// characters.
  std::string folder;
  /// "fej | family:sparse clutter_rate_per_scan=1": the filter and dataset entries' names with the values
  /// they vary.
  std::string configuration;
  /// Its two halves: the filter entry's and the dataset entry's name with their varied values (the
  /// rows and columns of its tables).
  std::string filter_entry, dataset_entry;
  /// What the job is, as run.json's provenance records it under "campaign" (the campaign's name,
  /// configuration, dataset, seeds and varied values).
  nlohmann::json description;
  RunSpec spec;
};

struct CampaignSpec {
  std::string name;
  RunOutputs outputs = RunOutputs::kFolder;
  /// Each run's threads (the filters' `threads` setting, where a filter's settings do not give it):
  /// a campaign runs one job per core.
  unsigned threads_per_run = 1;
  /// The memory one run may use, in bytes (0: no budget): the campaign runs no more jobs at once than
  /// fit the machine's memory, and a job estimated to need more fails before it starts.
  double memory_per_run_bytes = 0.0;
  std::vector<Job> jobs;
  /// Tables its report writes to tables.md (campaign/tables.hpp).
  std::vector<TableSpec> tables;
  /// The file's contents, kept in the campaign folder to tell a rerun of the same campaign from a
  /// different one.
  nlohmann::json source;
};

/// Expands a spec file. Every job's settings are layered and checked here, before anything runs.
/// Throws InputError naming the file and the key (e.g. "filters[1].vary.particles: expected a list
/// of values") for a spec that is malformed, settings that do not go together, or two jobs that
/// would share a folder.
CampaignSpec read_campaign_spec(const std::string& path);
/// The same for a spec already read; `source` names it, and relative file names in it are relative
/// to `base_folder`.
CampaignSpec parse_campaign_spec(const nlohmann::json& spec, const std::string& source, const std::string& base_folder);

}  // namespace slamkit::campaign
