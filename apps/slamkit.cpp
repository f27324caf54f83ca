// slamkit command-line tool: a thin layer over the library. Each subcommand parses its options,
// calls the public API, and reports. Bad input of any kind ends in one line on stderr naming the
// file, the line and what was expected, and a non-zero exit code.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <iostream>
#include <optional>
#include <stdexcept>

#include "slamkit/calib/calibration.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/version.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/mrclam.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/io/trajectory_io.hpp"
#include "slamkit/pipeline/replay.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/plot/benchmark_plots.hpp"
#include "slamkit/plot/replay_html.hpp"
#include "slamkit/plot/report.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace fs = std::filesystem;
using namespace slamkit;

namespace {

constexpr int kExitBadInput = 1;
constexpr int kExitUsage = 2;
constexpr int kExitDiverged = 3;       // the filter's estimate stopped being finite
constexpr int kExitInterrupted = 130;  // the shell's code for a program ended by SIGINT

// CLI11's own range checks print the limits of a double in full (310 digits); these say the range in
// words. An integer option is checked here as text, so that "1.5" gets the same message as "0".
CLI::Validator integer_at_least(unsigned long long min) {
  const std::string expected = fmt::format("an integer >= {}", min);
  return CLI::Validator(
      [=](std::string& text) {
        unsigned long long v = 0;
        const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), v);
        if (error != std::errc() || end != text.data() + text.size() || v < min)
          return fmt::format("expected {}, found {}", expected, text);
        return std::string();
      },
      "");
}

CLI::Validator number_where(const std::string& expected, bool (*ok)(double)) {
  return CLI::Validator(
      [=](std::string& text) {
        double v = 0.0;
        if (!CLI::detail::lexical_cast(text, v) || !ok(v)) return fmt::format("expected {}, found {}", expected, text);
        return std::string();
      },
      "");
}

/// A setting given by name and parsed by the library (a filter, an association method, a resampling
/// scheme or policy): a name the parser rejects is a usage error carrying the parser's message,
/// which lists the accepted names. The help shows the default under its name.
template <typename T>
CLI::Option* add_named(CLI::App* cmd, const std::string& flag, T& target, T (*parse)(const std::string&),
                       const std::string& help) {
  return cmd
      ->add_option_function<std::string>(
          flag, [&target, parse](const std::string& text) { target = parse(text); }, help)
      ->check(CLI::Validator(
          [parse](std::string& text) {
            try {
              parse(text);
            } catch (const std::invalid_argument& e) {
              return std::string(e.what());
            }
            return std::string();
          },
          ""))
      ->default_str(to_string(target));
}

enum class Verbosity { kQuiet, kNormal, kVerbose };

void print_outputs(const std::string& dir, const Metrics& metrics, Verbosity verbosity) {
  if (verbosity == Verbosity::kQuiet) return;
  fmt::print("{}\n", headline(metrics));
  std::string files = "metrics.json, map.svg, landmark_std.svg";
  // These need a truth of the right kind (with headings; any truth for truth.tum).
  for (const char* optional : {"nees.svg", "pose_error.svg", "truth.tum"})
    if (fs::exists(fs::path(dir) / optional)) files += fmt::format(", {}", optional);
  fmt::print("results in {}/: {}, trajectory.tum, map.txt\n", dir, files);
}

/// A progress line on stderr, rewritten in place, for runs that last longer than a second: how far,
/// how fast, and when it will end. Only on a terminal, so logs and pipes stay clean.
class ProgressLine : public RunObserver {
 public:
  void on_scan(const SlamFilter& filter, const ScanEvent& scan, std::size_t done, std::size_t total) override {
    const auto now = std::chrono::steady_clock::now();
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    if (elapsed < 1.0 || now - last_ < std::chrono::milliseconds(250)) return;
    last_ = now;
    const double rate = static_cast<double>(done) / elapsed;
    const double eta = static_cast<double>(total - done) / rate;
    fmt::print(stderr, "\r\033[K{:5.1f}%  t = {:.0f} s  {} landmarks  {:.0f} events/s  ETA {:.0f} s",
               100.0 * static_cast<double>(done) / static_cast<double>(total), scan.t, filter.num_landmarks(), rate,
               eta);
    shown_ = true;
  }
  /// Clears the line, so what follows starts on a clean one.
  void finish() {
    if (shown_) fmt::print(stderr, "\r\033[K");
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point last_ = start_;
  bool shown_ = false;
};

// Set by the first Ctrl-C: the run stops after the current event and writes what it has, marked
// partial. The handler then steps aside, so a second Ctrl-C ends the program at once.
std::atomic<bool> g_interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free);
extern "C" void on_interrupt(int) {
  g_interrupted.store(true);
  std::signal(SIGINT, SIG_DFL);
}

