#include "slamkit/plot/report.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <new>
#include <numbers>
#include <stdexcept>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/chi_square.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/grid/grid_snapshot.hpp"
#include "slamkit/grid/map_files.hpp"
#include "slamkit/plot/information_matrix_svg.hpp"
#include "slamkit/plot/svg_plot.hpp"

namespace slamkit {

namespace {

/// Sets the picture's focus to the box of the grid's occupied cells, bar the outermost hundredth
/// along each axis: a long beam through a window marks a lone cell tens of metres from the walls.
/// No occupied cell: the whole grid is shown.
void frame_occupied_cells(const GridMap& grid, plot::MapPlotData& map) {
  std::vector<int> columns, rows;
  for (int j = 0; j < grid.height; ++j)
    for (int i = 0; i < grid.width; ++i) {
      const std::size_t cell = grid.index(i, j);
      if (grid.observed[cell] == 0 || grid.log_odds[cell] <= 0.0f) continue;
      columns.push_back(i);
      rows.push_back(j);
    }
  if (columns.empty()) return;
  const auto quantile = [](std::vector<int>& v, double q) {
    const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + k, v.end());
    return v[static_cast<std::size_t>(k)];
  };
  map.grid_focus_min = grid.origin + grid.resolution * Vector2(quantile(columns, 0.01), quantile(rows, 0.01));
  map.grid_focus_max =
      grid.origin + grid.resolution * Vector2(quantile(columns, 0.99) + 1, quantile(rows, 0.99) + 1);
}

std::vector<Vector2> positions(const std::vector<StampedPose>& poses, const eval::Se2Transform& align) {
  std::vector<Vector2> out;
  out.reserve(poses.size());
  for (const auto& p : poses) out.push_back(align.apply(Vector2(p.pose.head<2>())));
  return out;
}

std::string filter_title(const std::string& filter) {
  if (filter == "ekf") return "EKF-SLAM";
  if (filter == "ukf") return "UKF-SLAM";
  if (filter == "eif") return "EIF-SLAM";
  if (filter == "seif") return "SEIF-SLAM";
  if (filter == "eseif") return "ESEIF-SLAM";
  if (filter == "tjtf") return "TJTF-SLAM";
  if (filter == "fastslam1") return "FastSLAM 1.0";
  if (filter == "fastslam2") return "FastSLAM 2.0";
  if (filter == "scan-matching") return "Scan matching";
  if (filter == "grid-fastslam") return "Grid FastSLAM";
  return filter;
}

/// The headline's " | "-separated parts, wrapped into lines short enough for the figure's width.
std::string wrap_headline(const std::string& headline) {
  constexpr std::size_t kMaxLine = 100;
  std::string out, line;
  std::size_t start = 0;
  while (start <= headline.size()) {
    const std::size_t bar = headline.find(" | ", start);
    const std::string part = headline.substr(start, bar == std::string::npos ? std::string::npos : bar - start);
    if (!line.empty() && line.size() + 3 + part.size() > kMaxLine) {
      out += line + "\n";
      line.clear();
    }
    line += (line.empty() ? "" : " | ") + part;
    if (bar == std::string::npos) break;
    start = bar + 3;
  }
  return out + line;
}

/// `text` broken at spaces into lines of at most `width` characters (a longer word alone on its line).
std::string wrap_words(std::string_view text, std::size_t width) {
  std::string out, line;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t space = std::min(text.find(' ', start), text.size());
    const std::string_view word = text.substr(start, space - start);
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      out += line + "\n";
      line.clear();
    }
    if (!line.empty()) line += ' ';
    line += word;
    start = space + 1;
  }
  return out + line;
}

