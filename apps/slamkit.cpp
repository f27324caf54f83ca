// slamkit command-line tool: a thin layer over the library. Each subcommand parses its options,
// calls the public API, and reports. Bad input of any kind ends in one line on stderr naming the
// file, the line and what was expected, and a non-zero exit code: 2 for a usage error (an unknown
// option, subcommand or name, a value out of range, a malformed dataset spec), 1 for bad data (a
// missing or malformed file), 3 for a run whose filter diverged, 130 for an interrupted run.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <iostream>
#include <new>
#include <optional>
#include <stdexcept>

#include "campaign_commands.hpp"
#include "slamkit/calib/calibration.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/atomic_folder.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/names.hpp"
#include "slamkit/core/version.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/carmen.hpp"
#include "slamkit/io/mrclam.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/pipeline/execute.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/replay.hpp"
#include "slamkit/pipeline/run_folder.hpp"
#include "slamkit/pipeline/run_memory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/pipeline/stop_signals.hpp"
#include "slamkit/pipeline/settings.hpp"
#include "slamkit/plot/benchmark_plots.hpp"
#include "slamkit/plot/replay_html.hpp"
#include "slamkit/plot/report.hpp"
#include "slamkit/sim/building.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace fs = std::filesystem;
using namespace slamkit;

