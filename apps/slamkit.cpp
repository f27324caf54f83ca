// slamkit command-line tool: a thin layer over the library. Each subcommand parses its options,
// calls the public API, and reports. Bad input of any kind ends in one line on stderr naming the
// file, the line and what was expected, and a non-zero exit code.
#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fmt/format.h>
#include <iostream>
#include <stdexcept>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/plot/benchmark_plots.hpp"
#include "slamkit/plot/report.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace fs = std::filesystem;
using namespace slamkit;

namespace {

constexpr int kExitBadInput = 1;
constexpr int kExitUsage = 2;

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

void print_outputs(const std::string& dir, const Metrics& metrics) {
  fmt::print("{}\n", headline(metrics));
  fmt::print("results in {}/: metrics.json, map.svg, landmark_std.svg, trajectory.tum, map.txt (nees.svg where the truth has headings)\n", dir);
}

bool has_landmark_ids(const Dataset& dataset) {
  for (const Event& e : dataset.events)
    if (const auto* scan = std::get_if<ScanEvent>(&e))
      for (const Observation& o : scan->observations)
        if (o.id != kUnknownId) return true;
  return false;
}

/// Evaluates a run against its dataset's truth, writes metrics.json and the pictures.
Metrics evaluate_and_report(const std::string& dir, const RunResult& run, const Dataset& dataset) {
  const Metrics metrics = evaluate_run(run, dataset.truth);
  write_metrics(dir, metrics);
  write_run_plots(dir, run, dataset.truth, metrics);
  return metrics;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"slamkit: landmark-based SLAM (EKF-SLAM) with a simulator, evaluation and plots"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Show help for every command");

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
  run_cmd->add_option("--data", data_spec,
                      "Dataset, as KIND:PATH: sim:DIR, victoria-park:DIR, mrclam:DIR:robotN, course:DIR")
      ->required();
  run_cmd->add_option("--data-config", data_config,
                      "Dataset settings (JSON: noise, sensor limits); the defaults are config/*.json")
      ->check(CLI::ExistingFile);
  run_cmd->add_option("--seed", filter.seed, "Random seed for stochastic filters")
      ->capture_default_str()
      ->check(integer_at_least(0));
  run_cmd->add_option("--particles", filter.particles, "FastSLAM: number of particles")
      ->capture_default_str()
      ->check(integer_at_least(1));
  add_named(run_cmd, "--resample", filter.resample, parse_resample_method,
            "FastSLAM: multinomial, stratified, systematic or residual");
  add_named(run_cmd, "--resample-when", filter.resample_when, parse_resample_policy,
            "FastSLAM: always, every:K (scans) or ess:F (effective sample size below F*N)");
  run_cmd->add_option("--threads", filter.threads, "FastSLAM: worker threads (0: all cores)")
      ->capture_default_str()
      ->check(integer_at_least(0));
  add_named(run_cmd, "--ekf-update", filter.ekf_update, parse_ekf_update,
            "EKF and UKF: joint (a scan at once) or sequential (one observation after another); the "
            "compressed variant is always sequential");
  add_named(run_cmd, "--ekf-variant", filter.ekf_variant, parse_ekf_variant,
            "EKF: full, compressed (local-area updates, the same result as full with sequential updates), "
            "fej (first-estimates Jacobians) or invariant (right-invariant error); fej and invariant keep "
            "the EKF consistent");
  run_cmd->add_option("--out", run_out, "Output folder for estimates, metrics and plots")->required();

  // ---- evaluate ----
  auto* eval_cmd = app.add_subcommand("evaluate", "Recompute metrics.json and the plots of a run folder");
  std::string eval_dir;
  eval_cmd->add_option("dir", eval_dir, "Run folder written by 'slamkit run'")->required()->check(CLI::ExistingDirectory);

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
  } catch (const CLI::ParseError& e) {
    const auto parsed = app.get_subcommands();
    const std::string help = parsed.empty() ? "slamkit --help" : "slamkit " + parsed.front()->get_name() + " --help";
    std::cerr << "slamkit: error: " << e.what() << " (see '" << help << "')\n";
    return kExitUsage;
  }
  // The filter settings as a whole, by the library's own check (which make_filter repeats), before
  // any data is read.
  if (*run_cmd) {
    try {
      validate(filter);
    } catch (const std::invalid_argument& e) {
      std::cerr << "slamkit: error: " << e.what() << " (see 'slamkit run --help')\n";
      return kExitUsage;
    }
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
      if (filter.ekf_variant == EkfVariant::kCompressed && filter.ekf_update == EkfUpdate::kJoint &&
          run_cmd->count("--ekf-update") > 0)
        std::cerr << "slamkit: warning: the compressed EKF updates one observation at a time; --ekf-update joint "
                     "is ignored and the run is sequential\n";
      const Dataset dataset = load_dataset(data_spec, data_config);
      if (filter.association.method == AssociationMethod::kKnown && !has_landmark_ids(dataset))
        throw InputError(data_spec, 0, "the log's observations carry no landmark ids; use --assoc nn or --assoc jcbb");
      auto slam = make_filter(filter, dataset);
      RunResult run = run_filter(*slam, dataset);
      run.association = to_string(filter.association.method);
      run.dataset_settings = data_config;
      write_run(run_out, run);
      print_outputs(run_out, evaluate_and_report(run_out, run, dataset));
    } else if (*nees_cmd) {
      std::vector<Metrics> runs;
      for (const std::string& dir : nees_dirs) {
        const RunResult run = read_run(dir);
        runs.push_back(evaluate_run(run, load_dataset(run.dataset, run.dataset_settings).truth));
      }
      write_monte_carlo_nees(nees_out, runs, nees_title);
      fmt::print("wrote {} ({} runs)\n", nees_out, runs.size());
    } else if (*eval_cmd) {
      const RunResult run = read_run(eval_dir);
      const Dataset dataset = load_dataset(run.dataset, run.dataset_settings);
      print_outputs(eval_dir, evaluate_and_report(eval_dir, run, dataset));
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