/// The ground truth in TUM format beside the estimate (same times), so tools such as evo compare
/// them as they are. A truth of positions only (GPS) gets heading 0.
void write_truth(const std::string& dir, const Dataset& dataset) {
  const std::string path = (fs::path(dir) / "truth.tum").string();
  if (dataset.truth.poses.empty())
    fs::remove(path);
  else
    write_tum(path, dataset.truth.poses);
}

/// The dataset settings' contents, or null for the reader's defaults.
nlohmann::json dataset_settings_json(const std::string& path) {
  return path.empty() ? nlohmann::json() : read_json_file(path);
}

bool has_landmark_ids(const Dataset& dataset) {
  for (const Event& e : dataset.events)
    if (const auto* scan = std::get_if<ScanEvent>(&e))
      for (const Observation& o : scan->observations)
        if (o.id != kUnknownId) return true;
  return false;
}

/// A warning when the known-identity gate rejected most observations over part of the run
/// (assoc/gate_tally.hpp): a filter that lost itself, whose figures from then on are odometry's.
void warn_if_lost(const Metrics& metrics) {
  const auto& stats = metrics.filter_statistics;
  const auto lost_at = stats.find("known_id_lost_at_s");
  if (lost_at == stats.end()) return;
  std::cerr << fmt::format(
      "slamkit: warning: the filter lost itself: the known-identity gate rejected most observations in {:.0f} tenth(s) "
      "of the run, the first from t = {:.1f} s ({:.0f}% of all {:.0f} judged); its estimate strayed further than its "
      "covariance allows and it ran on odometry (known_id_* in metrics.json)\n",
      stats.at("known_id_lost_tenths"), lost_at->second, 100.0 * stats.at("known_id_rejected_fraction"),
      stats.at("known_id_judged"));
}

/// Evaluates a run against its dataset's truth, writes metrics.json and the pictures.
Metrics evaluate_and_report(const std::string& dir, const RunResult& run, const Dataset& dataset) {
  const Metrics metrics = evaluate_run(run, dataset.truth);
  write_metrics(dir, metrics);
  write_run_plots(dir, run, dataset.truth, metrics);
  warn_if_lost(metrics);
  return metrics;
}

