#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "slamkit/plot/svg_plot.hpp"
#include "svg_elements.hpp"

namespace slamkit::plot {

using svg::kNaN;

namespace {

/// Limits the map's view to the grid's focus and every trajectory, with a margin.
void frame_grid_focus(Figure& fig, const MapPlotData& data) {
  if (data.grid_png.empty() || !(data.grid_focus_max.array() > data.grid_focus_min.array()).all()) return;
  Vector2 lo = data.grid_focus_min, hi = data.grid_focus_max;
  for (const auto* path : {&data.true_trajectory, &data.estimated_trajectory, &data.dead_reckoning,
                           &data.reference_points})
    for (const Vector2& p : *path)
      if (p.allFinite()) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
  const double margin = std::max(1.0, 0.03 * (hi - lo).maxCoeff());
  fig.set_x_limits(lo.x() - margin, hi.x() + margin);
  fig.set_y_limits(lo.y() - margin, hi.y() + margin);
}

}  // namespace

Figure map_figure(const MapPlotData& data) {
  Figure fig(960, 800);
  fig.set_title(data.title);
  fig.set_subtitle(data.subtitle);
  fig.set_x_label("x [m]");
  fig.set_y_label("y [m]");
  fig.set_equal_aspect(true);

  // Drawing order, bottom to top: the grid map, reference data so the estimate stays visible over it, true
  // landmarks last because a thin '+' does not hide the estimate's dot under it.
  fig.add_image(data.grid_png, data.grid_lower_left, data.grid_size);
  fig.add_line(data.dead_reckoning, {palette::kGrey, 1.3, Dash::kDashed}, "dead reckoning");
  fig.add_markers(data.reference_points, {Marker::kCircle, palette::kGreen, 3.0, 1.0, true, 0.6},
                  "reference fixes");
  fig.add_line(data.true_trajectory, {palette::kDark, 1.6}, "true trajectory");
  fig.add_line(data.estimated_trajectory, {palette::kBlue, 1.6}, "estimated trajectory");
  const EllipseStyle ellipse{{palette::kVermillion, 0.9, Dash::kSolid, 0.8}, 0.08};
  const std::string ellipse_label = fmt::format("{:g}\u03C3 covariance", data.ellipse_sigma);
  std::vector<Vector2> estimated, truth;
  for (const Landmark& l : data.estimated_landmarks) {
    fig.add_ellipse(l.position, l.covariance, data.ellipse_sigma, ellipse, ellipse_label);
    estimated.push_back(l.position);
  }
  for (const Landmark& l : data.true_landmarks) truth.push_back(l.position);
  fig.add_markers(estimated, {Marker::kCircle, palette::kVermillion, 4.5}, "estimated landmarks");
  fig.add_markers(truth, {Marker::kPlus, palette::kBlack, 8.0, 1.3}, "true landmarks");
  frame_grid_focus(fig, data);
  return fig;
}

void write_map_svg(const std::string& path, const MapPlotData& data) { map_figure(data).save(path); }

Figure landmark_std_figure(const StdPlotData& data) {
  Figure fig(900, 560);
  fig.set_title(data.title);
  fig.set_subtitle(data.subtitle);
  fig.set_x_label("time [s]");
  fig.set_y_label("landmark standard deviation, max(\u03C3x, \u03C3y) [m]");
  fig.set_log_y(data.log_y);

  int lo = std::numeric_limits<int>::max(), hi = std::numeric_limits<int>::min();
  for (const StdSeries& s : data.series) {
    if (s.t.size() != s.std_x.size() || s.t.size() != s.std_y.size())
      throw std::invalid_argument(fmt::format("landmark {}: {} times but {} std_x and {} std_y values", s.id,
                                              s.t.size(), s.std_x.size(), s.std_y.size()));
    lo = std::min(lo, s.id);
    hi = std::max(hi, s.id);
  }
  // A few landmarks are told apart by name; many only as a trend, so colour encodes the id.
  const bool many = data.series.size() > kCategoricalColors;
  for (std::size_t i = 0; i < data.series.size(); ++i) {
    const StdSeries& s = data.series[i];
    std::vector<Vector2> pts;
    pts.reserve(s.t.size());
    for (std::size_t k = 0; k < s.t.size(); ++k) {
      const bool known = std::isfinite(s.std_x[k]) && std::isfinite(s.std_y[k]);
      pts.emplace_back(s.t[k], known ? std::max(s.std_x[k], s.std_y[k]) : kNaN);
    }
    if (many) {
      const double t = hi > lo ? static_cast<double>(s.id - lo) / (hi - lo) : 0.5;
      fig.add_line(pts, {sequential_color(t), 0.9, Dash::kSolid, 0.85});
    } else {
      fig.add_line(pts, {categorical_color(i), 1.5}, fmt::format("landmark {}", s.id));
    }
  }
  if (many) {
    fig.add_legend_entry("one line per landmark", LineStyle{sequential_color(0.5), 0.9});
    fig.set_colorbar("landmark id", lo, hi);
  }
  return fig;
}

void write_landmark_std_svg(const std::string& path, const StdPlotData& data) {
  landmark_std_figure(data).save(path);
}

Figure nees_figure(const NeesPlotData& data) {
  if (!(data.band_lo < data.band_hi)) throw std::invalid_argument("NEES plot: the band needs lo < hi");
  double t0 = std::numeric_limits<double>::infinity(), t1 = -t0;
  for (const Vector2& p : data.nees)
    if (p.allFinite()) {
      t0 = std::min(t0, p.x());
      t1 = std::max(t1, p.x());
    }
  if (!(t0 <= t1)) throw std::invalid_argument("NEES plot: no finite NEES value");
  Figure fig;
  fig.set_title(data.title);
  fig.set_subtitle(data.subtitle);
  fig.set_x_label("time [s]");
  fig.set_y_label(data.runs > 1 ? fmt::format("pose NEES, mean of {} runs", data.runs) : "pose NEES");
  fig.set_log_y(true);
  const std::string band = data.runs > 1 ? fmt::format("95% interval of a {}-run mean", data.runs) : "95% interval";
  const LineStyle band_style{palette::kVermillion, 1.2, Dash::kDashed};
  const Vector2 lo[] = {{t0, data.band_lo}, {t1, data.band_lo}};
  const Vector2 hi[] = {{t0, data.band_hi}, {t1, data.band_hi}};
  const Vector2 mean[] = {{t0, data.dof}, {t1, data.dof}};
  fig.add_line(data.nees, {palette::kBlue, data.runs > 1 ? 1.2 : 0.8}, "pose NEES");
  fig.add_line(lo, band_style, band);
  fig.add_line(hi, band_style, band);
  fig.add_line(mean, {palette::kGrey, 1.0, Dash::kDotted}, fmt::format("consistent mean ({:g})", data.dof));
  return fig;
}

}  // namespace slamkit::plot