/// pose_error.svg: the per-step estimate's error against the truth over time, x and y in one panel
/// and the heading (wrapped, in degrees) in another under it, each with the filter's own +-2 sigma
/// bounds; a consistent filter keeps its error inside them about 95% of the time. Unaligned, like
/// pose NEES, so only for a truth in the map's frame (one with headings).
void write_pose_error_plot(const std::string& path, const RunResult& run, const GroundTruth& truth,
                           const std::string& title) {
  const std::vector<eval::PosePair> pairs = eval::match_by_time(run.filtered, truth.poses, 1.0);
  std::filesystem::remove(path);
  if (pairs.empty() || run.pose_covariances.size() != run.filtered.size()) return;
  // A few thousand points draw the same curve as a hundred thousand.
  const std::size_t step = std::max<std::size_t>(1, pairs.size() / 3000);
  constexpr double kDegrees = 180.0 / std::numbers::pi;
  std::vector<Vector2> error_x, error_y, error_heading, upper_x, lower_x, upper_y, lower_y, upper_heading,
      lower_heading;
  for (std::size_t i = 0; i < pairs.size(); i += step) {
    const eval::PosePair& p = pairs[i];
    const Matrix3& cov = run.pose_covariances[static_cast<std::size_t>(p.estimate_index)];
    const auto two_sigma = [&](int k) { return 2.0 * std::sqrt(std::max(0.0, cov(k, k))); };
    error_x.emplace_back(p.t, p.estimate.x() - p.truth.x());
    error_y.emplace_back(p.t, p.estimate.y() - p.truth.y());
    error_heading.emplace_back(p.t, kDegrees * wrap_angle(p.estimate.z() - p.truth.z()));
    upper_x.emplace_back(p.t, two_sigma(0));
    lower_x.emplace_back(p.t, -two_sigma(0));
    upper_y.emplace_back(p.t, two_sigma(1));
    lower_y.emplace_back(p.t, -two_sigma(1));
    upper_heading.emplace_back(p.t, kDegrees * two_sigma(2));
    lower_heading.emplace_back(p.t, -kDegrees * two_sigma(2));
  }
  plot::Figure position(900, 460), heading(900, 300);
  position.set_title("Pose error over time: " + title);
  position.set_subtitle("estimate minus truth, with the filter's own 2-sigma bounds (unaligned, like pose NEES)");
  position.set_y_label("position error [m]");
  heading.set_x_label("time [s]");
  heading.set_y_label("heading error [deg]");
  // One time axis for both panels, even where a series has no finite point.
  if (pairs.back().t > pairs.front().t)
    for (plot::Figure* panel : {&position, &heading}) panel->set_x_limits(pairs.front().t, pairs.back().t);
  const auto add = [](plot::Figure& panel, const std::vector<Vector2>& error, const std::vector<Vector2>& upper,
                      const std::vector<Vector2>& lower, plot::Color color, const std::string& name) {
    const plot::LineStyle bound{color, 1.0, plot::Dash::kDashed};
    panel.add_line(upper, bound, name + ": +-2 sigma");
    panel.add_line(lower, bound);
    panel.add_line(error, {color, 1.2}, name + " error");
  };
  add(position, error_x, upper_x, lower_x, plot::palette::kBlue, "x");
  add(position, error_y, upper_y, lower_y, plot::palette::kGreen, "y");
  add(heading, error_heading, upper_heading, lower_heading, plot::palette::kVermillion, "heading");
  write_file_atomically(path, plot::stacked_svg({position, heading}));
}

/// Runs `draw`, which writes the figure `path`: a failure names the figure, so that an error after a
/// whole run says what could not be done (a write error names its file already).
template <class Draw>
void draw_figure(const std::string& path, Draw&& draw) {
  try {
    draw();
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("{}: cannot draw the figure: {}", path, e.what()));
  }
}

}  // namespace

