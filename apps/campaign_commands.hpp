#pragma once
// `slamkit campaign` and `slamkit report`: their options, and what they do once parsed. Kept apart
// from slamkit.cpp's single-run commands; main() dispatches to them and handles what they throw as
// it does for every command (InputError: exit 1).
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace slamkit::cli {

struct CampaignCommands {
  CLI::App* campaign = nullptr;
  CLI::App* report = nullptr;
  std::string spec_path, campaign_out;
  unsigned jobs = 0;
  bool dry_run = false, no_report = false, quiet = false;
  std::vector<std::string> report_paths;
  std::string report_out;
  std::vector<std::string> report_metrics;
  std::string report_tables, report_into;
  bool no_nees = false;
};

/// Adds both subcommands to `app`; the options land in `commands`, which must outlive parsing.
void add_campaign_commands(CLI::App& app, CampaignCommands& commands);

/// Runs the campaign: 0 when every job ran, 1 when some failed (listed), 128 + the signal when
/// stopped by one.
int run_campaign_command(const CampaignCommands& commands);

/// Writes the report of the run folders given; std::invalid_argument for a --metrics key no run has.
int run_report_command(const CampaignCommands& commands);

}  // namespace slamkit::cli
