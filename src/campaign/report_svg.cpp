// Writing a report (campaign/report.hpp): its pictures (ATE per configuration as box plots, the runs'
// position errors and trajectories, each configuration's averaged NEES), and the page and tables
// that show them and the numbers (report.md, summary.csv, runs.csv, report.json). report.cpp
// collects what they show.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "slamkit/campaign/report.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/atomic_folder.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/eval/metrics.hpp"
#include "slamkit/io/trajectory_io.hpp"
#include "slamkit/plot/svg_plot.hpp"

namespace slamkit::campaign {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// A configuration's colour and, past the palette's colours, a dash pattern of its own, so that up to
/// four times as many configurations as colours stay apart.
plot::LineStyle configuration_style(std::size_t c, double width) {
  constexpr std::array kDashes = {plot::Dash::kSolid, plot::Dash::kDashed, plot::Dash::kDotted, plot::Dash::kDashDot};
  return {plot::categorical_color(c), width, kDashes[(c / plot::kCategoricalColors) % kDashes.size()], 0.85};
}

/// A legend entry short enough to leave the plot its room; a label cut short starts with the
/// configuration's number in report.md, which keeps the entries apart.
std::string legend_label(std::size_t c, const std::string& label) {
  constexpr std::size_t kLongest = 40;
  return label.size() <= kLongest ? label : fmt::format("{}: {}...", c + 1, label.substr(0, kLongest - 8));
}

std::vector<double> finite_values(const Report& report, const ReportConfiguration& config, const char* metric) {
  std::vector<double> values;
  for (const std::size_t r : config.runs) {
    const json& metrics = report.runs[r].metrics;
    if (const auto it = metrics.find(metric);
        it != metrics.end() && it->is_number() && std::isfinite(it->get<double>()))
      values.push_back(it->get<double>());
  }
  std::sort(values.begin(), values.end());
  return values;
}

/// The q-quantile of sorted values, interpolated between neighbours (Hyndman and Fan's type 7, the
/// default of R and numpy).
double sorted_quantile(const std::vector<double>& sorted, double q) {
  const double at = q * static_cast<double>(sorted.size() - 1);
  const auto i = static_cast<std::size_t>(at);
  return i + 1 < sorted.size() ? sorted[i] + (at - static_cast<double>(i)) * (sorted[i + 1] - sorted[i]) : sorted[i];
}

/// Horizontal boxes, configuration #n of report.md at y = n (the axis' ticks are its numbers), each
/// labelled above it: a long label reads across the plot, where under a vertical box it would not fit.
bool write_ate_boxplot(const Report& report, const fs::path& file) {
  const double k = static_cast<double>(report.configurations.size());
  plot::Figure figure(1000, std::clamp(170.0 + 70.0 * k, 330.0, 2000.0));
  figure.set_title("ATE per configuration");
  figure.set_subtitle("box: quartiles; whiskers: the runs within 1.5 IQR of the box; beyond them, outliers");
  figure.set_x_label("ATE RMSE [m]");
  figure.set_y_label("configuration (# in report.md)");
  const plot::LineStyle box{plot::palette::kBlue, 1.5};
  const plot::LineStyle median{plot::palette::kDark, 2.5};
  const plot::MarkerStyle outlier{plot::Marker::kCross, plot::palette::kVermillion, 7.0};
  const plot::MarkerStyle mean{plot::Marker::kCircle, plot::palette::kDark, 6.0, 1.2, false};
  double lo = 0.0, hi = 0.0;
  bool any = false;
  for (std::size_t c = 0; c < report.configurations.size(); ++c) {
    const ReportConfiguration& config = report.configurations[c];
    const std::vector<double> v = finite_values(report, config, "ate_rmse_m");
    const double y = static_cast<double>(c + 1);
    const std::string label =
        fmt::format("#{}: {} ({} of {} runs with an ATE)", c + 1, config.label, v.size(), config.runs.size());
    figure.add_text({0.0, y + 0.3}, label);
    if (v.empty()) continue;
    any = true;
    lo = std::min(lo, v.front());
    hi = std::max(hi, v.back());
    const double q1 = sorted_quantile(v, 0.25), q2 = sorted_quantile(v, 0.5), q3 = sorted_quantile(v, 0.75);
    const double fence_lo = q1 - 1.5 * (q3 - q1), fence_hi = q3 + 1.5 * (q3 - q1);
    const double whisker_lo = *std::find_if(v.begin(), v.end(), [&](double x) { return x >= fence_lo; });
    const double whisker_hi = *std::find_if(v.rbegin(), v.rend(), [&](double x) { return x <= fence_hi; });
    const double h = 0.2;
    const std::vector<Vector2> outline = {{q1, y - h}, {q3, y - h}, {q3, y + h}, {q1, y + h}, {q1, y - h}};
    figure.add_line(outline, box);
    figure.add_line(std::vector<Vector2>{{whisker_lo, y}, {q1, y}}, box);
    figure.add_line(std::vector<Vector2>{{q3, y}, {whisker_hi, y}}, box);
    for (const double w : {whisker_lo, whisker_hi})
      figure.add_line(std::vector<Vector2>{{w, y - h / 2}, {w, y + h / 2}}, box);
    figure.add_line(std::vector<Vector2>{{q2, y - h}, {q2, y + h}}, median, "median");
    std::vector<Vector2> beyond;
    double sum = 0.0;
    for (const double x : v) {
      if (x < whisker_lo || x > whisker_hi) beyond.emplace_back(x, y);
      sum += x;
    }
    figure.add_markers(beyond, outlier, "outlier");
    figure.add_markers(std::vector<Vector2>{{sum / static_cast<double>(v.size()), y}}, mean, "mean");
  }
  if (!any) return false;
  figure.set_x_limits(lo, hi > lo ? hi + 0.05 * (hi - lo) : lo + 1.0);
  figure.set_y_limits(0.4, k + 0.8);
  write_file_atomically(file.string(), figure.to_svg());
  return true;
}

double alignment_value(const json& metrics, const char* key) {
  const json alignment = metrics.value("alignment", json::object());
  const auto it = alignment.find(key);
  return it != alignment.end() && it->is_number() ? it->get<double>() : 0.0;
}

struct RunPaths {
  std::vector<Vector2> estimate, truth;
  std::vector<Vector2> error;  // (t [s], position error [m])
};

/// The run's per-step estimate under the alignment its evaluation found (as ATE scores it), the truth,
/// and the position error between them; empty where the folder keeps no trajectories.
RunPaths read_run_paths(const ReportRun& run) {
  RunPaths paths;
  const fs::path dir(run.dir);
  const fs::path estimate_file = fs::exists(dir / "filtered.tum") ? dir / "filtered.tum" : dir / "trajectory.tum";
  if (!fs::exists(estimate_file) || !fs::exists(dir / "truth.tum")) return paths;
  const std::vector<StampedPose> estimate = read_tum(estimate_file.string());
  const std::vector<StampedPose> truth = read_tum((dir / "truth.tum").string());
  eval::Se2Transform align;
  align.theta = alignment_value(run.metrics, "theta_rad");
  align.translation = Vector2(alignment_value(run.metrics, "tx_m"), alignment_value(run.metrics, "ty_m"));
  for (const StampedPose& p : estimate) paths.estimate.push_back(align.apply(Vector2(p.pose.head<2>())));
  for (const StampedPose& p : truth) paths.truth.emplace_back(p.pose.head<2>());
  // Without an ATE the evaluation found no alignment, and an error in two frames would mean nothing.
  if (!run.metrics.value("ate_rmse_m", json(nullptr)).is_number()) return paths;
  for (const eval::PosePair& pair : eval::match_by_time(estimate, truth, EvaluationOptions{}.max_interpolation_gap_s))
    paths.error.emplace_back(pair.t,
                             (align.apply(Vector2(pair.estimate.head<2>())) - Vector2(pair.truth.head<2>())).norm());
  return paths;
}

/// trajectories.svg and errors.svg, drawn together so that each run's files are read once; returns
/// the names of those written (no errors.svg where no drawn run has an ATE, hence no alignment).
std::vector<std::string> write_run_pictures(const Report& report, const fs::path& dir) {
  const std::string subtitle = fmt::format(
      "one line per run, at most {} runs of each configuration, the estimates "
      "SE(2)-aligned onto the truth as ATE aligns them",
      report.runs_per_picture);
  plot::Figure errors(1100, 600), trajectories(1100, 800);
  errors.set_title("Position error over time");
  errors.set_subtitle(subtitle);
  errors.set_x_label("time [s]");
  errors.set_y_label("position error [m]");
  trajectories.set_title("Trajectories over the truth");
  trajectories.set_subtitle(subtitle);
  trajectories.set_x_label("x [m]");
  trajectories.set_y_label("y [m]");
  trajectories.set_equal_aspect(true);
  bool any_path = false, any_error = false;
  for (std::size_t c = 0; c < report.configurations.size(); ++c) {
    const ReportConfiguration& config = report.configurations[c];
    for (std::size_t i = 0; i < config.runs.size() && i < report.runs_per_picture; ++i) {
      const RunPaths paths = read_run_paths(report.runs[config.runs[i]]);
      any_path |= !paths.estimate.empty();
      any_error |= !paths.error.empty();
      trajectories.add_line(paths.truth, {plot::palette::kGrey, 1.0}, "truth");
      trajectories.add_line(paths.estimate, configuration_style(c, 1.2), legend_label(c, config.label));
      errors.add_line(paths.error, configuration_style(c, 1.2), legend_label(c, config.label));
    }
  }
  std::vector<std::string> names;
  if (any_path) {
    write_file_atomically((dir / "trajectories.svg").string(), trajectories.to_svg());
    names.emplace_back("trajectories.svg");
  }
  if (any_error) {
    write_file_atomically((dir / "errors.svg").string(), errors.to_svg());
    names.emplace_back("errors.svg");
  }
  return names;
}

/// Returns false, drawing nothing, where no step's average is finite (a run infinitely inconsistent
/// at every step): there is no curve to draw, and the report's table says so in numbers.
bool write_nees_picture(const ReportConfiguration& config, const fs::path& file) {
  const NeesTest& test = config.nees;
  if (std::none_of(test.averaged.begin(), test.averaged.end(), [](const Vector2& p) { return std::isfinite(p.y()); }))
    return false;
  plot::NeesPlotData data;
  data.title = "Averaged pose NEES: " + config.label;
  data.subtitle = fmt::format("{} runs: mean {:.2f}, {:.0f}% of {} steps inside the 95% interval of the {}-run mean",
                              test.runs, test.mean, 100.0 * test.inside_fraction, test.steps, test.runs);
  data.nees = test.averaged;
  data.band_lo = test.band.lo;
  data.band_hi = test.band.hi;
  data.runs = static_cast<int>(test.runs);
  write_file_atomically(file.string(), plot::nees_figure(data).to_svg());
  return true;
}

// ---- the files ----------------------------------------------------------------------------------

/// Four significant digits, without an exponent where that reads well; whole numbers as such.
std::string format_number(double v) {
  if (!std::isfinite(v)) return std::isnan(v) ? "nan" : v > 0 ? "inf" : "-inf";
  const double magnitude = std::abs(v);
  if (v == std::round(v) && magnitude < 1e9) return fmt::format("{:.0f}", v);
  if (magnitude >= 1e5 || magnitude < 1e-3) return fmt::format("{:.3e}", v);
  return fmt::format("{:.{}f}", v, std::clamp(3 - static_cast<int>(std::floor(std::log10(magnitude))), 0, 6));
}

/// JSON has no infinity: an infinite averaged NEES is written as the text "inf", not as a null that
/// would read as "not measured".
json json_number(double v) { return std::isfinite(v) ? json(v) : json(format_number(v)); }

std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

/// A metrics.json value in a CSV cell: full precision, empty where it was not measured.
std::string csv_value(const json& value) {
  if (value.is_number()) return std::isfinite(value.get<double>()) ? fmt::format("{}", value.get<double>()) : "";
  if (value.is_boolean()) return value.get<bool>() ? "true" : "false";
  return value.is_string() ? csv_field(value.get<std::string>()) : "";
}

std::string md_cell(const std::string& text) {
  std::string cell;
  for (const char c : text) cell += c == '|' ? std::string("\\|") : std::string(1, c);
  return cell;
}

const char* metric_title(const std::string& metric) {
  static const std::map<std::string, const char*> titles = {
      {"ate_rmse_m", "ATE RMSE [m]"},
      {"final_position_error_m", "Final position error [m]"},
      {"nees_pose_mean", "Mean pose NEES (3 if consistent)"},
      {"nees_pose_in_95_fraction", "Share of steps with the pose NEES inside its 95% interval"},
      {"map_rmse_m", "Map RMSE [m]"},
      {"relative_translation_error_m", "Relative translation error [m]"},
      {"spurious_landmarks", "Spurious landmarks"},
      {"wall_time_s", "Filter wall time [s]"},
      {"loop_closed", "Loop closed"}};
  const auto it = titles.find(metric);
  return it == titles.end() ? "" : it->second;
}

bool yes_no_metric(const MetricSummary& s) { return s.n == 0 && s.yes_no > 0; }

std::string summary_csv(const Report& report) {
  std::string out = "configuration,metric,n,mean,median,min,max,ci_low,ci_high\n";
  for (const ReportConfiguration& config : report.configurations)
    for (const MetricSummary& s : config.metrics) {
      out += csv_field(config.label) + "," + csv_field(s.metric) + ",";
      if (yes_no_metric(s))  // a true/false metric: its mean is the share of true
        out += fmt::format("{},{},,,,,\n", s.yes_no, static_cast<double>(s.yes) / static_cast<double>(s.yes_no));
      else if (s.n == 0)
        out += "0,,,,,,\n";
      else
        out += fmt::format("{},{},{},{},{},{},{}\n", s.n, s.mean, s.median, s.min, s.max,
                           s.ci95 ? fmt::format("{}", s.ci95->lo) : "", s.ci95 ? fmt::format("{}", s.ci95->hi) : "");
    }
  return out;
}

/// One row per entry of report.json's "runs", its fields then its metrics.
std::string runs_csv(const Report& report, const json& runs) {
  constexpr std::array kFields = {"dir", "configuration", "filter", "dataset", "partial", "diverged_at_s"};
  std::string out = fmt::format("{}", fmt::join(kFields, ","));
  for (const std::string& metric : report.metrics) out += fmt::format(",{}", csv_field(metric));
  for (const json& run : runs) {
    out += "\n";
    for (const char* field : kFields)
      out += fmt::format("{}{}", field == kFields[0] ? "" : ",", csv_value(run.at(field)));
    for (const std::string& metric : report.metrics) out += fmt::format(",{}", csv_value(run.at("metrics").at(metric)));
  }
  return out + "\n";
}

json report_json(const Report& report) {
  json configurations = json::array(), runs = json::array();
  for (const ReportConfiguration& config : report.configurations) {
    json c = {{"label", config.label},    {"slug", config.slug},       {"key", config.key},
              {"runs", json::array()},    {"partial", config.partial}, {"diverged", config.diverged},
              {"metrics", json::object()}};
    for (const std::size_t r : config.runs) c["runs"].push_back(report.runs[r].dir);
    for (const MetricSummary& s : config.metrics) {
      json m = {{"n", s.n}};
      if (s.n > 0)
        m.update({{"mean", s.mean},
                  {"median", s.median},
                  {"min", s.min},
                  {"max", s.max},
                  {"ci95", s.ci95 ? json::array({s.ci95->lo, s.ci95->hi}) : json(nullptr)}});
      if (s.yes_no > 0) m.update({{"true", s.yes}, {"true_or_false", s.yes_no}});
      c["metrics"][s.metric] = m;
    }
    const NeesTest& t = config.nees;
    c["nees_test"] = t.skipped.empty() ? json{{"runs", t.runs},
                                              {"steps", t.steps},
                                              {"mean", json_number(t.mean)},
                                              {"inside_fraction", t.inside_fraction},
                                              {"band", {t.band.lo, t.band.hi}}}
                                       : json{{"skipped", t.skipped}};
    configurations.push_back(std::move(c));
  }
  for (const ReportRun& run : report.runs) {
    json metrics = json::object();
    for (const std::string& metric : report.metrics) metrics[metric] = run.metrics.value(metric, json(nullptr));
    runs.push_back({{"dir", run.dir},
                    {"configuration", run.configuration},
                    {"filter", run.filter},
                    {"dataset", run.dataset},
                    {"partial", run.partial},
                    {"diverged_at_s", run.diverged_at_s ? json(*run.diverged_at_s) : json(nullptr)},
                    {"metrics", std::move(metrics)}});
  }
  return {{"paths", report.paths},
          {"metrics", report.metrics},
          {"configurations", std::move(configurations)},
          {"runs", std::move(runs)}};
}

void append_metric_table(std::string& md, const Report& report, std::size_t m) {
  const std::string& metric = report.metrics[m];
  const std::string title = metric_title(metric);
  md += fmt::format("\n## {}{}\n\n", title.empty() ? metric : title, title.empty() ? "" : " (`" + metric + "`)");
  bool yes_no = false, measured = false;
  for (const ReportConfiguration& config : report.configurations) {
    yes_no |= yes_no_metric(config.metrics[m]);
    measured |= config.metrics[m].n > 0 || config.metrics[m].yes_no > 0;
  }
  if (!measured) {
    md += "Not measured in any run.\n";
    return;
  }
  md += yes_no ? "| configuration | runs where true |\n|---|---:|\n"
               : "| configuration | runs | mean | median | min – max | 95% CI of the mean "
                 "|\n|---|---:|---:|---:|---:|---:|\n";
  for (const ReportConfiguration& config : report.configurations) {
    const MetricSummary& s = config.metrics[m];
    const std::string name = md_cell(config.label);
    if (yes_no) {
      md += s.yes_no == 0 ? fmt::format("| {} | not measured |\n", name)
                          : fmt::format("| {} | {} of {} |\n", name, s.yes, s.yes_no);
    } else if (s.n == 0) {
      md += fmt::format("| {} | 0 of {} | | | | |\n", name, config.runs.size());
    } else {
      const std::string runs =
          s.n == config.runs.size() ? fmt::format("{}", s.n) : fmt::format("{} of {}", s.n, config.runs.size());
      md += fmt::format("| {} | {} | {} | {} | {} – {} | {} |\n", name, runs, format_number(s.mean),
                        format_number(s.median), format_number(s.min), format_number(s.max),
                        s.ci95 ? fmt::format("[{}, {}]", format_number(s.ci95->lo), format_number(s.ci95->hi)) : "");
    }
  }
}

std::string report_md(const Report& report, const std::vector<std::string>& pictures) {
  std::string md =
      fmt::format("# Report: {} run{} in {} configuration{}\n\nRun folders found under: ", report.runs.size(),
                  report.runs.size() == 1 ? "" : "s", report.configurations.size(),
                  report.configurations.size() == 1 ? "" : "s");
  for (std::size_t i = 0; i < report.paths.size(); ++i)
    md += fmt::format("{}`{}`", i == 0 ? "" : ", ", report.paths[i]);
  md += ".\n\n| # | configuration | runs | partial | diverged |\n|---:|---|---:|---:|---:|\n";
  for (std::size_t c = 0; c < report.configurations.size(); ++c) {
    const ReportConfiguration& config = report.configurations[c];
    md += fmt::format("| {} | {} | {} | {} | {} |\n", c + 1, md_cell(config.label), config.runs.size(), config.partial,
                      config.diverged);
  }
  for (std::size_t m = 0; m < report.metrics.size(); ++m) append_metric_table(md, report, m);

  md +=
      "\n## Averaged pose NEES (N-run test)\n\nThe pose NEES averaged over a configuration's N runs step by step, at "
      "the step times every run has. A consistent filter's average lies inside the 95% interval of chi2(3N) / N at "
      "95% of the steps, and its mean is 3.\n\n";
  std::string skipped;
  bool tested = false;
  for (const ReportConfiguration& config : report.configurations) {
    const NeesTest& t = config.nees;
    if (!t.skipped.empty()) {
      skipped += fmt::format("- {}: {}\n", config.label, t.skipped);
      continue;
    }
    if (!tested)
      md +=
          "| configuration | runs | steps | mean | 95% interval | steps inside | picture |\n"
          "|---|---:|---:|---:|---:|---:|---|\n";
    tested = true;
    const std::string picture = "nees_" + config.slug + ".svg";
    const bool drawn = std::find(pictures.begin(), pictures.end(), picture) != pictures.end();
    md += fmt::format("| {} | {} | {} | {} | {} – {} | {:.1f}% | {} |\n", md_cell(config.label), t.runs, t.steps,
                      format_number(t.mean), format_number(t.band.lo), format_number(t.band.hi),
                      100.0 * t.inside_fraction, drawn ? fmt::format("[{}]({})", picture, picture) : "no finite step");
  }
  if (!skipped.empty()) md += (tested ? "\nNot tested:\n\n" : "Not tested:\n\n") + skipped;

  md += "\n## Runs that did not finish\n\n";
  bool failures = false;
  for (const ReportRun& run : report.runs) {
    if (run.diverged_at_s)
      md += fmt::format("- `{}` ({}): diverged at t = {} s\n", run.dir, run.configuration,
                        format_number(*run.diverged_at_s));
    else if (run.partial)
      md += fmt::format("- `{}` ({}): partial, stopped before the end of its data\n", run.dir, run.configuration);
    failures |= run.partial || run.diverged_at_s;
  }
  if (!failures) md += "None: every run ran to the end of its data.\n";

  md += "\n## Pictures\n\n";
  md += std::find(pictures.begin(), pictures.end(), "trajectories.svg") == pictures.end()
            ? std::string("No run folder keeps its trajectories: no errors.svg, no trajectories.svg.\n\n")
            : fmt::format(
                  "errors.svg and trajectories.svg draw at most {} runs of each configuration, of those "
                  "whose folders keep their trajectories.\n\n",
                  report.runs_per_picture);
  for (const std::string& picture : pictures)
    if (picture.rfind("nees_", 0) != 0) md += fmt::format("![{}]({})\n\n", picture, picture);
  return md;
}

}  // namespace

