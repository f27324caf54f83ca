#include "campaign_commands.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <thread>

#include "campaign_mpi.hpp"
#include "slamkit/campaign/campaign.hpp"
#include "slamkit/campaign/report.hpp"
#include "slamkit/campaign/spec.hpp"
#include "slamkit/campaign/tables.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/memory_budget.hpp"
#include "slamkit/core/names.hpp"
#include "slamkit/pipeline/stop_signals.hpp"

namespace slamkit::cli {
namespace {

namespace fs = std::filesystem;

constexpr int kExitFailedJobs = 1;

const char* status_word(campaign::JobStatus status) {
  switch (status) {
    case campaign::JobStatus::kRun:
      return "done";
    case campaign::JobStatus::kAlreadyDone:
      return "already done";
    case campaign::JobStatus::kDiverged:
      return "diverged";
    case campaign::JobStatus::kStopped:
      return "stopped";
    case campaign::JobStatus::kFailed:
      return "FAILED";
  }
  return "";
}

/// "3 configurations x 50 jobs" style overview of what a spec expands to.
void print_plan(const campaign::CampaignSpec& spec) {
  std::vector<std::string> configurations;
  for (const campaign::Job& job : spec.jobs)
    if (configurations.empty() || configurations.back() != job.configuration)
      configurations.push_back(job.configuration);
  fmt::print("campaign {}: {} jobs\n", spec.name, spec.jobs.size());
  for (const std::string& c : configurations) fmt::print("  {}\n", c);
}

struct ReportRequest {
  bool nees = true;
  std::vector<std::string> metrics;  // empty: the defaults
  std::vector<campaign::TableSpec> tables;
  std::string into;  // a Markdown file whose tables are replaced
  /// A campaign's own report: a table that cannot be made (every run of one of its entries failed)
  /// is a warning, not a reason to lose the report.
  bool tables_optional = false;
};

std::vector<std::string> write_report_of(const std::vector<std::string>& paths, const std::string& out,
                                         const ReportRequest& request) {
  campaign::ReportOptions options;
  options.nees_test = request.nees;
  if (!request.metrics.empty()) options.metrics = request.metrics;
  const campaign::Report report = campaign::collect_report(paths, options);
  std::set<std::string> measured;
  for (const campaign::ReportRun& run : report.runs)
    for (const auto& [key, value] : run.metrics.items()) measured.insert(key);
  for (const std::string& key : request.metrics)  // a misspelt key would be a table of empty rows
    if (!measured.contains(key))
      throw std::invalid_argument(unknown_name_message("metric", key, {measured.begin(), measured.end()}));
  // Tables and the document are made before anything is written, so that a table naming an entry no
  // run has, or a document without a table's markers, fails without replacing an earlier report.
  std::vector<std::pair<std::string, std::string>> rendered;
  for (const campaign::TableSpec& table : request.tables) {
    try {
      rendered.emplace_back(table.name, campaign::render_table(report, table));
    } catch (const InputError& e) {
      if (!request.tables_optional) throw;
      fmt::print(stderr, "slamkit: warning: table '{}' left out: {}\n", table.name, e.what());
    }
  }
  const std::string document = request.into.empty() ? "" : campaign::spliced_document(request.into, rendered);
  std::vector<std::string> files = campaign::write_report(report, out);
  if (!rendered.empty()) files.push_back(campaign::write_tables(rendered, out));
  if (!request.into.empty()) {
    campaign::write_document(request.into, document);
    files.push_back(request.into);
  }
  return files;
}

}  // namespace

bool launched_by_mpi() {
  for (const char* variable : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(variable) != nullptr) return true;
  return false;
}

void add_campaign_commands(CLI::App& app, CampaignCommands& c) {
  c.campaign = app.add_subcommand(
      "campaign",
      "Run many runs from one spec file (datasets with seed ranges x filters x varied settings; campaigns/*.json "
      "and docs/campaigns.md), one job per core, then report them. Rerun it into the same folder to finish a "
      "campaign that was stopped or killed: jobs already done are skipped");
  c.campaign->add_option("spec", c.spec_path, "Campaign spec (JSON)")->required();
  c.campaign->add_option("--out", c.campaign_out, "Campaign folder: runs/, campaign.json, report/")->required();
  c.campaign->add_option("--jobs,-j", c.jobs, "Runs at once (default: one per core)")->check(CLI::Range(1u, 4096u));
  c.campaign->add_flag("--dry-run", c.dry_run, "Print the jobs the spec expands to and stop");
  c.campaign->add_flag("--no-report", c.no_report, "Do not write DIR/report at the end");
  c.campaign->add_flag("--quiet", c.quiet, "Print only errors");

  c.report = app.add_subcommand(
      "report",
      "Tables (mean, median, min-max, 95% confidence interval per configuration), the N-run NEES test and "
      "plots over any set of run folders: a campaign's, or folders written by 'slamkit run'");
  c.report->add_option("paths", c.report_paths, "Run folders, or folders searched for run folders")->required();
  c.report->add_option("--out", c.report_out, "Folder for report.md, summary.csv, runs.csv, report.json and SVGs")
      ->required();
  c.report
      ->add_option("--metrics", c.report_metrics,
                   fmt::format("metrics.json keys to summarise, comma-separated (default: {})",
                               fmt::join(campaign::default_report_metrics(), ",")))
      ->delimiter(',');
  c.report
      ->add_option("--tables", c.report_tables,
                   "A campaign spec or JSON file whose 'tables' to write to tables.md (docs/campaigns.md, \"Tables\")")
      ->check(CLI::ExistingFile);
  c.report->add_option("--into", c.report_into,
                       "A Markdown file whose marked tables (<!-- slamkit report table: NAME -->) to replace with "
                       "these")
      ->check(CLI::ExistingFile);
  c.report->add_flag("--no-nees", c.no_nees,
                     "Skip the averaged-NEES test, which re-reads each run's dataset to score it against the truth");
}

int run_campaign_command(const CampaignCommands& c) {
  const campaign::CampaignSpec spec = campaign::read_campaign_spec(c.spec_path);
  if (c.dry_run) {
    print_plan(spec);
    return 0;
  }
  const bool mpi = launched_by_mpi();
  const bool progress = !c.quiet && !mpi && isatty(STDOUT_FILENO);
  campaign::CampaignOptions options;
  options.workers = c.jobs;
  if (!mpi) {  // under MPI, a rank per core is the user's -n
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    if (options.workers == 0)
      options.workers = static_cast<unsigned>(campaign::default_workers(spec, cores, physical_memory_bytes()));
    options.workers = static_cast<unsigned>(std::min<std::size_t>(options.workers, std::max<std::size_t>(1, spec.jobs.size())));
    if (!c.quiet)
      fmt::print("campaign {}: {} jobs, {} at a time ({} cores, {} thread{} per run{})\n", spec.name, spec.jobs.size(),
                 options.workers, cores, spec.threads_per_run, spec.threads_per_run == 1 ? "" : "s",
                 spec.memory_per_run_bytes > 0.0
                     ? fmt::format(", {:.0f} MB per run of {:.0f} MB", spec.memory_per_run_bytes / 1e6,
                                   physical_memory_bytes() / 1e6)
                     : "");
  }
  options.on_job = [&](const campaign::Job& job, const campaign::JobOutcome& outcome,
                       const campaign::CampaignTally& t) {
    if (c.quiet) return;
    if (outcome.status == campaign::JobStatus::kFailed)
      fmt::print(stderr, "slamkit: job {} failed: {}\n", job.folder, outcome.error);
    else if (progress)
      fmt::print("\r[{}/{}] {} run, {} already done, {} failed ", t.finished(), t.total, t.run + t.diverged,
                 t.already_done, t.failed);
    else if (outcome.status != campaign::JobStatus::kAlreadyDone)
      fmt::print("{} {} ({:.1f} s)\n", job.folder, status_word(outcome.status), outcome.seconds);
    std::fflush(stdout);
  };
  const auto start = std::chrono::steady_clock::now();
  const StopSignals stop_signals;
  options.stop = stop_signals.flag();
  const auto finish = [&](const campaign::CampaignResult& result, int ranks) {
    const campaign::CampaignTally& t = result.tally;
    if (!c.quiet) {
      if (progress) fmt::print("\n");
      fmt::print("campaign {}: {} jobs: {} run, {} already done, {} diverged, {} stopped, {} failed ({:.1f} s{})\n",
                 spec.name, t.total, t.run, t.already_done, t.diverged, t.stopped, t.failed,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                 ranks > 1 ? fmt::format(", {} MPI ranks", ranks) : "");
    }
    if (const int signal = stop_signals.received(); signal != 0) {
      fmt::print(stderr, "slamkit: stopped by {}; run the same command again to finish the campaign\n",
                 signal_name(signal));
      return exit_code_for_signal(signal);
    }
    if (!c.no_report && t.run + t.already_done + t.diverged > 0) {
      const std::string out = (fs::path(c.campaign_out) / "report").string();
      ReportRequest request;
      request.tables = spec.tables;
      request.tables_optional = true;
      write_report_of({(fs::path(c.campaign_out) / "runs").string()}, out, request);
      if (!c.quiet) fmt::print("report: {}\n", (fs::path(out) / "report.md").string());
    }
    if (t.failed > 0) {
      fmt::print(stderr, "slamkit: {} of {} jobs failed; their errors are in {}\n", t.failed, t.total,
                 (fs::path(c.campaign_out) / "failures.json").string());
      return kExitFailedJobs;
    }
    return 0;
  };
  if (mpi)
    return run_campaign_mpi(spec, c.campaign_out, options,
                            [&](const MpiCampaign& all) { return finish(all.result, all.ranks); });
  return finish(campaign::run_campaign(spec, c.campaign_out, options), 1);
}

int run_report_command(const CampaignCommands& c) {
  if (!c.report_into.empty() && c.report_tables.empty())
    throw std::invalid_argument("--into needs --tables: the file whose tables replace those in it");
  ReportRequest request;
  request.nees = !c.no_nees;
  request.metrics = c.report_metrics;
  if (!c.report_tables.empty()) request.tables = campaign::read_report_tables(c.report_tables);
  request.into = c.report_into;
  const std::vector<std::string> files = write_report_of(c.report_paths, c.report_out, request);
  for (const std::string& file : files) fmt::print("wrote {}\n", file);
  return 0;
}

}  // namespace slamkit::cli
