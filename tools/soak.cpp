// Soak test: one long run on a simulated log with the runner keeping no history, reporting the step
// rate and the memory as it goes, so that a slowdown or a leak over 10^5..10^6 steps shows. `make
// soak` runs it for the EKF and FastSLAM; see docs/testing.md.
//
//   slamkit_soak --filter ekf --steps 1000000 [--particles 100] [--history none] [--reports 10]
//
// The log is the default scenario's world driven lap after lap (made before the run, so its memory is
// in the first figure); every report covers the steps since the previous one.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <string>

#include "slamkit/core/error.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"

using namespace slamkit;

namespace {

/// A figure of /proc/self/status in MiB: "VmRSS" (resident now) or "VmHWM" (peak resident).
double status_mib(const std::string& key) {
  std::ifstream in("/proc/self/status");
  std::string name;
  double kib = 0.0;
  while (in >> name) {
    if (name == key + ":" && in >> kib) return kib / 1024.0;
    in.ignore(1 << 20, '\n');
  }
  return NAN;
}

/// Prints a line every `every` steps: steps done, their rate since the last line, memory.
class SoakReport : public RunObserver {
 public:
  SoakReport(std::size_t total_steps, std::size_t reports) : every_(std::max<std::size_t>(1, total_steps / reports)) {
    fmt::print("{:>10} {:>10} {:>12} {:>10} {:>10} {:>10}\n", "steps", "time [s]", "steps/s", "RSS [MiB]",
               "peak [MiB]", "landmarks");
  }
  void on_step(const SlamFilter& filter) {
    if (++steps_ % every_ != 0) return;
    const auto now = std::chrono::steady_clock::now();
    const double window = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    const double rate = static_cast<double>(every_) / window;
    if (first_rate_ == 0.0) first_rate_ = rate;
    last_rate_ = rate;
    const double rss = status_mib("VmRSS");
    if (first_rss_ == 0.0) first_rss_ = rss;
    fmt::print("{:>10} {:>10.1f} {:>12.0f} {:>10.1f} {:>10.1f} {:>10}\n", steps_,
               std::chrono::duration<double>(now - start_).count(), rate, rss, status_mib("VmHWM"),
               filter.num_landmarks());
    std::fflush(stdout);
  }
  void on_scan(const SlamFilter&, const ScanEvent&, std::size_t, std::size_t) override {}
  double first_rate() const { return first_rate_; }
  double last_rate() const { return last_rate_; }
  double first_rss() const { return first_rss_; }

 private:
  std::size_t every_;
  std::size_t steps_ = 0;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point last_ = start_;
  double first_rate_ = 0.0, last_rate_ = 0.0, first_rss_ = 0.0;
};

/// Passes every call to the filter, and tells the report of each step.
class ReportingFilter : public SlamFilter {
 public:
  ReportingFilter(SlamFilter& filter, SoakReport& report) : filter_(filter), report_(report) {}
  std::string name() const override { return filter_.name(); }
  void predict(const ControlEvent& control) override {
    filter_.predict(control);
    report_.on_step(filter_);
  }
  void update(const ScanEvent& scan) override { filter_.update(scan); }
  Pose2 pose() const override { return filter_.pose(); }
  Matrix3 pose_covariance() const override { return filter_.pose_covariance(); }
  std::size_t num_landmarks() const override { return filter_.num_landmarks(); }
  std::vector<Landmark> landmarks() const override { return filter_.landmarks(); }
  const std::vector<AssociationRecord>& last_associations() const override { return filter_.last_associations(); }
  std::vector<StampedPose> smoothed_trajectory() const override { return filter_.smoothed_trajectory(); }
  void forget_smoothed_trajectory() override { filter_.forget_smoothed_trajectory(); }
  std::vector<WeightedPose> pose_samples() const override { return filter_.pose_samples(); }
  std::map<std::string, double> statistics() const override { return filter_.statistics(); }

 private:
  SlamFilter& filter_;
  SoakReport& report_;
};

/// The default scenario driven for `steps` control steps: enough laps, then cut at the last step.
Dataset long_log(std::size_t steps) {
  Scenario s = scenario("default");
  s.config.loops = 1;
  const Dataset lap = simulate(s.world, s.config);
  const auto per_lap = static_cast<std::size_t>(std::count_if(
      lap.events.begin(), lap.events.end(), [](const Event& e) { return std::holds_alternative<ControlEvent>(e); }));
  s.config.loops = static_cast<int>(steps / per_lap + 1);
  Dataset log = simulate(s.world, s.config);
  std::size_t controls = 0, end = 0;
  while (end < log.events.size() && controls < steps) controls += std::holds_alternative<ControlEvent>(log.events[end++]);
  log.events.resize(end);
  log.truth = {};
  return log;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"slamkit soak test: a long run with bounded history, its step rate and memory as it goes"};
  FilterConfig config;
  std::size_t steps = 1'000'000, reports = 10;
  std::string filter_name = "ekf", history_name = "none";
  app.add_option("--filter", filter_name, "ekf, ukf, fastslam1 or fastslam2")->capture_default_str();
  app.add_option("--steps", steps, "Control steps")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--particles", config.particles, "FastSLAM: particles")->capture_default_str();
  app.add_option("--history", history_name, "full, decimated or none")->capture_default_str();
  app.add_option("--reports", reports, "Lines of figures over the run")->capture_default_str()->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  try {
    config.filter = parse_filter_kind(filter_name);
    RunOptions options;
    options.history = parse_history(history_name);
    const Dataset log = long_log(steps);
    fmt::print("{} on {} control steps of the default scenario, history {}; RSS with the log in memory: {:.1f} MiB\n",
               filter_name, steps, history_name, status_mib("VmRSS"));
    const auto filter = make_filter(config, log);
    SoakReport report(steps, reports);
    ReportingFilter reporting(*filter, report);
    const RunResult run = run_filter(reporting, log, options);
    fmt::print("{} steps, {} scans in {:.1f} s; steps/s {:.0f} in the first report, {:.0f} in the last; RSS {:.1f} "
               "MiB at the first report, {:.1f} MiB at the end, peak {:.1f} MiB\n",
               run.steps, run.scans, run.wall_time_s, report.first_rate(), report.last_rate(), report.first_rss(),
               status_mib("VmRSS"), status_mib("VmHWM"));
  } catch (const std::exception& e) {
    std::cerr << "slamkit_soak: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