std::vector<std::string> write_report_pictures(const Report& report, const std::string& dir) {
  std::vector<std::string> names;
  if (write_ate_boxplot(report, fs::path(dir) / "ate_boxplot.svg")) names.emplace_back("ate_boxplot.svg");
  for (std::string& name : write_run_pictures(report, dir)) names.push_back(std::move(name));
  for (const ReportConfiguration& config : report.configurations) {
    const std::string name = "nees_" + config.slug + ".svg";
    if (config.nees.skipped.empty() && write_nees_picture(config, fs::path(dir) / name)) names.push_back(name);
  }
  return names;
}

std::vector<std::string> write_report(const Report& report, const std::string& out_dir) {
  AtomicFolder folder(out_dir, "report.md");
  const fs::path staging(folder.path());
  std::vector<std::string> names = write_report_pictures(report, folder.path());
  write_file_atomically((staging / "summary.csv").string(), summary_csv(report));
  const json contents = report_json(report);
  write_file_atomically((staging / "runs.csv").string(), runs_csv(report, contents["runs"]));
  write_file_atomically((staging / "report.json").string(), contents.dump(2) + "\n");
  write_file_atomically((staging / "report.md").string(), report_md(report, names));
  folder.commit();
  names.insert(names.begin(), {"report.md", "summary.csv", "runs.csv", "report.json"});
  std::vector<std::string> files;
  for (const std::string& name : names) files.push_back((fs::path(out_dir) / name).string());
  return files;
}

}  // namespace slamkit::campaign