namespace {

constexpr int kExitBadInput = 1;
constexpr int kExitUsage = 2;
constexpr int kExitDiverged = 3;  // the filter's estimate stopped being finite

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

/// A number `ok` accepts; NaN and infinities (which CLI11 converts from "nan" and "1e400") are
/// refused by every range here.
CLI::Validator number_where(const std::string& expected, bool (*ok)(double)) {
  return CLI::Validator(
      [=](std::string& text) {
        double v = 0.0;
        if (!CLI::detail::lexical_cast(text, v) || !std::isfinite(v) || !ok(v))
          return fmt::format("expected {}, found {}", expected, text);
        return std::string();
      },
      "");
}

/// Any finite number: for settings whose range the library states (validate), in one place.
CLI::Validator finite_number() {
  return number_where("a finite number", [](double) { return true; });
}

/// A check by a library parser or checker (a filter, an association method, a resampling scheme or
/// policy, a dataset spec, ...): text it rejects with std::invalid_argument is a usage error carrying
/// its message, which says what was expected and, for a name, the nearest ones.
template <typename Parse>
CLI::Validator parsed_by(Parse parse) {
  return CLI::Validator(
      [parse](std::string& text) {
        try {
          parse(text);
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
        return std::string();
      },
      "");
}

/// One of `names`, with the nearest ones suggested when the text is none of them.
CLI::Validator one_of(std::string what, std::vector<std::string> names) {
  return CLI::Validator(
      [what, names](std::string& text) {
        if (std::find(names.begin(), names.end(), text) != names.end()) return std::string();
        return unknown_name_message(what, text, names);
      },
      "");
}

/// A setting named on the command line and parsed by the library into `target`. The help shows the
/// default under its name.
template <typename T>
CLI::Option* add_named(CLI::App* cmd, const std::string& flag, T& target, T (*parse)(const std::string&),
                       const std::string& help) {
  return cmd
      ->add_option_function<std::string>(
          flag, [&target, parse](const std::string& text) { target = parse(text); }, help)
      ->check(parsed_by(parse))
      ->default_str(to_string(target));
}

/// A filter setting given as a flag: its value goes into `settings` under run.json's key (a JSON
/// pointer, "/particles" or "/association/accept_probability"), the top layer of the run's settings
/// (pipeline/settings.hpp). `default_text` is what the help shows.
template <typename T>
CLI::Option* add_setting(CLI::App* cmd, const std::string& flag, nlohmann::json& settings, const std::string& key,
                         const std::string& help, const std::string& default_text) {
  return cmd
      ->add_option_function<T>(
          flag, [&settings, key](const T& value) { settings[nlohmann::json::json_pointer(key)] = value; }, help)
      ->default_str(default_text);
}

/// The same for a setting given by name, checked by its library parser.
template <typename T>
CLI::Option* add_named_setting(CLI::App* cmd, const std::string& flag, nlohmann::json& settings,
                               const std::string& key, T (*parse)(const std::string&), const std::string& help,
                               const T& default_value) {
  return add_setting<std::string>(cmd, flag, settings, key, help, to_string(default_value))->check(parsed_by(parse));
}

/// A command's options by their long names, for suggestions.
std::vector<std::string> option_names(const CLI::App& cmd) {
  std::vector<std::string> names;
  for (const CLI::Option* option : cmd.get_options())
    for (const std::string& name : option->get_lnames()) names.push_back("--" + name);
  return names;
}

/// What an option stands for in a message: its flag, or its positional name in capitals ("DIR"),
/// and its help line.
std::string option_label(const CLI::App& cmd, const std::string& name) {
  for (const CLI::Option* option : cmd.get_options()) {
    if (!option->check_name(name)) continue;
    std::string label = name;
    if (option->get_lnames().empty())
      for (char& c : label) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return fmt::format("{}: {}", label, option->get_description());
  }
  return name;
}

/// CLI11's parse errors in slamkit's words, naming what was wrong and what was expected. `cmd` is the
/// subcommand being parsed, if CLI11 got that far.
std::string usage_message(const CLI::ParseError& e, const CLI::App& app, const CLI::App* cmd, int argc, char** argv) {
  const std::string what = e.what();
  std::vector<std::string> commands;
  for (const CLI::App* sub : app.get_subcommands({})) commands.push_back(sub->get_name());
  if (cmd == nullptr) {
    // CLI11 reports a misspelt subcommand as a missing one, or as an unexpected argument.
    if (argc > 1 && argv[1][0] != '-') return unknown_name_message("subcommand", argv[1], commands);
    if (argc > 1) return fmt::format("unknown option '{}'; expected a subcommand first: {}", argv[1], fmt::join(commands, ", "));
    return fmt::format("expected a subcommand: {}", fmt::join(commands, ", "));
  }
  if (dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr) {
    const std::vector<std::string> extras = cmd->remaining();
    const std::string first = extras.empty() ? what : extras.front();
    if (first.size() > 1 && first[0] == '-') {
      const std::string name = first.substr(0, first.find('='));
      // "-f" is no option of slamkit's (every option is long): suggest the long ones it begins.
      const std::string as_long = name[1] == '-' ? name : "--" + name.substr(1);
      return fmt::format("unknown option '{}'{}", name, did_you_mean(as_long, option_names(*cmd)));
    }
    return fmt::format("unexpected argument '{}'; options are written --NAME VALUE", first);
  }
  const std::string name = what.substr(0, what.find_first_of(": "));
  if (dynamic_cast<const CLI::RequiredError*>(&e) != nullptr)
    return fmt::format("missing {}", option_label(*cmd, name));
  if (dynamic_cast<const CLI::ArgumentMismatch*>(&e) != nullptr)
    return what.find("missing") != std::string::npos ? fmt::format("{} needs a value", name)
                                                     : fmt::format("{} may be given only once", name);
  if (dynamic_cast<const CLI::ExcludesError*>(&e) != nullptr) {
    const std::string other = what.substr(what.find(" excludes ") + 10);
    const bool repeat = name == "--config" || other == "--config";
    return fmt::format("{} and {} cannot be given together{}", name, other,
                       repeat ? ": --config repeats a run with every setting its run.json records" : "");
  }
  if (dynamic_cast<const CLI::ConversionError*>(&e) != nullptr) {
    // "Could not convert: --no-ids = maybe": every option with a value is checked before it is
    // converted, so only a flag given a value that is not true or false gets here.
    const auto flag = what.find("--"), equals = what.find(" = ");
    if (flag != std::string::npos && equals != std::string::npos && equals > flag)
      return fmt::format("{} is a flag: expected no value (or true or false), found '{}'",
                         what.substr(flag, equals - flag), what.substr(equals + 3));
  }
  return what;  // ValidationError: the message of one of the checks above, prefixed with the option
}

/// --family and --world-seed, which choose a world of a family; returns --family.
CLI::Option* add_family_options(CLI::App* cmd, std::string& family, std::uint64_t& world_seed) {
  std::string names;
  for (const std::string& name : world_family_names()) names += (names.empty() ? "" : ", ") + name;
  auto* family_opt =
      cmd->add_option("--family", family,
                      fmt::format("A random world of this family ({}), chosen by --world-seed; simulate uses "
                                  "the family's settings (docs/world-families.md)",
                                  names))
          ->check(parsed_by(&world_family));
  cmd->add_option("--world-seed", world_seed, "Which world of the --family; each seed gives its own route and landmarks")
      ->capture_default_str()
      ->check(integer_at_least(0))
      ->needs(family_opt);
  return family_opt;
}

enum class Verbosity { kQuiet, kNormal, kVerbose };

void print_outputs(const std::string& dir, const Metrics& metrics, Verbosity verbosity) {
  if (verbosity == Verbosity::kQuiet) return;
  fmt::print("{}\n", headline(metrics));
  std::string files = "metrics.json, map.svg";
  // These need a landmark map, a truth of the right kind (with headings; any truth for truth.tum), an
  // information filter or a grid map.
  for (const char* optional :
       {"landmark_std.svg", "nees.svg", "pose_error.svg", "information.svg", "truth.tum", "map.pgm", "map.yaml"})
    if (fs::exists(fs::path(dir) / optional)) files += fmt::format(", {}", optional);
  fmt::print("results in {}/: {}, trajectory.tum, map.txt\n", dir, files);
}

/// A progress line on stderr, rewritten in place, for runs that last longer than a second: how far,
/// how fast, and when it will end. Only on a terminal, so logs and pipes stay clean. Written with
/// fputs, which unlike fmt::print does not throw when the terminal has gone (SIGHUP): the run goes
/// on to write its folder.
class ProgressLine : public RunObserver {
 public:
  void on_scan(const SlamFilter& filter, const ScanEvent& scan, std::size_t done, std::size_t total) override {
    const auto now = std::chrono::steady_clock::now();
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    if (elapsed < 1.0 || now - last_ < std::chrono::milliseconds(250)) return;
    last_ = now;
    const double rate = static_cast<double>(done) / elapsed;
    const double eta = static_cast<double>(total - done) / rate;
    std::fputs(fmt::format("\r\033[K{:5.1f}%  t = {:.0f} s  {} landmarks  {:.0f} events/s  ETA {:.0f} s",
                           100.0 * static_cast<double>(done) / static_cast<double>(total), scan.t,
                           filter.num_landmarks(), rate, eta)
                   .c_str(),
               stderr);
    shown_ = true;
  }
  /// Clears the line, so what follows starts on a clean one.
  void finish() {
    if (shown_) std::fputs("\r\033[K", stderr);
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point last_ = start_;
  bool shown_ = false;
};

/// The dataset settings' contents, or null for the reader's defaults.
nlohmann::json dataset_settings_json(const std::string& path) {
  return path.empty() ? nlohmann::json() : read_json_file(path);
}

/// "pose_sample_fraction 0.01, association.method nn": a partial settings object in one line.
std::string settings_in_words(const nlohmann::json& settings, const std::string& prefix = "") {
  std::string words;
  for (const auto& item : settings.items()) {
    const std::string part = item.value().is_object()
                                 ? settings_in_words(item.value(), prefix + item.key() + ".")
                                 : fmt::format("{}{} {}", prefix, item.key(),
                                               item.value().is_string() ? item.value().get<std::string>()
                                                                        : item.value().dump());
    words += (words.empty() ? "" : ", ") + part;
  }
  return words;
}

/// std::bad_alloc's own text says nothing a user can act on.
int out_of_memory() {
  std::cerr << "slamkit: error: out of memory: the command needs more than this process may use (for a run: fewer "
               "--particles, --history decimated or none, or a shorter dataset)\n";
  return kExitBadInput;
}

/// A warning when the known-identity gate rejected most observations over part of the run
/// (assoc/gate_tally.hpp): a filter that lost itself, whose figures from then on are odometry's.
void warn_if_lost(const Metrics& metrics) {
  const auto& stats = metrics.filter_statistics;
  const auto lost_at = stats.find("known_id_lost_at_s");
  if (lost_at == stats.end()) return;
  const auto recoveries = stats.find("known_id_recoveries");
  const std::string recovered =
      recoveries == stats.end() || recoveries->second == 0.0
          ? "it ran on odometry"
          : fmt::format("it ran on odometry until one of its {:.0f} recoveries let it back", recoveries->second);
  std::cerr << fmt::format(
      "slamkit: warning: the filter lost itself: the known-identity gate rejected most observations in {:.0f} tenth(s) "
      "of the run, the first from t = {:.1f} s ({:.0f}% of all {:.0f} judged); its estimate strayed further than its "
      "covariance allows and {} (known_id_* in metrics.json)\n",
      stats.at("known_id_lost_tenths"), lost_at->second, 100.0 * stats.at("known_id_rejected_fraction"),
      stats.at("known_id_judged"), recovered);
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

int run_command(int argc, char** argv) {
  CLI::App app{"slamkit: landmark-based SLAM (EKF-SLAM, UKF, FastSLAM) with a simulator, evaluation and plots"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Show help for every command");
  app.set_version_flag("--version", version(), "Print the version and exit");
  app.footer(
      "Exit codes: 0 done, 1 bad data (a missing or malformed file), 2 usage error, 3 the filter diverged, "
      "130 interrupted.\nDocumentation: docs/ of the source tree, installed in PREFIX/share/doc/slamkit; which "
      "filter, association and settings for which situation: choosing.md there.");

  // ---- simulate ----
  auto* simulate_cmd = app.add_subcommand("simulate", "Simulate a vehicle driving through a landmark world");
  std::string world_path, config_path, sim_out, scenario_name = "default", family_name, sensor_name;
  std::uint64_t sim_seed = 1, world_seed = 1;
  int loops = 0;
  double clutter = -1.0, detection = -1.0;
  bool no_ids = false;
  auto* scenario_opt =
      simulate_cmd
      ->add_option("--scenario", scenario_name,
                   fmt::format("Built-in world and settings: {}", fmt::join(scenario_names(), ", ")))
      ->capture_default_str()
      ->check(one_of("scenario", scenario_names()));
  auto* world_opt =
      simulate_cmd->add_option("--world", world_path, "World file (landmarks and waypoints); replaces the scenario's world");
  add_family_options(simulate_cmd, family_name, world_seed)->excludes(scenario_opt)->excludes(world_opt);
  simulate_cmd->add_option("--config", config_path, "Simulator settings (JSON); default: the reference simulator's");
  simulate_cmd->add_option("--seed", sim_seed, "Random seed of the noise; the same seeds give the same log")
      ->capture_default_str()
      ->check(integer_at_least(0));
  simulate_cmd->add_option("--loops", loops, "Laps of the route (overrides the config)")->check(integer_at_least(1));
  simulate_cmd->add_option("--clutter", clutter, "False detections per scan (Poisson mean)")
      ->check(number_where(">= 0", [](double v) { return v >= 0.0; }));
  simulate_cmd->add_option("--detection-prob", detection, "Probability of detecting a landmark in view")
      ->check(number_where("in (0, 1]", [](double v) { return v > 0.0 && v <= 1.0; }));
  simulate_cmd->add_flag("--no-ids", no_ids, "Withhold landmark identities from the log (kept in the truth)");
  simulate_cmd
      ->add_option("--sensor", sensor_name,
                   "What the sensor measures of each landmark: range-bearing (the scenario's), range-only (a radio "
                   "ranging to beacons) or bearing-only (a camera's azimuth); its noise is the config's sigma_range "
                   "or sigma_bearing")
      ->check(parsed_by(parse_sensor_kind));
  std::string building_name;
  auto* building_opt =
      simulate_cmd
          ->add_option("--building", building_name,
                       fmt::format("Simulate a robot with a planar laser in a building instead: {} (--config: "
                                   "its settings, docs/grid-mapping.md; writes "
                                   "OUT/PLAN.log, a CARMEN log with its odometry, and OUT/PLAN.reference.log, the "
                                   "true poses; run it with --data carmen:OUT/PLAN.log)",
                                   fmt::join(floor_plan_names(), ", ")))
          ->check(one_of("building", floor_plan_names()));
  for (const char* name : {"--scenario", "--world", "--family", "--clutter", "--detection-prob", "--no-ids", "--sensor"})
    building_opt->excludes(simulate_cmd->get_option(name));
  simulate_cmd->add_option("--out", sim_out, "Output folder for the log and ground truth")->required();

  // ---- make-world ----
  auto* world_cmd = app.add_subcommand("make-world", "Generate a world file (a loop route with landmarks)");
  WorldGenOptions gen;
  std::string world_out;
  world_cmd->add_option("--landmarks", gen.landmarks,
                        "Number of landmarks, up to 1e7 (in a band that cannot hold them 3 m apart, closer)")
      ->capture_default_str()
      ->check(integer_at_least(1));
  const CLI::Validator positive = number_where("> 0", [](double v) { return v > 0.0; });
  world_cmd->add_option("--width", gen.width, "Route width [m]")->capture_default_str()->check(positive);
  world_cmd->add_option("--height", gen.height, "Route height [m]")->capture_default_str()->check(positive);
  world_cmd->add_option("--band", gen.band_outer, "Landmarks lie up to this far from the route [m]")
      ->capture_default_str()
      ->check(positive);
  world_cmd->add_option("--seed", gen.seed, "Random seed")->capture_default_str()->check(integer_at_least(0));
  world_cmd->add_option("--out", world_out, "World file to write")->required();
  auto* world_family_opt = add_family_options(world_cmd, family_name, world_seed);
  std::string world_scenario;
  auto* world_scenario_opt =
      world_cmd
          ->add_option("--scenario", world_scenario,
                       fmt::format("Write a built-in scenario's world instead: {}", fmt::join(scenario_names(), ", ")))
          ->check(one_of("scenario", scenario_names()))
          ->excludes(world_family_opt);
  for (const char* name : {"--landmarks", "--width", "--height", "--band", "--seed"}) {
    world_family_opt->excludes(world_cmd->get_option(name));
    world_scenario_opt->excludes(world_cmd->get_option(name));
  }

  // ---- run ----
  // Every filter setting is parsed and checked here, before any data is read: a misspelt name or a
  // value out of range is a usage error. The flags are the top layer of the run's settings; below
  // them lie --assoc-config, the dataset's recommendation and the defaults (pipeline/settings.hpp).
  auto* run_cmd = app.add_subcommand(
      "run",
      "Run a SLAM filter on a dataset and evaluate it. Settings come from, lowest first: the defaults, the "
      "dataset's recommended settings for the filter (the \"recommended\" object of its config file; Victoria "
      "Park's name an association method for every filter, --ukf-noise additive and --pose-sample-fraction 0.01), "
      "--assoc-config, and the flags; --print-config shows the result");
  const FilterConfig defaults;
  nlohmann::json flag_settings = nlohmann::json::object();
  std::string data_spec, run_out, data_config;
  add_named_setting(run_cmd, "--filter", flag_settings, "/filter", parse_filter_kind,
                    "Filter: ekf, ukf, eif (the EKF in information form), seif (the sparse extended information filter), "
                    "eseif (the exactly sparse extended information filter), tjtf (Paskin's thin junction tree filter), "
                    "fastslam1, fastslam2; on laser logs: scan-matching (odometry corrected by matching each scan "
                    "against the map so far), grid-fastslam (particles with occupancy grids, GMapping's proposal)",
                    defaults.filter);
  add_named_setting(run_cmd, "--assoc", flag_settings, "/association/method", parse_association_method,
                    "Data association: known (ids from the log), nn, jcbb", defaults.association.method);
  auto* data_opt =
      run_cmd
          ->add_option("--data", data_spec,
                       "Dataset, as KIND:PATH: sim:DIR, victoria-park:DIR, mrclam:DIR:robotN (N 1-5; also DIR:N "
                       "and DIR/RobotN; a bare DIR is robot 1), course:DIR, plaza:DIR:Plaza1 (range-only), carmen:FILE (a laser "
                       "log, .gz too; config/radish.json for the corrected Radish logs). Its files "
                       "must be regular files, with lines up to 1 MiB, positions within +-2e6 m and at least one "
                       "observation")
          ->check(parsed_by(check_dataset_spec));
  auto* data_config_opt = run_cmd->add_option(
      "--data-config", data_config,
      "Dataset settings (JSON: noise, sensor limits, recommended filter settings); the defaults are the shipped "
      "config/*.json, installed in PREFIX/share/slamkit/config");
  add_setting<std::uint64_t>(run_cmd, "--seed", flag_settings, "/seed", "Random seed for stochastic filters",
                             std::to_string(defaults.seed))
      ->check(integer_at_least(0));
  add_setting<int>(run_cmd, "--particles", flag_settings, "/particles",
                   "FastSLAM and grid-fastslam (which starts at 30): number of particles; a run whose estimated memory (particles x landmarks, and the "
                   "history kept) exceeds what this process may use is refused before it starts",
                   std::to_string(defaults.particles))
      ->check(integer_at_least(1));
  add_setting<double>(run_cmd, "--grid-resolution", flag_settings, "/grid/resolution_m",
                      "scan-matching and grid-fastslam: the occupancy grid's cell side [m]",
                      fmt::format("{}", defaults.grid.grid.resolution))
      ->check(finite_number());
  add_setting<double>(run_cmd, "--grid-range-cutoff", flag_settings, "/grid/range_cutoff_m",
                      "scan-matching and grid-fastslam: readings beyond this (and no-returns) mark free space up to "
                      "it and no obstacle [m]",
                      fmt::format("{}", defaults.grid.grid.range_cutoff))
      ->check(finite_number());
  add_setting<double>(run_cmd, "--grid-sample-fraction", flag_settings, "/grid/proposal_sample_fraction",
                      "grid-fastslam: share of the proposal's covariance a particle draws its pose from, in [0, 1] "
                      "(0: the proposal's mean, as GMapping moves a particle to its match)",
                      fmt::format("{}", defaults.grid.proposal_sample_fraction))
      ->check(finite_number());
  add_setting<double>(run_cmd, "--grid-update-distance", flag_settings, "/grid/update_distance_m",
                      "scan-matching and grid-fastslam: a scan is matched and mapped once the odometry has moved "
                      "this far since the last one (or turned grid.update_rotation_deg); 0 takes every scan [m]",
                      fmt::format("{}", defaults.grid.update_distance))
      ->check(finite_number());
  add_setting<double>(run_cmd, "--pose-sample-fraction", flag_settings, "/pose_sample_fraction",
                      "FastSLAM 2.0: share of the proposal's covariance a particle draws its pose from, in (0, 1]; "
                      "it carries the rest as a Gaussian (1: the textbook filter)",
                      fmt::format("{}", defaults.pose_sample_fraction))
      ->check(finite_number());
  add_named_setting(run_cmd, "--resample", flag_settings, "/resample", parse_resample_method,
                    "FastSLAM: multinomial, stratified, systematic or residual", defaults.resample);
  add_named_setting(run_cmd, "--resample-when", flag_settings, "/resample_when", parse_resample_policy,
                    "FastSLAM: always, every:K (scans) or ess:F (effective sample size below F*N)",
                    defaults.resample_when);
  add_setting<unsigned>(run_cmd, "--threads", flag_settings, "/threads",
                        "FastSLAM and EKF: worker threads (0: all cores); the result does not depend on it",
                        std::to_string(defaults.threads))
      ->check(integer_at_least(0));
  add_named_setting(run_cmd, "--ekf-update", flag_settings, "/ekf_update", parse_ekf_update,
                    "EKF and UKF: joint (a scan at once) or sequential (one observation after another). "
                    "EKF full, fej or invariant, eif, seif and eseif: iterated (joint, relinearised at the "
                    "result until it converges; keeps a loop closure after a long drift consistent). tjtf: always one "
                    "observation after another",
                    defaults.ekf_update);
  add_named_setting(run_cmd, "--ekf-variant", flag_settings, "/ekf_variant", parse_ekf_variant,
                    "EKF: full, compressed (local-area updates, the same result as full), "
                    "fej (first-estimates Jacobians) or invariant (right-invariant error); fej and invariant keep "
                    "the EKF consistent. eif, seif and eseif: fej too",
                    defaults.ekf_variant);
  add_named_setting(run_cmd, "--ukf-noise", flag_settings, "/ukf_noise", parse_ukf_noise,
                    "UKF: augmented (sigma points over the vehicle and the control noise, which then moves the mean "
                    "too) or additive (over the vehicle; the control noise's spread added as zero-mean process "
                    "noise, for noise that is an allowance for model error)",
                    defaults.ukf_noise);
  add_setting<std::size_t>(run_cmd, "--seif-active", flag_settings, "/seif_active_landmarks",
                           "SEIF: landmarks linked to the vehicle at most after each scan's sparsification (more: "
                           "closer to the exact EIF; fewer: a sparser information matrix)",
                           std::to_string(defaults.seif.active_landmarks))
      ->check(integer_at_least(1));
  add_setting<int>(run_cmd, "--seif-sweeps", flag_settings, "/seif_recovery_sweeps",
                   "SEIF: Gauss-Seidel sweeps of the mean recovery per scan over the vehicle, the active landmarks "
                   "and as many others in turn (0: exact, a sparse solve of the whole map)",
                   std::to_string(defaults.seif.recovery_sweeps))
      ->check(integer_at_least(0));
  add_named_setting(run_cmd, "--seif-covariance", flag_settings, "/seif_covariance", parse_covariance_recovery,
                    "SEIF: how the covariances the gates and the outputs read are recovered: local (from the "
                    "Markov blanket of what is asked about; the same cost however large the map, overconfident) "
                    "or exact (a sparse factorisation of the whole map, whose solve then also gives the mean each "
                    "update linearises at)",
                    defaults.seif.covariance);
  add_setting<std::size_t>(run_cmd, "--eseif-active", flag_settings, "/eseif_active_landmarks",
                           "ESEIF: landmarks linked to the vehicle at most before a scan relocates it (more: fewer "
                           "relocations, less information forgotten; fewer: a sparser information matrix)",
                           std::to_string(defaults.eseif.active_landmarks))
      ->check(integer_at_least(1));
  add_setting<int>(run_cmd, "--eseif-sweeps", flag_settings, "/eseif_recovery_sweeps",
                   "ESEIF: Gauss-Seidel sweeps of the mean recovery per scan, as --seif-sweeps",
                   std::to_string(defaults.eseif.recovery_sweeps))
      ->check(integer_at_least(0));
  add_named_setting(run_cmd, "--eseif-covariance", flag_settings, "/eseif_covariance", parse_covariance_recovery,
                    "ESEIF: how covariances are recovered, as --seif-covariance (exact by default: the local "
                    "recovery of a relocated vehicle conditions on the landmarks that relocated it)",
                    defaults.eseif.covariance);
  add_setting<std::size_t>(run_cmd, "--tjtf-clique", flag_settings, "/tjtf_max_clique_landmarks",
                           "TJTF: landmarks a clique of the junction tree holds at most (more: more of the EKF's "
                           "correlations kept, each clique costing (3 + 2k)^3)",
                           std::to_string(defaults.tjtf.max_clique_landmarks))
      ->check(integer_at_least(TjtfOptions::kMinCliqueLandmarks));
  add_named_setting(run_cmd, "--landmark-init", flag_settings, "/landmark_init", parse_landmark_init,
                    "How a landmark starts: immediate (from one measurement's inverse), delayed "
                    "(triangulated from several observations at well-spread poses; known ids only), ring (range "
                    "only: a ring of Gaussian hypotheses that collapses as the ranges agree; known ids only), "
                    "inverse-distance (bearing only, ekf full or fej, known ids; the landmark joins the state at its first "
                    "bearing as an azimuth and inverse distance from its origin, and becomes a point once its "
                    "distance is known; docs/sensing.md) or "
                    "auto (immediate where one measurement places a landmark, delayed for range-only and "
                    "bearing-only sensors)",
                    defaults.landmark_init);
  add_setting<double>(run_cmd, "--init-max-std", flag_settings, "/delayed_init/max_std_m",
                      "Delayed and ring starts: the largest standard deviation a landmark may start with [m]",
                      fmt::format("{}", defaults.delayed_init.max_std_m))
      ->check(finite_number());
  add_setting<double>(run_cmd, "--init-window", flag_settings, "/delayed_init/window_s",
                      "Delayed and ring starts: how long a landmark's observations are kept while it waits [s]",
                      fmt::format("{}", defaults.delayed_init.window_s))
      ->check(finite_number());
  add_setting<double>(run_cmd, "--init-min-distance", flag_settings, "/inverse_distance_min_m",
                      "Inverse-distance start: the nearest a landmark is expected [m]; the prior of its inverse "
                      "distance reaches it at two standard deviations",
                      fmt::format("{}", defaults.inverse_distance.min_distance_m))
      ->check(finite_number());
  add_setting<double>(run_cmd, "--init-prior-distance", flag_settings, "/inverse_distance_prior_m",
                      "Inverse-distance start: where a landmark is first put along its ray [m], the mean of its "
                      "inverse distance's prior",
                      fmt::format("{}", defaults.inverse_distance.prior_distance_m))
      ->check(finite_number());
  // The range calibration: on with its default prior; a deviation given turns it on too.
  const RangeCalibrationPrior calibration_prior;
  run_cmd->add_flag_callback(
      "--range-calibration",
      [&] {
        nlohmann::json& calibration = flag_settings["range_calibration"];
        if (!calibration.is_object()) calibration = nlohmann::json::object();
      },
      fmt::format("EKF (full, fej, invariant) or fastslam2 (with the delayed start), known ids: estimate the "
                  "range sensor's offset and scale error (it reads (1 + s) d + b; radio beacons read long), from "
                  "priors 0 +- {} m and 0 +- {}",
                  calibration_prior.offset_std_m, calibration_prior.scale_error_std));
  add_setting<double>(run_cmd, "--range-offset-std", flag_settings, "/range_calibration/offset_std_m",
                      "The range calibration's prior standard deviation of the offset [m] (implies "
                      "--range-calibration)",
                      fmt::format("{}", calibration_prior.offset_std_m))
      ->check(finite_number());
  add_setting<double>(run_cmd, "--range-scale-std", flag_settings, "/range_calibration/scale_error_std",
                      "The range calibration's prior standard deviation of the scale error (implies "
                      "--range-calibration)",
                      fmt::format("{}", calibration_prior.scale_error_std))
      ->check(finite_number());
  add_named_setting(run_cmd, "--likelihood", flag_settings, "/likelihood", parse_likelihood_kind,
                    "The measurement noise's shape: gaussian, student-t (heavy tails: an observation far from "
                    "its prediction, a radio's multipath range, is trusted less instead of pulling the estimate; "
                    "the gate still rejects gross outliers), or student-t-long (the same, for a radio whose "
                    "outliers are only ever read long: a landmark's delayed start leaves out only ranges read long)",
                    defaults.likelihood.kind);
  add_setting<double>(run_cmd, "--likelihood-dof", flag_settings, "/likelihood_dof",
                      "With --likelihood student-t or student-t-long: its degrees of freedom (the smaller, the heavier "
                      "its tails)",
                      fmt::format("{}", defaults.likelihood.dof))
      ->check(finite_number());
  // Association and map management: a file holding the keys run.json records under
  // settings.association, and a flag for each setting, which overrides the file. Their ranges are
  // validate(AssociationConfig)'s, checked with the other settings before any data is read.
  std::string assoc_config_path;
  const AssociationConfig& assoc = defaults.association;
  run_cmd->add_option("--assoc-config", assoc_config_path,
                      "Association and map-management settings (JSON, the keys of run.json's settings.association; "
                      "config/association-cluttered.json for cluttered worlds); the flags below override it");
  const auto real_setting = [&](const std::string& flag, const std::string& key, const std::string& help, double value) {
    add_setting<double>(run_cmd, flag, flag_settings, "/association/" + key, help, fmt::format("{}", value))
        ->check(finite_number());
  };
  const auto count_setting = [&](const std::string& flag, const std::string& key, const std::string& help,
                                 auto value, unsigned long long min) {
    add_setting<decltype(value)>(run_cmd, flag, flag_settings, "/association/" + key, help, std::to_string(value))
        ->check(integer_at_least(min));
  };
  real_setting("--accept-probability", "accept_probability",
               "Pair an observation with a landmark only inside this chi-square quantile of its innovation",
               assoc.accept_probability);
  real_setting("--new-landmark-probability", "new_landmark_probability",
               "Start a landmark only outside this quantile for every candidate (between: discarded)",
               assoc.new_landmark_probability);
  real_setting("--min-pairing-probability", "min_pairing_probability",
               "Pair an observation only if that landmark explains it with at least this probability against "
               "the other candidates and clutter (0: off)",
               assoc.min_pairing_probability);
  real_setting("--clutter-per-scan", "clutter_per_scan",
               "Expected false detections per scan: with it a new landmark waits, pending, until it is more "
               "probably real than false, and --min-pairing-probability weighs pairings against clutter",
               assoc.clutter_per_scan);
  run_cmd
      ->add_option_function<std::string>(
          "--gate-known",
          [&](const std::string& on) { flag_settings["association"]["gate_known"] = on == "on"; },
          "Known ids: reject an observation beyond the new-landmark gate (default: EKF and UKF on, FastSLAM off)")
      ->check(one_of("value", {"on", "off"}));
  count_setting("--confirm-after", "confirm_after", "Observations that confirm a new landmark", assoc.confirm_after, 1);
  count_setting("--provisional-max-misses", "provisional_max_misses",
                "Scans in a row a provisional landmark may be missed in view", assoc.provisional_max_misses, 1);
  count_setting("--confirmed-max-misses", "confirmed_max_misses",
                "Scans in a row a confirmed landmark may be missed in view (0: never removed)",
                assoc.confirmed_max_misses, 0);
  real_setting("--view-margin-m", "view_margin_m", "Range margin of \"in view\" for misses [m]", assoc.view_margin_m);
  real_setting("--view-margin-rad", "view_margin_rad", "Bearing margin of \"in view\" for misses [rad]",
               assoc.view_margin_rad);
  count_setting("--jcbb-max-nodes", "jcbb_max_nodes", "JCBB: search nodes per scan", assoc.jcbb_max_nodes, 1);
  count_setting("--relocalise-min-pairs", "relocalise_min_pairs",
                "Without identities: recognise landmarks unseen for the window only when this many landmarks "
                "started since pair jointly with them, and fuse the duplicates. With identities (EKF family): "
                "widen the pose when this many observations the gate rejected fit their landmarks up to one "
                "rigid motion (0: off)",
                assoc.relocalise_min_pairs, 0);
  real_setting("--relocalise-window-s", "relocalise_window_s",
               "Relocalisation: how long a landmark must be unseen to count as old, and how far back one "
               "counts as recently mapped; with identities, how long a rejected observation is kept [s]",
               assoc.relocalise_window_s);
  real_setting("--detection-probability", "detection_probability",
               "With --clutter-per-scan: the probability that a landmark in view is detected, which a pending "
               "landmark's evidence assumes",
               assoc.detection_probability);
  run_cmd->add_option("--out", run_out,
                      "Output folder for estimates, metrics and plots. Written as DIR.partial-PID beside it, it "
                      "replaces DIR as a whole when complete, so a run that fails leaves DIR's previous run intact. "
                      "Refused while another process writes DIR, or if DIR is not empty and holds no run.json");
  run_cmd->footer("Exit codes: 0 done; 1 bad data or an output that cannot be written; 2 usage error; 3 the filter "
                  "diverged (its result up to the last finite estimate is written); 128+N stopped by signal N after "
                  "the current step, the partial result written (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP); a second "
                  "signal ends the run at once.");
  std::string repeat_path;
  bool print_config = false, replay = false, quiet = false, verbose = false;
  // Every filter and data option, which a repeated run takes from its run.json instead.
  std::vector<CLI::Option*> setting_opts = {data_opt, data_config_opt};
  for (CLI::Option* opt : run_cmd->get_options())
    if (opt != data_opt && opt != data_config_opt && !opt->check_lname("out") && !opt->check_lname("help") &&
        !opt->check_lname("help-all"))
      setting_opts.push_back(opt);
  auto* repeat_opt = run_cmd->add_option(
      "--config", repeat_path,
      "Repeat a run: the run.json of its folder gives the dataset, the dataset settings and every filter setting "
      "(no other filter or data option may be given)");
  for (CLI::Option* opt : setting_opts) repeat_opt->excludes(opt);
  run_cmd->add_flag("--print-config", print_config,
                    "Print the effective settings (as run.json records them, with the recommended ones applied) and "
                    "exit without running");
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
  replay_cmd->add_option("dir", replay_dir, "Run folder holding replay.json")->required();

  // ---- evaluate ----
  auto* eval_cmd = app.add_subcommand("evaluate", "Recompute metrics.json and the plots of a run folder");
  std::string eval_dir;
  EvaluationOptions eval_options;
  eval_cmd->add_option("dir", eval_dir, "Run folder written by 'slamkit run'")->required();
  add_named(eval_cmd, "--match", eval_options.time_matching, parse_time_matching,
            "How estimate and truth samples are paired in time: interpolate (the estimate at every truth time) or "
            "evo (as evo_ape: each sample of the shorter trajectory with the other's nearest, within "
            "--max-time-difference, nothing interpolated; docs/evaluation.md says why the two differ)");
  eval_cmd
      ->add_option("--max-time-difference", eval_options.max_time_difference_s,
                   "With --match evo: samples further apart in time are not paired [s] (evo's --t_max_diff)")
      ->capture_default_str()
      ->check(number_where(">= 0", [](double v) { return v >= 0.0; }));

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
                   "Settings the logs are read with (default: config/mrclam.json's); the written file keeps its other keys");
  calibrate_cmd->add_option("--out", calibrate_out, "Dataset settings file to write (JSON, for run --data-config)")
      ->required();
  calibrate_cmd->add_option("--report", calibrate_report,
                            "Also write the evidence (errors by horizon and by range, outliers) as JSON");

  // ---- plot-nees ----
  auto* nees_cmd = app.add_subcommand(
      "plot-nees", "Draw the pose NEES of Monte Carlo runs (one filter, logs differing only in their seed) averaged "
                   "over the runs, with the 95% interval of the mean");
  std::vector<std::string> nees_dirs;
  std::string nees_out, nees_title = "Pose NEES over Monte Carlo runs";
  nees_cmd->add_option("dirs", nees_dirs, "Run folders written by 'slamkit run'")->required();
  nees_cmd->add_option("--out", nees_out, "SVG file to write")->required();
  nees_cmd->add_option("--title", nees_title, "Figure title")->capture_default_str();

  // ---- plot-bench ----
  auto* bench_cmd =
      app.add_subcommand("plot-bench", "Plot benchmark results (Google Benchmark JSON) against map size and particles");
  std::vector<std::string> bench_json;
  std::string bench_out;
  bench_cmd->add_option("json", bench_json, "Files written by slamkit_bench --benchmark_out (later ones override)")
      ->required();
  bench_cmd->add_option("--out", bench_out, "Folder for the SVG plots")->required();

  cli::CampaignCommands campaign_commands;
  cli::add_campaign_commands(app, campaign_commands);

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
    const CLI::App* cmd = parsed.empty() ? nullptr : parsed.front();
    const std::string help = cmd == nullptr ? "slamkit --help" : "slamkit " + cmd->get_name() + " --help";
    std::cerr << "slamkit: error: " << usage_message(e, app, cmd, argc, argv) << " (see '" << help << "')\n";
    return kExitUsage;
  }
  const auto usage_error = [&](const std::string& message) {
    const auto parsed = app.get_subcommands();
    std::cerr << "slamkit: error: " << message << " (see 'slamkit " << parsed.front()->get_name() << " --help')\n";
    return kExitUsage;
  };
  const auto bad_input = [](const std::exception& e) {
    std::cerr << "slamkit: error: " << e.what() << "\n";
    return kExitBadInput;
  };

  // The filter settings as a whole, layered and checked by the library (make_filter repeats the
  // check), before any data is read. A repeated run takes them from its run.json, checked the same way.
  const Verbosity verbosity = quiet ? Verbosity::kQuiet : verbose ? Verbosity::kVerbose : Verbosity::kNormal;
  RunSpec spec;
  const FilterConfig& filter = spec.filter;
  if (*run_cmd) {
    try {
      if (!repeat_path.empty()) {
        spec = run_spec_from_run_json(read_json_file(repeat_path), repeat_path);
      } else {
        if (data_spec.empty()) return usage_error("--data is required (or --config with an earlier run.json)");
        SettingsSources sources;
        if (!assoc_config_path.empty()) {
          sources.association = read_json_file(assoc_config_path);
          sources.association_source = assoc_config_path;
        }
        sources.explicit_settings = flag_settings;
        spec = make_run_spec(data_spec, data_config, std::move(sources));
      }
      spec.history = history;
    } catch (const std::invalid_argument& e) {
      return usage_error(e.what());
    } catch (const InputError& e) {  // a settings file or run.json that cannot be read or is wrong
      return bad_input(e);
    }
    data_spec = spec.dataset;
    if (run_out.empty() && !print_config) return usage_error("--out is required");
    if (replay && history != History::kFull)
      return usage_error("--replay records every scan; it needs --history full");
  }

  try {
    if (*simulate_cmd && !building_name.empty()) {
      BuildingSimConfig config =
          config_path.empty() ? BuildingSimConfig{}
                              : building_sim_config_from_json(read_json_file(config_path), config_path);
      config.seed = sim_seed;
      if (simulate_cmd->count("--loops")) config.loops = loops;
      const FloorPlan plan = floor_plan(building_name);
      const Dataset log = simulate_building(plan, config);
      std::filesystem::create_directories(sim_out);
      const std::string log_path = (std::filesystem::path(sim_out) / (plan.name + ".log")).string();
      write_carmen(log_path, log);
      std::size_t scans = 0;
      for (const Event& e : log.events) scans += std::holds_alternative<RangeScanEvent>(e);
      fmt::print("simulated {} walls, {} controls, {} laser scans ({:.0f} s) -> {}\n", plan.walls.size(),
                 log.events.size() - scans, scans, log.truth.poses.empty() ? 0.0 : log.truth.poses.back().t, log_path);
    } else if (*simulate_cmd) {
      const Scenario base = family_name.empty() ? scenario(scenario_name) : world_family(family_name).member(world_seed);
      const World world = world_path.empty() ? base.world : read_world(world_path);
      SimulatorConfig config =
          config_path.empty() ? base.config : simulator_config_from_json(read_json_file(config_path), config_path);
      // The base settings were checked as they were read, so a setting out of range now is the flag's.
      const auto flag = [&](const char* name, auto apply) {
        if (simulate_cmd->count(name) == 0) return;
        apply(config);
        validate(config, name);
      };
      if (simulate_cmd->count("--seed") || config_path.empty()) config.seed = sim_seed;
      try {
        flag("--loops", [&](SimulatorConfig& c) { c.loops = loops; });
        flag("--clutter", [&](SimulatorConfig& c) { c.clutter_rate = clutter; });
        flag("--detection-prob", [&](SimulatorConfig& c) { c.detection_probability = detection; });
        flag("--sensor", [&](SimulatorConfig& c) { c.sensor = parse_sensor_kind(sensor_name); });
      } catch (const InputError& e) {
        return usage_error(e.what());
      }
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
      World world;
      WorldGenReport report;
      try {  // every input is an option, so an error is a usage error
        if (!world_scenario.empty())
          world = scenario(world_scenario).world;
        else if (!family_name.empty())
          world = world_family(family_name).member(world_seed).world;
        else
          world = generate_world(gen, &report);
      } catch (const InputError& e) {
        return usage_error(e.what());
      }
      write_world(world_out, world);
      const bool closer = family_name.empty() && world_scenario.empty() && report.spacing < gen.min_spacing;
      fmt::print("wrote {} ({} landmarks{})\n", world_out, world.landmarks.size(),
                 closer ? fmt::format(", {:.3g} m apart at least: the band cannot hold them {} m apart", report.spacing,
                                      gen.min_spacing)
                        : "");
    } else if (*run_cmd) {
      const auto warn = [&](const std::string& message) { std::cerr << "slamkit: warning: " << message << "\n"; };
      const bool particle_filter = filter.filter == FilterKind::kFastSlam1 || filter.filter == FilterKind::kFastSlam2 ||
                                   filter.filter == FilterKind::kGridFastSlam;
      for (const char* name : {"--particles", "--resample", "--resample-when"})
        if (!particle_filter && run_cmd->count(name) > 0) warn(fmt::format("{} is ignored by the EKF and the UKF", name));
      if (filter.filter != FilterKind::kFastSlam2 && run_cmd->count("--pose-sample-fraction") > 0)
        warn(fmt::format("--pose-sample-fraction applies to fastslam2 only; {} ignores it", to_string(filter.filter)));
      if ((filter.filter == FilterKind::kUkf || filter.filter == FilterKind::kEif || filter.filter == FilterKind::kSeif ||
           filter.filter == FilterKind::kEseif || filter.filter == FilterKind::kTjtf) &&
          run_cmd->count("--threads") > 0)
        warn(fmt::format("--threads is ignored by the {}", to_string(filter.filter)));
      if (filter.filter != FilterKind::kUkf && run_cmd->count("--ukf-noise") > 0)
        warn(fmt::format("--ukf-noise applies to ukf only; {} ignores it", to_string(filter.filter)));
      for (const char* name : {"--ekf-update", "--ekf-variant"})
        if (particle_filter && run_cmd->count(name) > 0) warn(fmt::format("{} is ignored by FastSLAM", name));
      if (!particle_filter && run_cmd->count("--seed") > 0)
        warn(fmt::format("--seed is ignored by the {} filter, which draws no random numbers", to_string(filter.filter)));

      nlohmann::json provenance = {{"command_line", std::vector<std::string>(argv, argv + argc)},
                                   {"working_directory", fs::current_path().string()}};
      if (print_config) {
        provenance.update({{"slamkit_version", version()},
                           {"dataset", absolute_dataset_spec(spec.dataset)},
                           {"dataset_as_given", spec.dataset},
                           {"dataset_settings", spec.dataset_settings_path},
                           {"dataset_settings_contents", spec.dataset_settings},
                           {"settings", to_json(filter)}});
        if (!spec.recommendation.is_null()) provenance["recommended_settings"] = spec.recommendation;
        fmt::print("{}\n", provenance.dump(2));
        return 0;
      }
      const auto stage_start = std::chrono::steady_clock::now();
      ExecuteOptions options;
      options.provenance = std::move(provenance);
      options.catch_stop_signals = true;
      options.replay = replay;
      if (verbosity == Verbosity::kVerbose) {
        fmt::print(stderr, "settings: {}\n", to_json(filter).dump());
        options.on_stage = [&](std::string_view what) {
          fmt::print(stderr, "{}: {:.2f} s\n", what,
                     std::chrono::duration<double>(std::chrono::steady_clock::now() - stage_start).count());
        };
      }
      if (verbosity != Verbosity::kQuiet && repeat_path.empty() && !spec.recommendation.is_null())
        fmt::print(stderr, "slamkit: {}'s recommended settings for {}: {} (from {}; a flag overrides each)\n",
                   data_spec.substr(0, data_spec.find(':')), to_string(filter.filter),
                   settings_in_words(spec.recommendation.at("applied")),
                   spec.recommendation.at("source").get<std::string>());
      ProgressLine progress;
      if (verbosity != Verbosity::kQuiet && isatty(STDERR_FILENO)) options.observers.push_back(&progress);
      const RunRecord record = execute(spec, run_out, options);
      progress.finish();
      const RunResult& run = record.run;
      if (run.diverged_at_s)
        warn(fmt::format("the filter diverged: {} after the event at t = {} s; writing the result up to its last "
                         "estimate before it (t = {:.1f} s) to {}",
                         run.divergence, *run.diverged_at_s, run.filtered.back().t, run_out));
      else if (run.partial)
        warn(fmt::format("stopped by {}: writing the partial result (up to t = {:.1f} s) to {}",
                         signal_name(record.stop_signal), run.filtered.back().t, run_out));
      warn_if_lost(record.metrics);
      print_outputs(run_out, record.metrics, verbosity);
      if (replay && verbosity != Verbosity::kQuiet)
        fmt::print("replay: {}\n", (fs::path(run_out) / "replay.html").string());
      if (run.diverged_at_s) return kExitDiverged;
      if (run.partial) return exit_code_for_signal(record.stop_signal);
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
    } else if (*campaign_commands.campaign) {
      return cli::run_campaign_command(campaign_commands);
    } else if (*campaign_commands.report) {
      try {
        return cli::run_report_command(campaign_commands);
      } catch (const std::invalid_argument& e) {  // a misspelt --metrics key
        return usage_error(e.what());
      }
    } else if (*nees_cmd) {
      std::vector<Metrics> runs;
      for (const std::string& dir : nees_dirs) {
        const RunResult run = read_run(dir);
        runs.push_back(evaluate_run(run, load_dataset(run.dataset, run.dataset_settings).truth));
      }
      write_monte_carlo_nees(nees_out, runs, nees_title);
      fmt::print("wrote {} ({} runs)\n", nees_out, runs.size());
    } else if (*replay_cmd) {
      const fs::path recording = fs::path(replay_dir) / "replay.json";
      if (!fs::is_directory(replay_dir))
        throw InputError(replay_dir, 0, "no such folder; expected a run folder recorded with 'slamkit run --replay'");
      if (!fs::exists(recording))
        throw InputError(recording.string(), 0, "missing; record the run with 'slamkit run --replay'");
      const FolderLock lock(replay_dir);
      const std::string page = (fs::path(replay_dir) / "replay.html").string();
      plot::write_replay_html(page, read_json_file(recording.string()));
      fmt::print("wrote {}\n", page);
    } else if (*eval_cmd) {
      if (eval_cmd->count("--max-time-difference") > 0 && eval_options.time_matching != TimeMatching::kEvo)
        return usage_error("--max-time-difference applies to --match evo");
      require_run_folder(eval_dir);  // before the lock, which would create a missing folder's parent
      const FolderLock lock(eval_dir);
      const RunResult run = read_run(eval_dir);
      remove_stale_temporaries(eval_dir);  // a run folder's writers all take its lock: these are the killed ones
      // A run.json that records the settings' contents is evaluated with them, wherever the file went.
      const Dataset dataset =
          run.provenance.contains("dataset_settings_contents")
              ? load_dataset(run.dataset, run.provenance.at("dataset_settings_contents"), run.dataset_settings)
              : load_dataset(run.dataset, run.dataset_settings);
      const Metrics metrics = write_evaluation(eval_dir, run, dataset, eval_options);
      warn_if_lost(metrics);
      print_outputs(eval_dir, metrics, Verbosity::kNormal);
    }
  } catch (const std::bad_alloc&) {
    return out_of_memory();
  } catch (const std::exception& e) {  // InputError above all: a missing or malformed file
    return bad_input(e);
  }
  return 0;
}

}  // namespace

// What escapes a command's own handlers (reading the settings, say) still ends in one line and a
// non-zero exit, never in std::terminate.
int main(int argc, char** argv) {
  try {
    return run_command(argc, argv);
  } catch (const std::bad_alloc&) {
    return out_of_memory();
  } catch (const std::exception& e) {
    std::cerr << "slamkit: error: " << e.what() << "\n";
    return kExitBadInput;
  }
}
