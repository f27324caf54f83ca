#include "slamkit/campaign/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <new>
#include <numeric>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>

#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/atomic_folder.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/eval/metrics.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/run_io.hpp"

namespace slamkit::campaign {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// ---- Student's t --------------------------------------------------------------------------------

/// The continued fraction of the regularised incomplete beta function (Lentz's method), which
/// converges quickly for x < (a + 1) / (a + b + 2).
double beta_continued_fraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  const auto guard = [](double v) { return std::abs(v) < kTiny ? kTiny : v; };
  double c = 1.0, d = 1.0 / guard(1.0 - (a + b) * x / (a + 1.0));
  double h = d;
  const auto step = [&](double coefficient) {
    d = 1.0 / guard(1.0 + coefficient * d);
    c = guard(1.0 + coefficient / c);
    h *= d * c;
  };
  for (int m = 1; m <= 10000 && std::abs(d * c - 1.0) >= 1e-16; ++m) {
    const double m2 = 2.0 * m;
    step(m * (b - m) * x / ((a + m2 - 1.0) * (a + m2)));
    step(-(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0)));
  }
  return h;
}

double regularised_incomplete_beta(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double front =
      std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x));
  if (x < (a + 1.0) / (a + b + 2.0)) return front * beta_continued_fraction(a, b, x) / a;
  return 1.0 - front * beta_continued_fraction(b, a, 1.0 - x) / b;
}