void write_run_plots(const std::string& dir, const RunResult& run, const GroundTruth& truth,
                     const Metrics& metrics) {
  namespace fs = std::filesystem;
  const std::string title = filter_title(run.filter) + " on " + run.dataset;
  const std::string subtitle = wrap_headline(headline(metrics));

  plot::MapPlotData map;
  map.title = title;
  map.subtitle = subtitle;
  // Without truth there is nothing to align to: the estimate is drawn in its own frame. Nor is a grid
  // map's: the picture is drawn in the map's frame, which the truth shares through the start pose.
  const bool aligned = metrics.ate_rmse_m.has_value() && run.grid.empty();
  const eval::Se2Transform align = aligned ? metrics.alignment : eval::Se2Transform{};
  map.estimated_trajectory = positions(run.trajectory, align);
  map.dead_reckoning = positions(run.dead_reckoning, aligned ? metrics.dead_reckoning_alignment : align);
  map.true_trajectory = positions(truth.poses, eval::Se2Transform{});
  if (!truth.poses_have_heading) std::swap(map.true_trajectory, map.reference_points);
  map.true_landmarks = truth.landmarks;
  const Matrix2 rotation = Eigen::Rotation2Dd(align.theta).toRotationMatrix();
  for (Landmark lm : run.map) {
    lm.position = align.apply(lm.position);
    lm.covariance = rotation * lm.covariance * rotation.transpose();
    map.estimated_landmarks.push_back(lm);
  }
  if (!run.grid.empty()) {
    const GridImage image = grid_png(from_grid_map(run.grid));
    map.grid_png = image.png;
    map.grid_lower_left = Vector2(image.origin_x, image.origin_y);
    map.grid_size = Vector2(image.width_m, image.height_m);
    frame_occupied_cells(run.grid, map);
  }
  const std::string map_path = (fs::path(dir) / "map.svg").string();
  draw_figure(map_path, [&] {
    plot::Figure figure = plot::map_figure(map);
    if (!run.particles.empty()) {
      // The clouds, thinned to at most ~100 particles per sample time so the map stays readable.
      std::vector<Vector2> cloud;
      std::size_t per_time = 0;
      double t = -1.0;
      for (const ParticleSample& s : run.particles) {
        per_time = s.t == t ? per_time + 1 : 0;
        t = s.t;
        if (per_time < 100) cloud.push_back(align.apply(Vector2(s.particle.pose.head<2>())));
      }
      plot::MarkerStyle style;
      style.color = plot::palette::kPurple;
      style.size = 2.0;
      style.opacity = 0.35;
      figure.add_markers(cloud, style, "particles (every second)");
    }
    figure.save(map_path);
  });

  plot::StdPlotData std_plot;
  std_plot.title = "Landmark uncertainty over time: " + title;
  std_plot.subtitle = "standard deviation of each landmark's position estimate (cf. tutorial Figure 3)";
  std::map<int, std::size_t> series_of_id;
  for (const auto& s : run.landmark_std) {
    auto [it, inserted] = series_of_id.try_emplace(s.id, std_plot.series.size());
    if (inserted) std_plot.series.push_back(plot::StdSeries{s.id, {}, {}, {}});
    auto& series = std_plot.series[it->second];
    series.t.push_back(s.t);
    series.std_x.push_back(s.std_x);
    series.std_y.push_back(s.std_y);
  }
  const std::string std_path = (fs::path(dir) / "landmark_std.svg").string();
  if (run.grid.empty())
    draw_figure(std_path, [&] { plot::write_landmark_std_svg(std_path, std_plot); });
  else
    fs::remove(std_path);

  if (metrics.nees_pose && !metrics.nees_pose_series.empty()) {
    plot::NeesPlotData nees;
    nees.title = "Pose NEES over time: " + title;
    nees.subtitle = fmt::format("mean {:.3g}, {:.0f}% of steps inside the 95% interval", metrics.nees_pose->mean,
                                100.0 * metrics.nees_pose->in_interval_fraction);
    if (pose_nees_of_particle_cloud(run.filter))
      nees.subtitle += "\n" + wrap_words(fmt::format("For {} this is {}.", filter_title(run.filter), kParticleCloudNeesNote), 120);
    nees.nees = metrics.nees_pose_series;
    nees.band_lo = metrics.nees_pose->interval.lo;
    nees.band_hi = metrics.nees_pose->interval.hi;
    const std::string nees_path = (fs::path(dir) / "nees.svg").string();
    draw_figure(nees_path, [&] { plot::nees_figure(nees).save(nees_path); });
  }

  const std::string information_path = (fs::path(dir) / "information.svg").string();
  if (!run.information.empty())
    draw_figure(information_path, [&] { write_information_matrix_svg(information_path, run.information); });
  else
    fs::remove(information_path);

  const std::string pose_error_path = (fs::path(dir) / "pose_error.svg").string();
  if (truth.poses_have_heading)
    draw_figure(pose_error_path, [&] { write_pose_error_plot(pose_error_path, run, truth, title); });
  else
    fs::remove(pose_error_path);
}

void write_monte_carlo_nees(const std::string& path, const std::vector<Metrics>& runs, const std::string& title) {
  if (runs.empty()) throw std::invalid_argument("Monte Carlo NEES: no runs");
  // Runs of one world step at the same times, but need not have a NEES at each (a start pose known
  // exactly has none; a log may end a step earlier): the times all runs have are averaged.
  std::map<long long, std::pair<Vector2, std::size_t>> by_time;  // microseconds -> (t, sum), runs
  for (std::size_t r = 0; r < runs.size(); ++r) {
    if (runs[r].nees_pose_series.empty())
      throw std::invalid_argument(fmt::format("Monte Carlo NEES: run {} has no pose NEES", r + 1));
    for (const Vector2& p : runs[r].nees_pose_series) {
      auto& [sum, count] = by_time.try_emplace(std::llround(p.x() * 1e6), Vector2::Zero(), 0).first->second;
      sum = Vector2(p.x(), sum.y() + p.y());
      ++count;
    }
  }
  std::vector<Vector2> mean;
  for (const auto& [key, entry] : by_time)
    if (entry.second == runs.size()) mean.emplace_back(entry.first.x(), entry.first.y() / static_cast<double>(runs.size()));
  if (mean.empty()) throw std::invalid_argument("Monte Carlo NEES: the runs have no step time in common");
  const int n = static_cast<int>(runs.size());
  const eval::Interval band = eval::averaged_nees_interval(0.95, 3, n);
  std::size_t inside = 0;
  double total = 0.0;
  for (const Vector2& p : mean) {
    inside += band.contains(p.y());
    total += p.y();
  }
  plot::NeesPlotData data;
  data.title = title;
  data.subtitle = fmt::format("{} runs: mean NEES {:.2f}, {:.0f}% of steps inside the 95% interval of the {}-run mean",
                              n, total / static_cast<double>(mean.size()),
                              100.0 * static_cast<double>(inside) / static_cast<double>(mean.size()), n);
  data.nees = std::move(mean);
  data.band_lo = band.lo;
  data.band_hi = band.hi;
  data.runs = n;
  plot::nees_figure(data).save(path);
}

}  // namespace slamkit
