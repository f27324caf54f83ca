#pragma once
// A report over any set of run folders (a campaign's, or runs made one by one): the runs grouped by
// configuration (what was run, seeds aside), each metric of metrics.json summarised per configuration
// with the 95% confidence interval of its mean, Bar-Shalom's N-run averaged NEES test, and pictures.
// It reads only what the folders hold (run.json, metrics.json, the trajectories where kept), except
// for the NEES test, which re-evaluates the runs against their datasets' truth: metrics.json keeps
// each run's NEES summary, not the step-by-step series the N-run test averages.
//   report.md          the tables, the NEES test, the failed runs, links to the pictures
//   summary.csv        configuration,metric,n,mean,median,min,max,ci_low,ci_high (for a true/false
//                      metric, n counts the runs where it is either and mean is the share of true)
//   runs.csv           one row per run: its folder, configuration, state and metrics
//   report.json        all of the above as JSON
//   ate_boxplot.svg    ATE per configuration
//   errors.svg         position error over time, trajectories.svg the trajectories over the truth
//                      (a colour per configuration, at most ReportOptions::runs_per_picture runs each)
//   nees_<slug>.svg    a configuration's averaged NEES with its 95% band
#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "slamkit/core/chi_square.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit::campaign {

/// The metrics.json keys summarised by default: accuracy, consistency, map and cost, and whether the
/// loop closed (a true/false key, counted rather than averaged).
std::vector<std::string> default_report_metrics();

struct ReportOptions {
  std::vector<std::string> metrics = default_report_metrics();
  /// The N-run NEES test costs a dataset load per distinct dataset (a simulation, or a real log read
  /// again): a report of metrics only can leave it out.
  bool nees_test = true;
  /// Runs drawn per configuration in errors.svg and trajectories.svg: more lines than this make
  /// a tangle, and each drawn run's trajectories are read into memory.
  std::size_t runs_per_picture = 10;
};

/// The quantile of Student's t distribution with `dof` degrees of freedom at probability p, to about
/// 1e-12 relative: the confidence intervals' factor, t(0.975, n - 1). Throws std::invalid_argument
/// unless 0 < p < 1 and dof > 0.
double student_t_quantile(double p, double dof);

/// One run folder as the report sees it.
struct ReportRun {
  std::string dir;
  std::string configuration;  // the label of its configuration
  std::size_t configuration_index = 0;
  std::string filter, dataset;  // run.json's
  nlohmann::json metrics;       // metrics.json as written
  /// run.json's "campaign": the job a campaign made it from (its seeds, varied values); null otherwise.
  nlohmann::json campaign_job;
  bool partial = false;
  std::optional<double> diverged_at_s;
};

/// One metric over the runs of a configuration.
struct MetricSummary {
  std::string metric;
  /// Runs where the value is a finite number: what mean..max describe (a null or absent value is a
  /// metric that was not measured, and is not counted).
  std::size_t n = 0;
  double mean = 0, median = 0, min = 0, max = 0, sum = 0;
  std::size_t zeros = 0;  // of those n, the runs where it is 0
  /// The 95% confidence interval of the mean (Student's t with n - 1 dof); none for n < 2.
  std::optional<eval::Interval> ci95;
  /// A true/false metric (loop_closed): true in `yes` of the `yes_no` runs where it is either.
  std::size_t yes = 0, yes_no = 0;
};

/// Bar-Shalom's N-run test: the pose NEES averaged over the N runs step by step, against the 95%
/// interval of chi2(3N) / N.
struct NeesTest {
  /// Why the test was not made (empty when it was): it does not apply to particle filters, to runs
  /// without a pose NEES, to folders without trajectories, or the data no longer loads.
  std::string skipped;
  std::size_t runs = 0;
  std::size_t steps = 0;  // the step times every run has
  double mean = 0;        // of the averaged NEES over those steps; 3 if consistent
  double inside_fraction = 0;
  eval::Interval band;
  std::vector<Vector2> averaged;  // (t [s], averaged NEES)
};

struct ReportConfiguration {
  std::string label;
  std::string slug;  // the label in file-name characters, unique in the report
  /// What its runs share: run.json's campaign label, or the filter settings and dataset without seeds.
  nlohmann::json key;
  /// Its two halves, what tables (campaign/tables.hpp) pivot on: a campaign's filter and dataset
  /// entries with their varied values ("fej ekf_update=iterated", "sparse"); for other runs the
  /// labels of their filter settings and their dataset.
  std::string filter_entry, dataset_entry;
  std::vector<std::size_t> runs;  // into Report::runs, in folder order
  std::size_t partial = 0, diverged = 0;
  std::vector<MetricSummary> metrics;  // in Report::metrics order
  NeesTest nees;
};

struct Report {
  std::vector<std::string> paths;    // as given to collect_report
  std::vector<std::string> metrics;  // ReportOptions::metrics
  std::size_t runs_per_picture = 0;
  std::vector<ReportRun> runs;  // sorted by folder, numbers in names by value (seed-2 before seed-10)
  std::vector<ReportConfiguration> configurations;  // in order of their first run
};

/// One metric over some of a report's runs (indices into Report::runs).
MetricSummary summarize_metric(const std::string& metric, const Report& report, const std::vector<std::size_t>& runs);

/// Every run folder under `paths` (each a run folder, or a folder searched recursively for run
/// folders = folders holding run.json and metrics.json; sorted, each once), read and grouped by
/// configuration. A run.json with "campaign": {"configuration": LABEL} is in configuration LABEL;
/// other runs are grouped by their filter settings and dataset without the seeds (a sim: log by its
/// simulator parameters, a scenario's or world family's spec without its last seed) and dataset
/// settings, and labelled by the filter and the settings that tell the groups apart (and the dataset,
/// where there are several). A path that does not exist or holds no run folder is an InputError
/// naming it; a malformed run.json or metrics.json one naming the file. A run folder being written
/// (core/atomic_folder.hpp) is not a run yet and is passed over.
Report collect_report(const std::vector<std::string>& paths, const ReportOptions& options = {});

/// Writes report.md, summary.csv, runs.csv, report.json and the SVGs into out_dir, replacing it as a
/// whole (an existing folder must be an earlier report or empty); returns the files written. Throws
/// InputError if it cannot.
std::vector<std::string> write_report(const Report& report, const std::string& out_dir);

/// Writes the report's pictures alone into `dir` (an existing folder); returns the names of the files
/// written: a picture without data (no run with an ATE, no folder with trajectories) is left out.
/// errors.svg and trajectories.svg read the trajectories of the runs they draw from their folders
/// (filtered.tum or trajectory.tum, truth.tum; a campaign that keeps metrics only has none), under
/// the alignment their evaluation found, as ATE scores them.
std::vector<std::string> write_report_pictures(const Report& report, const std::string& dir);

}  // namespace slamkit::campaign