/// The t >= 0 with P(T > t) = tail, 0 < tail < 0.5, by bisection (the tail falls monotonically).
/// Tails near 0.5 go through the central probability P(|T| < t) = 1 - 2 tail instead: the upper
/// tail's beta function reads t through 1 - t^2 / dof, which loses a small t to cancellation.
double student_t_for_tail(double tail, double dof) {
  const bool central = tail > 0.25;
  const double target = central ? 1.0 - 2.0 * tail : tail;
  const auto below_quantile = [&](double t) {
    return central ? regularised_incomplete_beta(0.5, dof / 2.0, t * t / (dof + t * t)) < target
                   : 0.5 * regularised_incomplete_beta(dof / 2.0, 0.5, dof / (dof + t * t)) > target;
  };
  double lo = 0.0, hi = 1.0;
  while (below_quantile(hi)) {
    lo = hi;
    hi *= 2.0;
  }
  // 200 halvings reach a double's precision from any bracket [0, 2^k].
  for (int i = 0; i < 200 && hi - lo > 1e-15 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (below_quantile(mid) ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// ---- finding and reading run folders --------------------------------------------------------------

/// The key that sorts numbers in names by value, so that seed-2 comes before seed-10: every run of
/// digits padded with zeros to 20 places.
std::string natural_key(const std::string& name) {
  std::string key;
  for (std::size_t i = 0; i < name.size();) {
    const std::size_t digits = std::min(name.find_first_not_of("0123456789", i), name.size()) - i;
    key += digits == 0 ? name.substr(i, 1) : std::string(digits < 20 ? 20 - digits : 0, '0') + name.substr(i, digits);
    i += std::max<std::size_t>(digits, 1);
  }
  return key;
}

/// A whole run: a staging folder holds INCOMPLETE, and a folder a killed writer moved aside
/// (`<run>.old-<pid>`) is a copy of one that its next writer puts back.
bool is_run_folder(const fs::path& dir) {
  return fs::is_regular_file(dir / "run.json") && fs::is_regular_file(dir / "metrics.json") &&
         !fs::exists(dir / kIncompleteMarker) && stem_of_name_with_pid(dir.filename().string(), ".old-").empty();
}

std::vector<std::string> find_run_folders(const std::vector<std::string>& paths) {
  std::vector<fs::path> found;
  for (const std::string& path : paths) {
    if (!fs::exists(path)) throw InputError(path, 0, "no such file or folder; expected run folders");
    const std::size_t before = found.size();
    if (is_run_folder(path)) {
      found.emplace_back(path);
    } else if (fs::is_directory(path)) {
      for (auto it = fs::recursive_directory_iterator(path, fs::directory_options::skip_permission_denied);
           it != fs::recursive_directory_iterator(); ++it)
        if (it->is_directory() && is_run_folder(it->path())) {
          found.push_back(it->path());
          it.disable_recursion_pending();
        }
    }
    if (found.size() == before)
      throw InputError(path, 0,
                       "holds no run folder (a folder with run.json and metrics.json, as 'slamkit run' writes)");
  }
  std::vector<std::pair<std::string, fs::path>> keyed;  // equal keys (seed-02, seed-2) ordered by their text
  for (const fs::path& dir : found) keyed.emplace_back(natural_key(dir.generic_string()), dir);
  std::sort(keyed.begin(), keyed.end());
  std::set<fs::path> seen;
  std::vector<std::string> folders;
  for (const auto& entry : keyed)
    if (seen.insert(fs::weakly_canonical(entry.second)).second) folders.push_back(entry.second.string());
  return folders;
}

json read_json_object(const fs::path& file, const char* what) {
  json j = read_json_file(file.string());
  if (!j.is_object()) throw InputError(file.string(), 0, fmt::format("expected {} as a JSON object", what));
  return j;
}

/// run.json as far as the report reads it; InputError naming the file for anything else.
json read_run_json(const fs::path& file, ReportRun& run) {
  json j = read_json_object(file, "a run description");
  const auto expect = [&](bool ok, const char* key, const char* expected) {
    if (!ok) throw InputError(file.string(), 0, fmt::format("expected '{}' to be {}", key, expected));
  };
  expect(j.contains("filter") && j["filter"].is_string(), "filter", "the filter's name");
  expect(j.contains("dataset") && j["dataset"].is_string(), "dataset", "a dataset spec");
  expect(j.value("partial", json(false)).is_boolean(), "partial", "true or false");
  expect(j.value("dataset_settings", json("")).is_string(), "dataset_settings", "a file name");
  const json diverged = j.value("diverged_at_s", json(nullptr));
  expect(diverged.is_null() || diverged.is_number(), "diverged_at_s", "a time or null");
  const json campaign = j.value("campaign", json::object());
  expect(campaign.is_object() && campaign.value("configuration", json("")).is_string(), "campaign",
         "an object with the configuration's name");
  run.filter = j["filter"].get<std::string>();
  run.dataset = j["dataset"].get<std::string>();
  run.partial = j.value("partial", false);
  run.campaign_job = j.value("campaign", json(nullptr));
  if (diverged.is_number()) run.diverged_at_s = diverged.get<double>();
  return j;
}

// ---- configurations -------------------------------------------------------------------------------

json without_seeds(json j) {
  if (j.is_object()) {
    j.erase("seed");
    for (auto& item : j.items()) item.value() = without_seeds(item.value());
  }
  return j;
}

void flatten_json(const json& j, const std::string& prefix, std::map<std::string, std::string>& out) {
  if (j.is_object() && !j.empty()) {
    for (const auto& item : j.items())
      flatten_json(item.value(), prefix.empty() ? item.key() : prefix + "." + item.key(), out);
  } else {
    out[prefix] = j.is_string() ? j.get<std::string>() : j.dump();
  }
}

/// What tells a run's group apart, and the name shown for its part of it.
struct GroupPart {
  std::string name;
  json details;
};

/// The dataset without its seeds: a simulator log by its parameters (its folder is one per seed), a
/// simulated spec without its last number, a real log by its spec, shown by the folder's last name.
GroupPart dataset_part(const json& run_json) {
  const std::string spec = run_json.at("dataset").get<std::string>();
  const std::size_t colon = spec.find(':');
  const std::string kind = spec.substr(0, colon), rest = colon == std::string::npos ? "" : spec.substr(colon + 1);
  const bool simulator_log = kind == "sim" && run_json.value("simulator", json()).is_object();
  json details = simulator_log ? without_seeds(run_json.at("simulator")) : json::object();
  details["settings"] = run_json.value("dataset_settings_contents", json(nullptr));
  if (simulator_log) return {"sim", details};
  const auto parts = static_cast<std::size_t>(std::count(rest.begin(), rest.end(), ':')) + 1;
  const std::size_t seeded_parts = kind == "family" ? 3 : kind == "scenario" || kind == "building" ? 2 : 0;
  if (seeded_parts != 0) return {parts == seeded_parts ? spec.substr(0, spec.rfind(':')) : spec, details};
  details["spec"] = spec;
  const fs::path folder = fs::path(rest).lexically_normal();
  const std::string last =
      folder.has_filename() ? folder.filename().string() : folder.parent_path().filename().string();
  return {kind + ":" + last, details};
}

/// For each part, its name and the `key=value` pairs of the details that differ between the parts of
/// the same name: what a reader needs to tell them apart, and no more.
std::vector<std::string> distinguishing_labels(const std::vector<GroupPart>& parts, const std::string& ignored_key) {
  std::vector<std::map<std::string, std::string>> flat(parts.size());
  for (std::size_t i = 0; i < parts.size(); ++i) {
    flatten_json(parts[i].details, "", flat[i]);
    flat[i].erase(ignored_key);
  }
  std::vector<std::string> labels;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    std::set<std::string> keys;
    for (std::size_t j = 0; j < parts.size(); ++j)
      if (parts[j].name == parts[i].name)
        for (const auto& entry : flat[j]) keys.insert(entry.first);
    std::string label = parts[i].name;
    for (const std::string& key : keys) {
      const auto value_in = [&](std::size_t j) {
        const auto it = flat[j].find(key);
        return it == flat[j].end() ? std::string("-") : it->second;
      };
      bool differs = false;
      for (std::size_t j = 0; j < parts.size(); ++j)
        differs |= parts[j].name == parts[i].name && value_in(j) != value_in(i);
      if (differs) label += fmt::format(" {}={}", key, value_in(i));
    }
    labels.push_back(std::move(label));
  }
  return labels;
}

/// Longer labels than this do not fit a table column or a legend: they fall back to "ekf #2".
constexpr std::size_t kMaxLabelLength = 80;

std::string unique_label(const std::string& name, const std::set<std::string>& used, const char* separator) {
  std::string candidate = name;
  for (int k = 2; used.count(candidate) != 0; ++k) candidate = fmt::format("{}{}{}", name, separator, k);
  return candidate;
}

std::string slug_of(const std::string& label) {
  std::string slug;
  for (const char c : label) {
    if (std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.')
      slug += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    else if (!slug.empty() && slug.back() != '-')
      slug += '-';
    if (slug.size() >= 48) break;
  }
  while (!slug.empty() && (slug.back() == '-' || slug.back() == '.')) slug.pop_back();
  return slug.empty() ? "configuration" : slug;
}

/// Groups the runs (campaign label, else filter settings and dataset without seeds) and labels the groups.
void group_runs(Report& report, const std::vector<json>& run_jsons) {
  std::vector<GroupPart> filter_parts, dataset_parts;  // of the derived groups
  std::vector<bool> derived;
  std::map<std::string, std::size_t> by_key;
  for (std::size_t r = 0; r < report.runs.size(); ++r) {
    const json& j = run_jsons[r];
    const std::string label = j.value("campaign", json::object()).value("configuration", "");
    GroupPart filter{report.runs[r].filter, without_seeds(j.value("settings", json(nullptr)))};
    GroupPart dataset = dataset_part(j);
    const json key =
        label.empty()
            ? json{{"settings", filter.details}, {"dataset", dataset.name}, {"dataset_details", dataset.details}}
            : json{{"campaign", label}};
    const auto [it, fresh] = by_key.try_emplace(key.dump(), report.configurations.size());
    if (fresh) {
      ReportConfiguration c;
      c.label = label;
      c.key = key;
      if (const std::size_t bar = label.find(" | "); bar != std::string::npos) {
        c.filter_entry = label.substr(0, bar);
        c.dataset_entry = label.substr(bar + 3);
      } else {
        c.filter_entry = label;
      }
      report.configurations.push_back(std::move(c));
      derived.push_back(label.empty());
      if (label.empty()) {
        filter_parts.push_back(std::move(filter));
        dataset_parts.push_back(std::move(dataset));
      }
    }
    report.runs[r].configuration_index = it->second;
    report.configurations[it->second].runs.push_back(r);
  }
  const std::vector<std::string> filter_labels = distinguishing_labels(filter_parts, "filter");
  const std::vector<std::string> dataset_labels = distinguishing_labels(dataset_parts, "");
  std::set<std::string> datasets;
  for (const GroupPart& p : dataset_parts) datasets.insert(p.name + p.details.dump());
  std::vector<std::string> labels;
  for (std::size_t d = 0; d < filter_parts.size(); ++d)
    labels.push_back(filter_labels[d] + (datasets.size() > 1 ? " | " + dataset_labels[d] : ""));
  const auto shared = [&labels](const std::string& label) {
    return std::count(labels.begin(), labels.end(), label) > 1;
  };
  std::set<std::string> used;
  for (std::size_t c = 0; c < report.configurations.size(); ++c)
    if (!derived[c]) used.insert(report.configurations[c].label);
  std::map<std::string, int> ordinal;  // derived groups so far, by filter
  for (std::size_t c = 0, d = 0; c < report.configurations.size(); ++c) {
    ReportConfiguration& config = report.configurations[c];
    if (derived[c]) {
      config.filter_entry = filter_labels[d];
      config.dataset_entry = dataset_labels[d];
      const int k = ++ordinal[filter_parts[d].name];
      const bool fits = labels[d].size() <= kMaxLabelLength && used.count(labels[d]) == 0 && !shared(labels[d]);
      config.label = unique_label(fits ? labels[d] : fmt::format("{} #{}", filter_parts[d].name, k), used, " #");
      ++d;
    }
    used.insert(config.label);
  }
  std::set<std::string> slugs;
  for (ReportConfiguration& config : report.configurations) {
    config.slug = unique_label(slug_of(config.label), slugs, "-");
    slugs.insert(config.slug);
    for (const std::size_t r : config.runs) {
      report.runs[r].configuration = config.label;
      config.partial += report.runs[r].partial;
      config.diverged += report.runs[r].diverged_at_s.has_value();
    }
  }
}

// ---- summaries ------------------------------------------------------------------------------------

}  // namespace

MetricSummary summarize_metric(const std::string& metric, const Report& report, const std::vector<std::size_t>& runs) {
  MetricSummary s;
  s.metric = metric;
  std::vector<double> values;  // the finite ones
  for (const std::size_t r : runs) {
    const auto it = report.runs[r].metrics.find(metric);
    if (it == report.runs[r].metrics.end()) continue;
    if (it->is_boolean()) {
      ++s.yes_no;
      s.yes += it->get<bool>();
    } else if (it->is_number() && std::isfinite(it->get<double>())) {
      values.push_back(it->get<double>());
    }
  }
  s.n = values.size();
  if (values.empty()) return s;
  s.zeros = static_cast<std::size_t>(std::count(values.begin(), values.end(), 0.0));
  std::sort(values.begin(), values.end());
  s.min = values.front();
  s.max = values.back();
  s.median = 0.5 * (values[(s.n - 1) / 2] + values[s.n / 2]);
  s.sum = std::accumulate(values.begin(), values.end(), 0.0);
  s.mean = s.sum / static_cast<double>(s.n);
  if (s.n >= 2) {
    double squares = 0.0;
    for (const double v : values) squares += (v - s.mean) * (v - s.mean);
    const double half = student_t_quantile(0.975, static_cast<double>(s.n - 1)) *
                        std::sqrt(squares / static_cast<double>(s.n - 1) / static_cast<double>(s.n));
    s.ci95 = eval::Interval{s.mean - half, s.mean + half};
  }
  return s;
}

namespace {

// ---- the N-run NEES test ------------------------------------------------------------------------------

/// Why a configuration's runs cannot take the test before any data is loaded; empty if they can.
std::string nees_obstacle(const Report& report, const ReportConfiguration& config) {
  if (config.runs.size() < 2) return "one run: the N-run test needs two or more (see the run's own nees.svg)";
  for (const std::size_t r : config.runs) {
    const ReportRun& run = report.runs[r];
    if (pose_nees_of_particle_cloud(run.filter))
      return fmt::format("{}'s pose NEES is its particle cloud's, no consistency test (metrics.json's nees_pose_note)",
                         run.filter);
    if (!run.metrics.contains("nees_pose_mean") || !run.metrics["nees_pose_mean"].is_number())
      return fmt::format("{} has no pose NEES (a truth without headings, or a run that kept no history)", run.dir);
    if (!fs::exists(fs::path(run.dir) / "pose_covariance.txt"))
      return fmt::format("{} keeps its metrics only, no trajectory to evaluate again", run.dir);
  }
  return {};
}

struct NeesStep {
  double t = 0.0, sum = 0.0;
  std::size_t runs = 0;
};

/// The message of an error `f` throws, empty if none: a dataset or run that cannot be evaluated
/// again fails its configuration's NEES test, not the report. Running out of memory is no such error.
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    return e.what();
  }
  return {};
}

Dataset load_dataset_of(const json& run_json, const std::string& dir) {
  const std::string spec = run_json.at("dataset").get<std::string>();
  const std::string settings = run_json.value("dataset_settings", "");
  if (const auto it = run_json.find("dataset_settings_contents"); it != run_json.end())
    return load_dataset(spec, *it, (fs::path(dir) / "run.json (dataset_settings_contents)").string());
  return load_dataset(spec, settings);
}

/// Each distinct dataset (spec and settings) loaded once, for all the runs on it, and let go before
/// the next: a report over many real logs holds one at a time.
void run_nees_tests(Report& report, const std::vector<json>& run_jsons) {
  std::vector<std::map<long long, NeesStep>> steps(report.configurations.size());
  std::vector<std::string> order;
  std::map<std::string, std::vector<std::size_t>> runs_by_dataset;
  for (ReportConfiguration& config : report.configurations) {
    config.nees.skipped = nees_obstacle(report, config);
    if (!config.nees.skipped.empty()) continue;
    for (const std::size_t r : config.runs) {
      const json& j = run_jsons[r];
      const std::string key = j.at("dataset").dump() + j.value("dataset_settings", json("")).dump() +
                              j.value("dataset_settings_contents", json("none")).dump();
      auto [it, fresh] = runs_by_dataset.try_emplace(key);
      if (fresh) order.push_back(key);
      it->second.push_back(r);
    }
  }
  for (const std::string& key : order) {
    std::optional<Dataset> dataset;
    std::string load_error;
    for (const std::size_t r : runs_by_dataset[key]) {
      const ReportRun& run = report.runs[r];
      NeesTest& test = report.configurations[run.configuration_index].nees;
      if (!test.skipped.empty()) continue;
      if (!dataset && load_error.empty())
        load_error = error_of([&] { dataset = load_dataset_of(run_jsons[r], run.dir); });
      if (!dataset) {
        test.skipped = "its dataset no longer loads: " + load_error;
        continue;
      }
      const std::string error = error_of([&] {
        const Metrics metrics = evaluate_run(read_run(run.dir), dataset->truth);
        if (metrics.nees_pose_series.empty()) throw std::invalid_argument("no pose NEES series");
        for (const Vector2& p : metrics.nees_pose_series) {
          NeesStep& step = steps[run.configuration_index][std::llround(p.x() * 1e6)];
          step.t = p.x();
          step.sum += p.y();
          ++step.runs;
        }
      });
      if (!error.empty()) test.skipped = fmt::format("{} cannot be evaluated again: {}", run.dir, error);
    }
  }
  for (std::size_t c = 0; c < report.configurations.size(); ++c) {
    NeesTest& test = report.configurations[c].nees;
    if (!test.skipped.empty()) continue;
    test.runs = report.configurations[c].runs.size();
    const double n = static_cast<double>(test.runs);
    test.band = eval::averaged_nees_interval(0.95, 3, static_cast<int>(test.runs));
    double total = 0.0;
    std::size_t inside = 0;
    for (const auto& entry : steps[c]) {
      const NeesStep& step = entry.second;
      if (step.runs != test.runs) continue;  // a time not every run has (an earlier end, a known start)
      test.averaged.emplace_back(step.t, step.sum / n);
      total += step.sum / n;
      inside += test.band.contains(step.sum / n);
    }
    test.steps = test.averaged.size();
    if (test.steps == 0) {
      test.skipped = "the runs have no step time in common";
      continue;
    }
    test.mean = total / static_cast<double>(test.steps);
    test.inside_fraction = static_cast<double>(inside) / static_cast<double>(test.steps);
  }
}

}  // namespace

