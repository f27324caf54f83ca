#include "slamkit/plot/benchmark_plots.hpp"

#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>

#include "slamkit/core/error.hpp"
#include "slamkit/core/input_file.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/plot/svg_plot.hpp"

namespace slamkit::plot {

namespace {

struct Series {
  const char* label;
  const char* pattern;  // a benchmark's name without its aggregate suffix; group 1 is the x value
};

struct Plot {
  const char* file;
  const char* title;
  const char* x_label;
  std::vector<Series> series;
  // x drawn as its logarithm, for x values over decades: Figure's x axis is linear only.
  bool log_x = false;
};

// The benchmark names are those of bench/*.cpp.
const std::vector<Plot>& plots() {
  static const std::vector<Plot> all = {
      {"ekf_vs_landmarks.svg",
       "EKF-SLAM: cost against the map",
       "landmarks",
       {{"observation update (one landmark)", R"(BM_EkfObservationUpdate/(\d+))"},
        {"scan of 15 observations, joint", R"(BM_EkfScanUpdate/(\d+))"},
        {"full EKF step (8 predictions + scan)", R"(BM_EkfStep/compressed:0/landmarks:(\d+))"},
        {"compressed EKF step", R"(BM_EkfStep/compressed:1/landmarks:(\d+))"},
        {"compressed EKF flush", R"(BM_CompressedEkfFlush/(\d+))"},
        {"time update (one control)", R"(BM_EkfTimeUpdate/(\d+))"}}},
      {"fastslam_vs_particles.svg",
       "FastSLAM: one step against the particles (100 landmarks, one thread)",
       "particles",
       {{"FastSLAM 1.0", R"(BM_StepVsParticles/1/(\d+))"}, {"FastSLAM 2.0", R"(BM_StepVsParticles/2/(\d+))"}}},
      {"fastslam_vs_landmarks.svg",
       "FastSLAM 2.0: one step against the map (100 particles)",
       "landmarks",
       {{"known identities", R"(BM_StepVsLandmarks/0/(\d+))"},
        {"nearest neighbour", R"(BM_StepVsLandmarks/1/(\d+))"},
        {"resampling, shared maps", R"(BM_ResampleMaps/1/100/(\d+))"}}},
      {"association_vs_landmarks.svg",
       "Data association: one scan (16 observations) against the map",
       "landmarks",
       {{"nearest neighbour", R"(BM_AssociationNearestNeighbour/(\d+))"},
        {"JCBB", R"(BM_AssociationJcbb/(\d+))"}}},
      {"information_vs_landmarks.svg",
       "One SLAM step (8 predictions, a scan of ~10 known landmarks) against the map",
       "landmarks",
       {{"SEIF (known-identity gate on)", R"(BM_InformationStep/seif/(\d+))"},
        {"EIF", R"(BM_InformationStep/eif/(\d+))"},
        {"full EKF", R"(BM_InformationStep/ekf/(\d+))"},
        {"SEIF, gate off: its own step", R"(BM_InformationStep/seif_ungated/(\d+))"},
        {"ESEIF, gate off: its own step", R"(BM_InformationStep/eseif_ungated/(\d+))"},
        {"TJTF, gate off: its own step", R"(BM_InformationStep/tjtf_ungated/(\d+))"}},
       true},
  };
  return all;
}

double seconds_per_unit(const std::string& unit, const std::string& path) {
  if (unit == "ns") return 1e-9;
  if (unit == "us") return 1e-6;
  if (unit == "ms") return 1e-3;
  if (unit == "s") return 1.0;
  throw InputError(path, 0, fmt::format("expected a time_unit of ns, us, ms or s, found '{}'", unit));
}

// Benchmark name (aggregate suffix removed) -> CPU time [s]: medians where the file has them.
std::map<std::string, double> read_times(const std::string& path) {
  const std::string text = read_input_file(path);
  // Google Benchmark writes NaN and inf bare (e.g. the coefficient of variation of a counter that is
  // always 0), which JSON does not allow; no time is ever one of them, so they are read as null.
  static const std::regex non_finite(R"(:\s*-?(NaN|nan|inf|Infinity)\b)");
  nlohmann::json json = parse_json(std::regex_replace(text, non_finite, ": null"), path);
  if (!json.is_object() || !json.contains("benchmarks") || !json["benchmarks"].is_array())
    throw InputError(path, 0, "expected Google Benchmark JSON output (an object with a 'benchmarks' array)");
  std::map<std::string, double> medians, singles;
  for (const auto& b : json["benchmarks"]) {
    if (!b.is_object() || !b.contains("run_name") || !b.contains("cpu_time") || !b.contains("time_unit") ||
        !b["cpu_time"].is_number())
      continue;  // complexity fits and the like carry no time of one run
    const std::string name = b["run_name"].get<std::string>();
    const double t = b["cpu_time"].get<double>() * seconds_per_unit(b["time_unit"].get<std::string>(), path);
    const std::string type = b.value("run_type", "iteration");
    if (type == "aggregate" && b.value("aggregate_name", "") == "median") medians[name] = t;
    if (type == "iteration") singles[name] = t;
  }
  for (const auto& [name, t] : singles) medians.try_emplace(name, t);
  return medians;
}

}  // namespace

std::vector<std::string> write_benchmark_plots(const std::vector<std::string>& json_paths, const std::string& out_dir) {
  std::map<std::string, double> times;
  for (const std::string& path : json_paths)
    for (const auto& [name, t] : read_times(path)) times[name] = t;  // later files override earlier ones
  std::filesystem::create_directories(out_dir);
  std::vector<std::string> written;
  for (const Plot& plot : plots()) {
    Figure fig(900, 560);
    fig.set_title(plot.title);
    fig.set_subtitle("Google Benchmark, CPU time per operation; medians of the repetitions where run with them");
    fig.set_x_label(plot.log_x ? fmt::format("log\u2081\u2080 {} (2: 100, 3: 1,000, 4: 10,000)", plot.x_label)
                               : std::string(plot.x_label));
    fig.set_y_label("time per operation [s]");
    fig.set_log_y(true);
    std::size_t drawn = 0;
    for (std::size_t i = 0; i < plot.series.size(); ++i) {
      const std::regex pattern(plot.series[i].pattern);
      std::map<double, double> points;
      for (const auto& [name, t] : times) {
        std::smatch m;
        if (std::regex_match(name, m, pattern)) points[std::stod(m[1].str())] = t;
      }
      if (points.empty()) continue;
      std::vector<Vector2> xy;
      for (const auto& [x, t] : points) xy.emplace_back(plot.log_x ? std::log10(x) : x, t);
      const Color color = categorical_color(i);
      fig.add_line(xy, LineStyle{color, 1.5}, plot.series[i].label);
      fig.add_markers(xy, MarkerStyle{Marker::kCircle, color, 6.0});
      ++drawn;
    }
    if (drawn == 0) continue;
    const std::string file = (std::filesystem::path(out_dir) / plot.file).string();
    fig.save(file);
    written.push_back(file);
  }
  return written;
}

}  // namespace slamkit::plot