/// The calibration as a few lines and its evidence as two tables.
std::string calibration_summary(const Calibration& c, double total_delay) {
  std::string out = fmt::format(
      "command delay {:.2f} s ({:+.2f} s on the logs' settings)\n"
      "motion: q_v {:.3g} m^2/s, q_omega {:.3g} rad^2/s over {} stretches between scans\n"
      "measurement: sigma_range {:.3f} m, sigma_bearing {:.2f} deg over {} passes of {} observations "
      "(per observation {:.3f} m, {:.2f} deg; {} gross outliers left out)\n",
      total_delay, c.command_delay_s, c.motion.q_v, c.motion.q_omega, c.motion_windows, c.measurement.sigma_range,
      rad2deg(c.measurement.sigma_bearing), c.passes, c.observations, c.rms_range_m, rad2deg(c.rms_bearing_rad),
      c.gross_outliers);
  out += "horizon [s]  windows  q_v [m^2/s]  q_omega [rad^2/s]  speed bias [m/s]  turn bias [rad/s]\n";
  for (const MotionErrorAtHorizon& r : c.motion_by_horizon)
    out += fmt::format("{:11.2f}  {:7}  {:11.3g}  {:17.3g}  {:16.4f}  {:17.5f}\n", r.horizon_s, r.windows, r.q_v,
                       r.q_omega, r.speed_bias_mps, r.turn_rate_bias_radps);
  out += "range [m]  observations  rms range [m]  rms bearing [deg]  mean range [m]  mean bearing [deg]\n";
  for (const MeasurementErrorAtRange& r : c.measurement_by_range)
    out += fmt::format("{:4.0f}-{:<4.0f}  {:12}  {:13.3f}  {:17.2f}  {:14.3f}  {:18.2f}\n", r.range_from_m, r.range_to_m,
                       r.observations, r.rms_range_m, rad2deg(r.rms_bearing_rad), r.mean_range_m,
                       rad2deg(r.mean_bearing_rad));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"slamkit: landmark-based SLAM (EKF-SLAM) with a simulator, evaluation and plots"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Show help for every command");
  app.set_version_flag("--version", version(), "Print the version and exit");

  // ---- simulate ----
  auto* simulate_cmd = app.add_subcommand("simulate", "Simulate a vehicle driving through a landmark world");
  std::string world_path, config_path, sim_out, scenario_name = "default";
  std::uint64_t sim_seed = 1;
  int loops = 0;
  double clutter = -1.0, detection = -1.0;
  bool no_ids = false;
  std::string scenario_help = "Built-in world and settings:";
  for (const auto& n : scenario_names()) scenario_help += " " + n;
  simulate_cmd->add_option("--scenario", scenario_name, scenario_help)->capture_default_str();
  simulate_cmd->add_option("--world", world_path, "World file (landmarks and waypoints); replaces the scenario's world")
      ->check(CLI::ExistingFile);
  simulate_cmd->add_option("--config", config_path, "Simulator settings (JSON); default: the reference simulator's")
      ->check(CLI::ExistingFile);
  simulate_cmd->add_option("--seed", sim_seed, "Random seed; the same seed gives the same log")
      ->capture_default_str()
      ->check(integer_at_least(0));
  simulate_cmd->add_option("--loops", loops, "Laps of the route (overrides the config)")->check(integer_at_least(1));
  simulate_cmd->add_option("--clutter", clutter, "False detections per scan (Poisson mean)")
      ->check(number_where(">= 0", [](double v) { return v >= 0.0 && std::isfinite(v); }));
  simulate_cmd->add_option("--detection-prob", detection, "Probability of detecting a landmark in view")
      ->check(number_where("in [0, 1]", [](double v) { return v >= 0.0 && v <= 1.0; }));
  simulate_cmd->add_flag("--no-ids", no_ids, "Withhold landmark identities from the log (kept in the truth)");
  simulate_cmd->add_option("--out", sim_out, "Output folder for the log and ground truth")->required();

  // ---- make-world ----
  auto* world_cmd = app.add_subcommand("make-world", "Generate a world file (a loop route with landmarks)");
  WorldGenOptions gen;
  std::string world_out;
  world_cmd->add_option("--landmarks", gen.landmarks, "Number of landmarks")
      ->capture_default_str()
      ->check(integer_at_least(1));
  const CLI::Validator positive = number_where("> 0", [](double v) { return v > 0.0 && std::isfinite(v); });
  world_cmd->add_option("--width", gen.width, "Route width [m]")->capture_default_str()->check(positive);
  world_cmd->add_option("--height", gen.height, "Route height [m]")->capture_default_str()->check(positive);
  world_cmd->add_option("--band", gen.band_outer, "Landmarks lie up to this far from the route [m]")->capture_default_str();
  world_cmd->add_option("--seed", gen.seed, "Random seed")->capture_default_str()->check(integer_at_least(0));
  world_cmd->add_option("--out", world_out, "World file to write")->required();

  // ---- run ----
  // Every filter setting is parsed and checked here, before any data is read: a misspelt name or a
  // value out of range is a usage error.
  auto* run_cmd = app.add_subcommand("run", "Run a SLAM filter on a dataset and evaluate it");
  FilterConfig filter;
  std::string data_spec, run_out, data_config;
  add_named(run_cmd, "--filter", filter.filter, parse_filter_kind, "Filter: ekf, ukf, fastslam1, fastslam2");
  add_named(run_cmd, "--assoc", filter.association.method, parse_association_method,
            "Data association: known (ids from the log), nn, jcbb");
  auto* data_opt = run_cmd->add_option(
      "--data", data_spec, "Dataset, as KIND:PATH: sim:DIR, victoria-park:DIR, mrclam:DIR:robotN, course:DIR");
  auto* data_config_opt =
      run_cmd
          ->add_option("--data-config", data_config,
                       "Dataset settings (JSON: noise, sensor limits); the defaults are config/*.json")
          ->check(CLI::ExistingFile);
  run_cmd->add_option("--seed", filter.seed, "Random seed for stochastic filters")
      ->capture_default_str()
      ->check(integer_at_least(0));
  run_cmd->add_option("--particles", filter.particles, "FastSLAM: number of particles")
      ->capture_default_str()
      ->check(integer_at_least(1));
  run_cmd
      ->add_option("--pose-sample-fraction", filter.pose_sample_fraction,
                   "FastSLAM 2.0: share of the proposal's covariance a particle draws its pose from, in (0, 1]; "
                   "it carries the rest as a Gaussian (1: the textbook filter)")
      ->capture_default_str();
  add_named(run_cmd, "--resample", filter.resample, parse_resample_method,
            "FastSLAM: multinomial, stratified, systematic or residual");
  add_named(run_cmd, "--resample-when", filter.resample_when, parse_resample_policy,
            "FastSLAM: always, every:K (scans) or ess:F (effective sample size below F*N)");
  run_cmd->add_option("--threads", filter.threads, "FastSLAM and EKF: worker threads (0: all cores); the result does not depend on it")
      ->capture_default_str()
      ->check(integer_at_least(0));
  add_named(run_cmd, "--ekf-update", filter.ekf_update, parse_ekf_update,
            "EKF and UKF: joint (a scan at once) or sequential (one observation after another). "
            "EKF full, fej or invariant: iterated (joint, relinearised at the "
            "result until it converges; keeps a loop closure after a long drift consistent)");
  add_named(run_cmd, "--ekf-variant", filter.ekf_variant, parse_ekf_variant,
            "EKF: full, compressed (local-area updates, the same result as full), "
            "fej (first-estimates Jacobians) or invariant (right-invariant error); fej and invariant keep "
            "the EKF consistent");
  add_named(run_cmd, "--ukf-noise", filter.ukf_noise, parse_ukf_noise,
            "UKF: augmented (sigma points over the vehicle and the control noise, which then moves the mean "
            "too) or additive (over the vehicle; the control noise's spread added as zero-mean process noise, "
            "for noise that is an allowance for model error)");
  // Association and map management: a file holding the keys run.json records under
  // settings.association, and a flag for each setting, which overrides the file.
  std::string assoc_config_path, gate_known;
  AssociationConfig assoc_flags;
  run_cmd->add_option("--assoc-config", assoc_config_path,
                      "Association and map-management settings (JSON, the keys of run.json's settings.association); "
                      "the flags below override it")
      ->check(CLI::ExistingFile);
  run_cmd->add_option("--accept-probability", assoc_flags.accept_probability,
                      "Pair an observation with a landmark only inside this chi-square quantile of its innovation")
      ->capture_default_str();
  run_cmd->add_option("--new-landmark-probability", assoc_flags.new_landmark_probability,
                      "Start a landmark only outside this quantile for every candidate (between: discarded)")
      ->capture_default_str();
  run_cmd->add_option("--min-pairing-probability", assoc_flags.min_pairing_probability,
                      "Pair an observation only if that landmark explains it with at least this probability against "
                      "the other candidates and clutter (0: off)")
      ->capture_default_str();
  run_cmd->add_option("--clutter-per-scan", assoc_flags.clutter_per_scan,
                      "Expected false detections per scan, for --min-pairing-probability")
      ->capture_default_str();
  run_cmd->add_option("--gate-known", gate_known,
                      "Known ids: reject an observation beyond the new-landmark gate (default: EKF and UKF on, FastSLAM off)")
      ->check(CLI::IsMember({"on", "off"}));
  run_cmd->add_option("--confirm-after", assoc_flags.confirm_after, "Observations that confirm a new landmark")
      ->capture_default_str()
      ->check(integer_at_least(1));
  run_cmd->add_option("--provisional-max-misses", assoc_flags.provisional_max_misses,
                      "Scans in a row a provisional landmark may be missed in view")
      ->capture_default_str()
      ->check(integer_at_least(1));
  run_cmd->add_option("--confirmed-max-misses", assoc_flags.confirmed_max_misses,
                      "Scans in a row a confirmed landmark may be missed in view (0: never removed)")
      ->capture_default_str()
      ->check(integer_at_least(0));
  run_cmd->add_option("--view-margin-m", assoc_flags.view_margin_m, "Range margin of \"in view\" for misses [m]")
      ->capture_default_str();
  run_cmd->add_option("--view-margin-rad", assoc_flags.view_margin_rad, "Bearing margin of \"in view\" for misses [rad]")
      ->capture_default_str();
  run_cmd->add_option("--jcbb-max-nodes", assoc_flags.jcbb_max_nodes, "JCBB: search nodes per scan")
      ->capture_default_str()
      ->check(integer_at_least(1));
  run_cmd->add_option("--relocalise-min-pairs", assoc_flags.relocalise_min_pairs,
                      "Without identities: recognise landmarks unseen for the window only when this many landmarks "
                      "started since pair jointly with them, and fuse the duplicates (0: off)")
      ->capture_default_str();
  run_cmd->add_option("--relocalise-window-s", assoc_flags.relocalise_window_s,
                      "Relocalisation: how long a landmark must be unseen to count as old, and how far back one "
                      "counts as recently mapped [s]")
      ->capture_default_str();
  const char* assoc_flag_names[] = {"--assoc-config",         "--accept-probability", "--new-landmark-probability",
                                    "--min-pairing-probability", "--clutter-per-scan",
                                    "--gate-known",           "--confirm-after",      "--provisional-max-misses",
                                    "--confirmed-max-misses", "--view-margin-m",      "--view-margin-rad",
                                    "--jcbb-max-nodes",         "--relocalise-min-pairs", "--relocalise-window-s"};
  run_cmd->add_option("--out", run_out, "Output folder for estimates, metrics and plots");
  std::string repeat_path;
  bool print_config = false, replay = false, quiet = false, verbose = false;
  // Every filter and data option, which a repeated run takes from its run.json instead.
  std::vector<CLI::Option*> setting_opts = {data_opt, data_config_opt};
  for (const char* name : {"--filter", "--assoc", "--seed", "--particles", "--pose-sample-fraction", "--resample",
                           "--resample-when", "--threads", "--ekf-update", "--ekf-variant", "--ukf-noise"})
    setting_opts.push_back(run_cmd->get_option(name));
  for (const char* name : assoc_flag_names) setting_opts.push_back(run_cmd->get_option(name));
  auto* repeat_opt =
      run_cmd
          ->add_option("--config", repeat_path,
                       "Repeat a run: the run.json of its folder gives the dataset, the dataset settings and every "
                       "filter setting (no other filter or data option may be given)")
          ->check(CLI::ExistingFile);
  for (CLI::Option* opt : setting_opts) repeat_opt->excludes(opt);
  run_cmd->add_flag("--print-config", print_config,
                    "Print the effective settings (as run.json records them) and exit without running");
  run_cmd->add_flag("--replay", replay,
                    "Also record the run scan by scan and write replay.html, a page that plays it back");
  History history = History::kFull;
  add_named(run_cmd, "--history", history, parse_history,
            fmt::format("What the run folder keeps: full (every step and scan), decimated (at most {} samples per "
                        "series, evenly spread; no associations) or none (the start and the final estimate; memory "
                        "stays flat)",
                        RunOptions{}.decimated_samples));
  auto* quiet_opt = run_cmd->add_flag("--quiet", quiet, "No progress line and no summary; errors and warnings only");
  run_cmd->add_flag("--verbose", verbose, "Also print the effective settings and the time of each stage")
      ->excludes(quiet_opt);

  // ---- replay ----
  auto* replay_cmd = app.add_subcommand("replay", "Write replay.html for a run folder recorded with 'run --replay'");
  std::string replay_dir;
  replay_cmd->add_option("dir", replay_dir, "Run folder holding replay.json")->required()->check(CLI::ExistingDirectory);

  // ---- evaluate ----
  auto* eval_cmd = app.add_subcommand("evaluate", "Recompute metrics.json and the plots of a run folder");
  std::string eval_dir;
  eval_cmd->add_option("dir", eval_dir, "Run folder written by 'slamkit run'")->required()->check(CLI::ExistingDirectory);

  // ---- calibrate ----
  auto* calibrate_cmd = app.add_subcommand(
      "calibrate", "Measure a robot's command delay, motion noise and measurement noise against ground truth and write "
                   "the dataset settings (MRCLAM logs: commanded velocities, range-bearing to identified landmarks)");
  std::vector<std::string> calibrate_specs;
  std::string calibrate_config, calibrate_out, calibrate_report;
  calibrate_cmd->add_option("--data", calibrate_specs, "Logs to calibrate on, each mrclam:DIR:robotN (repeat for several)")
      ->required();
  calibrate_cmd
      ->add_option("--data-config", calibrate_config,
                   "Settings the logs are read with (default: config/mrclam.json's); the written file keeps its other keys")
      ->check(CLI::ExistingFile);
  calibrate_cmd->add_option("--out", calibrate_out, "Dataset settings file to write (JSON, for run --data-config)")
      ->required();
  calibrate_cmd->add_option("--report", calibrate_report,
                            "Also write the evidence (errors by horizon and by range, outliers) as JSON");

  // ---- plot-bench ----
  auto* nees_cmd = app.add_subcommand(
      "plot-nees", "Draw the pose NEES of Monte Carlo runs (one filter, logs differing only in their seed) averaged "
                   "over the runs, with the 95% interval of the mean");
  std::vector<std::string> nees_dirs;
  std::string nees_out, nees_title = "Pose NEES over Monte Carlo runs";
  nees_cmd->add_option("dirs", nees_dirs, "Run folders written by 'slamkit run'")
      ->required()
      ->check(CLI::ExistingDirectory);
  nees_cmd->add_option("--out", nees_out, "SVG file to write")->required();
  nees_cmd->add_option("--title", nees_title, "Figure title")->capture_default_str();

  auto* bench_cmd =
      app.add_subcommand("plot-bench", "Plot benchmark results (Google Benchmark JSON) against map size and particles");
  std::vector<std::string> bench_json;
  std::string bench_out;
  bench_cmd->add_option("json", bench_json, "Files written by slamkit_bench --benchmark_out (later ones override)")
      ->required()
      ->check(CLI::ExistingFile);
  bench_cmd->add_option("--out", bench_out, "Folder for the SVG plots")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    const auto parsed = app.get_subcommands();
    const std::string help = parsed.empty() ? "slamkit --help" : "slamkit " + parsed.front()->get_name() + " --help";
    // CLI11 reports a misspelt subcommand as a missing one, or as an unexpected argument.
    if (parsed.empty() && argc > 1 && argv[1][0] != '-') {
      std::string names;
      for (const CLI::App* sub : app.get_subcommands({})) names += (names.empty() ? "" : ", ") + sub->get_name();
      std::cerr << "slamkit: error: unknown subcommand '" << argv[1] << "'; expected one of: " << names << " (see '"
                << help << "')\n";
    } else {
      std::cerr << "slamkit: error: " << e.what() << " (see '" << help << "')\n";
    }
    return kExitUsage;
  }
  // The filter settings as a whole, by the library's own check (which make_filter repeats), before
  // any data is read. A repeated run takes them from its run.json, checked the same way.
  const Verbosity verbosity = quiet ? Verbosity::kQuiet : verbose ? Verbosity::kVerbose : Verbosity::kNormal;
  nlohmann::json settings_contents;
  if (*run_cmd) {
    const auto usage_error = [](const std::string& message) {
      std::cerr << "slamkit: error: " << message << " (see 'slamkit run --help')\n";
      return kExitUsage;
    };
    try {
      if (!repeat_path.empty()) {
        const nlohmann::json previous = read_json_file(repeat_path);
        if (!previous.contains("settings") || !previous.contains("dataset"))
          throw InputError(repeat_path, 0, "expected the run.json of a run folder (with 'settings' and 'dataset')");
        filter = filter_config_from_json(previous.at("settings"), repeat_path);
        data_spec = previous.at("dataset").get<std::string>();
        data_config = previous.value("dataset_settings", "");
        settings_contents = previous.value("dataset_settings_contents", nlohmann::json());
      } else {
        if (data_spec.empty()) return usage_error("--data is required (or --config with an earlier run.json)");
        if (!assoc_config_path.empty()) {
          const AssociationMethod method = filter.association.method;
          filter.association = association_config_from_json(read_json_file(assoc_config_path), assoc_config_path);
          if (run_cmd->count("--assoc") > 0) filter.association.method = method;
        }
        AssociationConfig& a = filter.association;
        const auto given = [&](const char* name) { return run_cmd->count(name) > 0; };
        if (given("--accept-probability")) a.accept_probability = assoc_flags.accept_probability;
        if (given("--new-landmark-probability")) a.new_landmark_probability = assoc_flags.new_landmark_probability;
        if (given("--gate-known")) a.gate_known = gate_known == "on";
        if (given("--min-pairing-probability")) a.min_pairing_probability = assoc_flags.min_pairing_probability;
        if (given("--clutter-per-scan")) a.clutter_per_scan = assoc_flags.clutter_per_scan;
        if (given("--confirm-after")) a.confirm_after = assoc_flags.confirm_after;
        if (given("--provisional-max-misses")) a.provisional_max_misses = assoc_flags.provisional_max_misses;
        if (given("--confirmed-max-misses")) a.confirmed_max_misses = assoc_flags.confirmed_max_misses;
        if (given("--view-margin-m")) a.view_margin_m = assoc_flags.view_margin_m;
        if (given("--view-margin-rad")) a.view_margin_rad = assoc_flags.view_margin_rad;
        if (given("--jcbb-max-nodes")) a.jcbb_max_nodes = assoc_flags.jcbb_max_nodes;
        if (given("--relocalise-min-pairs")) a.relocalise_min_pairs = assoc_flags.relocalise_min_pairs;
        if (given("--relocalise-window-s")) a.relocalise_window_s = assoc_flags.relocalise_window_s;
        validate(filter);
        settings_contents = dataset_settings_json(data_config);
      }
    } catch (const std::invalid_argument& e) {
      return usage_error(e.what());
    } catch (const InputError& e) {  // a settings file or run.json that cannot be read or is wrong
      std::cerr << "slamkit: error: " << e.what() << "\n";
      return kExitBadInput;
    }
    if (run_out.empty() && !print_config) return usage_error("--out is required");
    if (replay && history != History::kFull)
      return usage_error("--replay records every scan; it needs --history full");
  }

  try {
    if (*simulate_cmd) {
      const Scenario base = scenario(scenario_name);
      const World world = world_path.empty() ? base.world : read_world(world_path);
      SimulatorConfig config =
          config_path.empty() ? base.config : simulator_config_from_json(read_json_file(config_path), config_path);
      if (simulate_cmd->count("--seed") || config_path.empty()) config.seed = sim_seed;
      if (loops > 0) config.loops = loops;
      if (clutter >= 0.0) config.clutter_rate = clutter;
      if (detection >= 0.0) config.detection_probability = detection;
      if (no_ids) config.provide_ids = false;
      const Dataset log = simulate(world, config);
      write_sim_log(sim_out, log, config, world);
      std::size_t scans = 0;
      for (const Event& e : log.events) scans += std::holds_alternative<ScanEvent>(e);
      fmt::print("simulated {} landmarks, {} controls, {} scans ({:.0f} s) -> {}\n", world.landmarks.size(),
                 log.events.size() - scans, scans, log.truth.poses.empty() ? 0.0 : log.truth.poses.back().t,
                 sim_out);
    } else if (*bench_cmd) {
      for (const std::string& file : plot::write_benchmark_plots(bench_json, bench_out)) fmt::print("wrote {}\n", file);
    } else if (*world_cmd) {
      write_world(world_out, generate_world(gen));
      fmt::print("wrote {} ({} landmarks)\n", world_out, gen.landmarks);
    } else if (*run_cmd) {
      const auto warn = [&](const std::string& message) { std::cerr << "slamkit: warning: " << message << "\n"; };
      const bool particle_filter = filter.filter == FilterKind::kFastSlam1 || filter.filter == FilterKind::kFastSlam2;
      for (const char* name : {"--particles", "--resample", "--resample-when"})
        if (!particle_filter && run_cmd->count(name) > 0) warn(fmt::format("{} is ignored by the EKF and the UKF", name));
      if (filter.filter != FilterKind::kFastSlam2 && run_cmd->count("--pose-sample-fraction") > 0)
        warn(fmt::format("--pose-sample-fraction applies to fastslam2 only; {} ignores it", to_string(filter.filter)));
      if (filter.filter == FilterKind::kUkf && run_cmd->count("--threads") > 0) warn("--threads is ignored by the UKF");
      if (filter.filter != FilterKind::kUkf && run_cmd->count("--ukf-noise") > 0)
        warn(fmt::format("--ukf-noise applies to ukf only; {} ignores it", to_string(filter.filter)));
      for (const char* name : {"--ekf-update", "--ekf-variant"})
        if (particle_filter && run_cmd->count(name) > 0) warn(fmt::format("{} is ignored by FastSLAM", name));
      if (!particle_filter && run_cmd->count("--seed") > 0)
        warn("--seed is ignored by the EKF and the UKF, which draw no random numbers");

      // Everything needed to repeat the run from any folder: absolute paths, the dataset settings'
      // contents (the file may change or move), every filter setting by name.
      nlohmann::json provenance = {
          {"slamkit_version", version()},
          {"command_line", std::vector<std::string>(argv, argv + argc)},
          {"working_directory", fs::current_path().string()},
          {"dataset_as_given", data_spec},
          {"dataset_settings_contents", settings_contents},
          {"settings", to_json(filter)},
      };
      const std::string dataset_spec = absolute_dataset_spec(data_spec);
      const std::string settings_path = data_config.empty() ? "" : fs::absolute(data_config).lexically_normal().string();
      if (print_config) {
        provenance["dataset"] = dataset_spec;
        provenance["dataset_settings"] = settings_path;
        fmt::print("{}\n", provenance.dump(2));
        return 0;
      }
      const auto stage_start = std::chrono::steady_clock::now();
      const auto stage = [&](const char* what) {
        if (verbosity == Verbosity::kVerbose)
          fmt::print(stderr, "{}: {:.2f} s\n", what,
                     std::chrono::duration<double>(std::chrono::steady_clock::now() - stage_start).count());
      };
      if (verbosity == Verbosity::kVerbose) fmt::print(stderr, "settings: {}\n", provenance.at("settings").dump());

      const Dataset dataset = load_dataset(dataset_spec, settings_contents, settings_path);
      stage("dataset read");
      if (filter.association.method == AssociationMethod::kKnown && !has_landmark_ids(dataset))
        throw InputError(data_spec, 0, "the log's observations carry no landmark ids; use --assoc nn or --assoc jcbb");
      if (dataset_spec.starts_with("sim:"))
        provenance["simulator"] = read_json_file((fs::path(dataset_spec.substr(4)) / "params.json").string());
      // The source's time of t = 0, as exact decimal text (a double would lose the sub-microsecond
      // digits of a Unix time): trajectory.tum and truth.tum times plus this are the source's times.
      if (dataset.time_origin_s != 0 || dataset.time_origin_fraction_s != 0.0)
        provenance["time_origin_s"] =
            fmt::format("{}.{:09}", dataset.time_origin_s, std::llround(dataset.time_origin_fraction_s * 1e9));

      auto slam = make_filter(filter, dataset);
      RunOptions options;
      ProgressLine progress;
      if (verbosity != Verbosity::kQuiet && isatty(STDERR_FILENO)) options.observers.push_back(&progress);
      std::optional<ReplayRecorder> recorder;
      if (replay) options.observers.push_back(&recorder.emplace(dataset));
      options.stop = &g_interrupted;
      options.history = history;
      std::signal(SIGINT, on_interrupt);
      RunResult run = run_filter(*slam, dataset, options);
      std::signal(SIGINT, SIG_DFL);
      progress.finish();
      stage("filter run");
      if (run.diverged_at_s)
        warn(fmt::format("the filter diverged: its pose estimate was no longer finite after the event at t = {} s; "
                         "writing the result up to its last finite estimate (t = {:.1f} s) to {}",
                         *run.diverged_at_s, run.filtered.back().t, run_out));
      else if (run.partial)
        warn(fmt::format("interrupted: writing the partial result (up to t = {:.1f} s) to {}", run.filtered.back().t,
                         run_out));
      run.association = to_string(filter.association.method);
      run.dataset = dataset_spec;
      run.dataset_settings = settings_path;
      run.provenance = std::move(provenance);
      write_run(run_out, run);
      write_truth(run_out, dataset);
      const Metrics metrics = evaluate_and_report(run_out, run, dataset);
      if (recorder) {
        // A truth with headings shares the map's frame (the start pose), as pose NEES assumes; a GPS
        // truth does not, and is brought over by the evaluation's alignment.
        const Pose2 alignment = dataset.truth.poses_have_heading
                                    ? Pose2::Zero()
                                    : Pose2(metrics.alignment.translation.x(), metrics.alignment.translation.y(),
                                            metrics.alignment.theta);
        const nlohmann::json recording = recorder->to_json(run.filter, alignment);
        write_file_atomically((fs::path(run_out) / "replay.json").string(), recording.dump() + "\n");
        plot::write_replay_html((fs::path(run_out) / "replay.html").string(), recording);
      }
      stage("written and evaluated");
      print_outputs(run_out, metrics, verbosity);
      if (recorder && verbosity != Verbosity::kQuiet)
        fmt::print("replay: {}\n", (fs::path(run_out) / "replay.html").string());
      if (run.diverged_at_s) return kExitDiverged;
      if (run.partial) return kExitInterrupted;
    } else if (*calibrate_cmd) {
      for (const std::string& spec : calibrate_specs)
        if (!spec.starts_with("mrclam:")) {
          std::cerr << "slamkit: error: calibrate writes MRCLAM settings; expected --data mrclam:DIR:robotN, found '"
                    << spec << "' (see 'slamkit calibrate --help')\n";
          return kExitUsage;
        }
      const nlohmann::json contents = dataset_settings_json(calibrate_config);
      MrclamOptions settings =
          calibrate_config.empty() ? MrclamOptions{} : mrclam_options_from_json(contents, calibrate_config);
      std::vector<Dataset> logs;
      for (const std::string& spec : calibrate_specs)
        logs.push_back(load_dataset(absolute_dataset_spec(spec), contents, calibrate_config));
      CalibrationOptions options;
      options.min_command_delay_s = -settings.command_delay;  // a robot cannot act before it logs
      const Calibration c = calibrate(logs, options);
      settings.command_delay += c.command_delay_s;
      settings.motion = c.motion;
      settings.measurement = c.measurement;
      write_file_atomically(calibrate_out, to_json(settings).dump(2) + "\n");
      if (!calibrate_report.empty()) write_file_atomically(calibrate_report, to_json(c).dump(2) + "\n");
      fmt::print("{}", calibration_summary(c, settings.command_delay));
      fmt::print("wrote {}\n", calibrate_out);
    } else if (*nees_cmd) {
      std::vector<Metrics> runs;
      for (const std::string& dir : nees_dirs) {
        const RunResult run = read_run(dir);
        runs.push_back(evaluate_run(run, load_dataset(run.dataset, run.dataset_settings).truth));
      }
      write_monte_carlo_nees(nees_out, runs, nees_title);
      fmt::print("wrote {} ({} runs)\n", nees_out, runs.size());
    } else if (*replay_cmd) {
      const std::string page = (fs::path(replay_dir) / "replay.html").string();
      plot::write_replay_html(page, read_json_file((fs::path(replay_dir) / "replay.json").string()));
      fmt::print("wrote {}\n", page);
    } else if (*eval_cmd) {
      const RunResult run = read_run(eval_dir);
      // A run.json that records the settings' contents is evaluated with them, wherever the file went.
      const Dataset dataset =
          run.provenance.contains("dataset_settings_contents")
              ? load_dataset(run.dataset, run.provenance.at("dataset_settings_contents"), run.dataset_settings)
              : load_dataset(run.dataset, run.dataset_settings);
      write_truth(eval_dir, dataset);
      print_outputs(eval_dir, evaluate_and_report(eval_dir, run, dataset), Verbosity::kNormal);
    }
  } catch (const InputError& e) {
    std::cerr << "slamkit: error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "slamkit: error: " << e.what() << "\n";
    return kExitBadInput;
  }
  return 0;
}