std::vector<std::string> default_report_metrics() {
  return {"ate_rmse_m", "final_position_error_m",       "nees_pose_mean",     "nees_pose_in_95_fraction",
          "map_rmse_m", "relative_translation_error_m", "spurious_landmarks", "wall_time_s",
          "loop_closed"};
}

double student_t_quantile(double p, double dof) {
  if (!(p > 0.0 && p < 1.0)) throw std::invalid_argument(fmt::format("student_t_quantile: p = {} outside (0, 1)", p));
  if (!(dof > 0.0) || std::isinf(dof))
    throw std::invalid_argument(fmt::format("student_t_quantile: dof = {} must be positive and finite", dof));
  if (p == 0.5) return 0.0;
  // The smaller tail as given: 1 - p is exact for p >= 0.5, p itself carries its own digits.
  const double t = student_t_for_tail(p < 0.5 ? p : 1.0 - p, dof);
  return p < 0.5 ? -t : t;
}

Report collect_report(const std::vector<std::string>& paths, const ReportOptions& options) {
  Report report;
  report.paths = paths;
  report.metrics = options.metrics;
  report.runs_per_picture = options.runs_per_picture;
  std::vector<json> run_jsons;
  for (const std::string& dir : find_run_folders(paths)) {
    ReportRun run;
    run.dir = dir;
    run_jsons.push_back(read_run_json(fs::path(dir) / "run.json", run));
    run.metrics = read_json_object(fs::path(dir) / "metrics.json", "a run's metrics");
    report.runs.push_back(std::move(run));
  }
  group_runs(report, run_jsons);
  for (ReportConfiguration& config : report.configurations) {
    for (const std::string& metric : report.metrics) config.metrics.push_back(summarize_metric(metric, report, config.runs));
    if (!options.nees_test) config.nees.skipped = "not asked for";
  }
  if (options.nees_test) run_nees_tests(report, run_jsons);
  return report;
}

}  // namespace slamkit::campaign
