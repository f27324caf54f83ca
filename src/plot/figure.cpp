#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string_view>

#include "axes.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/base64.hpp"
#include "slamkit/plot/svg_plot.hpp"
#include "svg_elements.hpp"

namespace slamkit::plot {

using namespace svg;

namespace {

// Layout around the plot area, in px. Sizes follow matplotlib's defaults at 100 dpi.
constexpr double kPad = 12;  // canvas edge to any content
constexpr double kTitleSize = 16;
constexpr double kSubtitleSize = 12.5;
constexpr double kLabelSize = 13;
constexpr double kLegendSize = 12;
constexpr double kLegendGap = 16;  // plot area to legend column
constexpr double kLegendRow = 20;
constexpr double kLegendSample = 28;  // width of a legend's line sample
constexpr double kLegendInner = 8;
constexpr double kColorbarWidth = 170;
constexpr double kColorbarHeight = 54;  // label, bar and tick labels
constexpr double kAutoMargin = 0.04;    // fraction of the data span added on each side

constexpr std::string_view kFontFamily = "DejaVu Sans, Helvetica, Arial, sans-serif";
constexpr std::string_view kSubtitleColor = "#555555";
constexpr std::string_view kClipId = "slamkit-plot-area";
constexpr std::string_view kGradientId = "slamkit-colorbar";

struct Span {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return !(lo <= hi); }
};

/// The automatic range of one axis: the data plus a small margin, with a sensible width when the
/// data has none. Works in log10 units on a log axis.
std::pair<double, double> padded(const Span& s, double empty_lo, double empty_hi, bool log_axis) {
  if (s.empty()) return {empty_lo, empty_hi};
  double lo = s.lo, hi = s.hi;
  if (hi - lo <= 1e-12 * std::max(1.0, std::abs(lo))) {
    const double half = log_axis ? 0.5 : std::max(0.1 * std::abs(lo), 1.0);
    return {lo - half, hi + half};
  }
  const double margin = kAutoMargin * (hi - lo);
  return {lo - margin, hi + margin};
}

/// Points on the ellipse, closed, dense enough that no chord strays more than ~0.1 px from it; the
/// count is a multiple of four so that the ends of both axes are vertices.
std::vector<Vector2> ellipse_points(const Vector2& c, const Vector2& major, const Vector2& minor,
                                    const Frame& f) {
  const double radius_px = (f.to_pixel(c + major) - f.to_pixel(c)).norm();
  // A chord of length L on a circle of radius a strays L^2 / (8a) from it.
  const double wanted = std::isfinite(radius_px) ? 2 * std::numbers::pi * std::sqrt(radius_px * 1.25) : 16;
  const int n = 4 * static_cast<int>(std::ceil(std::clamp(wanted, 16.0, 256.0) / 4));
  std::vector<Vector2> pts;
  pts.reserve(n + 1);
  for (int i = 0; i <= n; ++i) {
    const double a = 2 * std::numbers::pi * (i % n) / n;
    pts.push_back(f.to_pixel(c + std::cos(a) * major + std::sin(a) * minor));
  }
  return pts;
}

/// The XML header and the root element, with a white background, of a picture of this size.
std::string svg_open(double width, double height, std::string_view title) {
  std::string out = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" "
      "viewBox=\"0 0 {0} {1}\" font-family=\"{2}\">\n",
      px(width), px(height), kFontFamily);
  if (!title.empty()) out += "<title>" + escape(title) + "</title>\n";
  out += "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
  return out;
}

}  // namespace

Figure::Figure(double width, double height) : width_(width), height_(height) {
  if (!(width >= 200 && height >= 150) || !std::isfinite(width) || !std::isfinite(height))
    throw std::invalid_argument(
        fmt::format("figure size {} x {} px is too small (minimum 200 x 150)", width, height));
}

void Figure::set_x_limits(double lo, double hi) {
  if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi))
    throw std::invalid_argument(fmt::format("x limits [{}, {}] are not an increasing finite range", lo, hi));
  x_limits_ = {true, lo, hi};
}

void Figure::set_y_limits(double lo, double hi) {
  if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi))
    throw std::invalid_argument(fmt::format("y limits [{}, {}] are not an increasing finite range", lo, hi));
  if (log_y_ && !(lo > 0))
    throw std::invalid_argument(fmt::format("y limits [{}, {}] do not fit a log axis", lo, hi));
  y_limits_ = {true, lo, hi};
}

void Figure::add_to_legend(std::string label, LegendSample sample) {
  if (label.empty()) return;
  // Items that share a label (one ellipse per landmark) share one entry.
  for (const LegendEntry& e : legend_)
    if (e.label == label) return;
  legend_.push_back({std::move(label), sample});
}

void Figure::add_line(std::span<const Vector2> points, const LineStyle& style, std::string label) {
  if (std::none_of(points.begin(), points.end(), finite)) return;
  items_.push_back(Line{{points.begin(), points.end()}, style});
  add_to_legend(std::move(label), style);
}

void Figure::add_image(std::string png, const Vector2& lower_left, const Vector2& size) {
  if (png.empty() || !finite(lower_left) || !finite(size) || !(size.x() > 0 && size.y() > 0)) return;
  items_.push_back(Image{std::move(png), lower_left, size});
}

void Figure::add_markers(std::span<const Vector2> points, const MarkerStyle& style, std::string label) {
  if (std::none_of(points.begin(), points.end(), finite)) return;
  items_.push_back(Markers{{points.begin(), points.end()}, style});
  add_to_legend(std::move(label), style);
}

bool Figure::add_ellipse(const Vector2& centre, const Matrix2& cov, double n_sigma, const EllipseStyle& style,
                         std::string label) {
  if (!finite(centre) || !cov.allFinite() || !(n_sigma > 0) || !std::isfinite(n_sigma)) return false;
  Eigen::SelfAdjointEigenSolver<Matrix2> eig;
  eig.computeDirect(0.5 * (cov + cov.transpose()));  // closed form for 2x2, eigenvalues ascending
  const double big = eig.eigenvalues()[1], small = eig.eigenvalues()[0];
  // Round-off in a filter's covariance makes a rank-one ellipse's small eigenvalue slightly
  // negative; anything clearly negative means the matrix is not a covariance.
  if (!(big > 0) || small < -1e-9 * big) return false;
  items_.push_back(Ellipse{centre, n_sigma * std::sqrt(big) * eig.eigenvectors().col(1),
                           n_sigma * std::sqrt(std::max(small, 0.0)) * eig.eigenvectors().col(0), style});
  add_to_legend(std::move(label), style);
  return true;
}

void Figure::add_text(const Vector2& at, std::string text, const TextStyle& style) {
  if (!finite(at)) return;
  items_.push_back(Text{at, std::move(text), style});
}

void Figure::add_legend_entry(std::string label, const LineStyle& style) {
  add_to_legend(std::move(label), style);
}

void Figure::add_legend_entry(std::string label, const MarkerStyle& style) {
  add_to_legend(std::move(label), style);
}

void Figure::set_colorbar(std::string label, double lo, double hi) {
  if (!(std::isfinite(lo) && std::isfinite(hi) && lo <= hi))
    throw std::invalid_argument(fmt::format("colour bar range [{}, {}] is not a finite range", lo, hi));
  colorbar_ = Colorbar{std::move(label), lo, hi};
}

double Figure::legend_box_width() const {
  double widest = 0;
  for (const LegendEntry& e : legend_) widest = std::max(widest, text_width(e.label, kLegendSize));
  return 3 * kLegendInner + kLegendSample + widest;
}

double Figure::legend_box_height() const {
  return 2 * kLegendInner + kLegendRow * static_cast<double>(legend_.size());
}

double Figure::legend_width() const {
  const double box = legend_.empty() ? 0 : legend_box_width();
  if (!colorbar_) return box;
  return std::max({box, kColorbarWidth, text_width(colorbar_->label, kLegendSize)});
}

double Figure::legend_height() const {
  const double box = legend_.empty() ? 0 : legend_box_height();
  if (!colorbar_) return box;
  return box + (box > 0 ? kLegendGap : 0) + kColorbarHeight;
}

Frame Figure::frame() const {
  Span xs, ys;
  const auto add_point = [&](const Vector2& p) {
    if (!finite(p) || (log_y_ && !(p.y() > 0))) return;
    xs.add(p.x());
    ys.add(log_y_ ? std::log10(p.y()) : p.y());
  };
  for (const Item& item : items_) {
    if (const auto* line = std::get_if<Line>(&item)) {
      for (const Vector2& p : line->points) add_point(p);
    } else if (const auto* markers = std::get_if<Markers>(&item)) {
      for (const Vector2& p : markers->points) add_point(p);
    } else if (const auto* ellipse = std::get_if<Ellipse>(&item)) {
      // Only the centre: one diverged landmark's huge ellipse would otherwise shrink the whole map.
      add_point(ellipse->centre);
    } else if (const auto* image = std::get_if<Image>(&item)) {
      add_point(image->lower_left);
      add_point(image->lower_left + image->size);
    }
  }
  auto [x0, x1] = x_limits_.set ? std::pair(x_limits_.lo, x_limits_.hi) : padded(xs, 0.0, 1.0, false);
  auto [u0, u1] = y_limits_.set ? std::pair(y_limits_.lo, y_limits_.hi) : padded(ys, 0.0, 1.0, log_y_);
  if (log_y_ && y_limits_.set) {
    if (!(y_limits_.lo > 0))
      throw std::invalid_argument(
          fmt::format("y limits [{}, {}] do not fit a log axis", y_limits_.lo, y_limits_.hi));
    u0 = std::log10(u0);
    u1 = std::log10(u1);
  }

  const double title_lines = static_cast<double>(split_lines(title_).size());
  const double subtitle_lines = static_cast<double>(split_lines(subtitle_).size());
  const double top = kPad + title_lines * 1.3 * kTitleSize + subtitle_lines * 1.35 * kSubtitleSize +
                     (title_lines + subtitle_lines > 0 ? 8 : 0);
  const double bottom =
      kTickLength + kTickGap + 1.2 * kTickSize + (x_label_.empty() ? 0 : 6 + 1.3 * kLabelSize) + kPad;
  const double legend_w = legend_width();
  const double right = std::max(min_right_, kPad + (legend_w > 0 ? legend_w + kLegendGap : 8));

  Frame f;
  f.width = width_;
  f.log_y = log_y_;
  // The left margin fits the y tick labels, which depend on the range, which (with equal aspect)
  // depends on the plot width: iterate to a fixed point, which a couple of passes reach.
  double left = kPad + 40;
  for (int pass = 0; pass < 4; ++pass) {
    // Whole-pixel sizes at half-pixel edges keep the 1 px frame crisp instead of a blurred 2 px.
    f.left = std::round(left) + 0.5;
    f.top = std::round(top) + 0.5;
    f.plot_width = std::floor(width_ - f.left - right);
    f.plot_height = std::floor(height_ - f.top - bottom);
    if (f.plot_width < 50 || f.plot_height < 50)
      throw std::invalid_argument(
          fmt::format("figure of {} x {} px leaves no room to plot", width_, height_));
    double a0 = x0, a1 = x1, b0 = u0, b1 = u1;
    if (equal_aspect_ && !log_y_) {
      const double sx = f.plot_width / (a1 - a0), sy = f.plot_height / (b1 - b0);
      if (sx < sy) {
        // Wide data: shorten the canvas, but keep the plot tall enough to read and to hold the legend.
        const double min_height = std::min(f.plot_height, std::max(legend_height(), 0.35 * f.plot_width));
        f.plot_height = std::floor(std::max((b1 - b0) * sx, min_height));
        const double half = 0.5 * f.plot_height / sx, mid = 0.5 * (b0 + b1);
        b0 = mid - half;
        b1 = mid + half;
      } else {
        const double half = 0.5 * f.plot_width / sy, mid = 0.5 * (a0 + a1);
        a0 = mid - half;
        a1 = mid + half;
      }
    }
    f.x_min = a0;
    f.x_max = a1;
    f.y_min = log_y_ ? std::pow(10.0, b0) : b0;
    f.y_max = log_y_ ? std::pow(10.0, b1) : b1;
    f.height = f.top + f.plot_height + bottom;

    double widest = 0;
    const auto ticks = compute_ticks(f);
    for (const std::string& label : ticks.y_labels) widest = std::max(widest, text_width(label, kTickSize));
    const double needed = std::max(
        min_left_, kPad + (y_label_.empty() ? 0 : 1.3 * kLabelSize + 6) + widest + kTickLength + kTickGap);
    if (std::abs(needed - left) < 1) break;
    left = needed;
  }
  return f;
}

void Figure::write_data(std::string& out, const Frame& f, std::string_view clip_id) const {
  // Clipped to the plot area. Consecutive items with the same style share one group so that a
  // hundred ellipses do not repeat a hundred sets of style attributes.
  fmt::format_to(std::back_inserter(out), "<g clip-path=\"url(#{})\">\n", clip_id);
  std::string group_attributes;
  bool group_open = false;
  const auto emit = [&](const std::string& attributes, const std::string& element) {
    if (group_open && attributes != group_attributes) {
      out += "</g>\n";
      group_open = false;
    }
    if (!group_open && !attributes.empty()) {
      out += "<g " + attributes + ">\n";
      group_attributes = attributes;
      group_open = true;
    }
    out += element + '\n';
  };
  const auto path = [](const std::string& d) { return "<path d=\"" + d + "\"/>"; };
  const double right = f.left + f.plot_width, bottom = f.top + f.plot_height;
  for (const Item& item : items_) {
    if (const auto* line = std::get_if<Line>(&item)) {
      std::vector<Vector2> pixels;
      pixels.reserve(line->points.size());
      for (const Vector2& p : line->points) pixels.push_back(f.to_pixel(p));
      const std::string d = polyline_path(pixels);
      if (!d.empty()) emit(line_attributes(line->style), path(d));
    } else if (const auto* markers = std::get_if<Markers>(&item)) {
      std::string d;
      Vector2 last = Vector2::Constant(kNaN);    // distance to it is NaN, never below kMinStep
      const double reach = markers->style.size;  // markers off the plot area are clipped anyway
      for (const Vector2& p : markers->points) {
        const Vector2 q = f.to_pixel(p);
        if (!finite(q) || q.x() < f.left - reach || q.x() > right + reach || q.y() < f.top - reach ||
            q.y() > bottom + reach || (q - last).norm() < kMinStep)
          continue;
        put_marker(d, q, markers->style);
        last = q;
      }
      if (!d.empty()) emit(marker_attributes(markers->style), path(d));
    } else if (const auto* ellipse = std::get_if<Ellipse>(&item)) {
      const std::string d = polyline_path(ellipse_points(ellipse->centre, ellipse->major, ellipse->minor, f));
      if (!d.empty()) emit(ellipse_attributes(ellipse->style), path(d));
    } else if (const auto* image = std::get_if<Image>(&item)) {
      const Vector2 a = f.to_pixel(Vector2(image->lower_left.x(), image->lower_left.y() + image->size.y()));
      const Vector2 b = f.to_pixel(Vector2(image->lower_left.x() + image->size.x(), image->lower_left.y()));
      if (finite(a) && finite(b))
        emit("", fmt::format("<image x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" preserveAspectRatio=\"none\" "
                             "style=\"image-rendering:pixelated\" href=\"data:image/png;base64,{}\"/>",
                             px(a.x()), px(a.y()), px(b.x() - a.x()), px(b.y() - a.y()), base64(image->png)));
    } else if (const auto* text = std::get_if<Text>(&item)) {
      const Vector2 q = f.to_pixel(text->at);
      const TextStyle& s = text->style;
      if (finite(q)) emit("", text_element(q.x(), q.y(), text->text, s.size, s.color.hex(), s.anchor));
    }
  }
  if (group_open) out += "</g>\n";
  out += "</g>\n";
}

void Figure::write_labels(std::string& out, const Frame& f) const {
  const double centre_x = f.left + 0.5 * f.plot_width, bottom = f.top + f.plot_height;
  if (!x_label_.empty())
    out += text_element(centre_x, bottom + kTickLength + kTickGap + 1.2 * kTickSize + 6 + 0.65 * kLabelSize,
                        x_label_, kLabelSize, kTextColor, Anchor::kMiddle) +
           '\n';
  if (!y_label_.empty()) {
    const double x = kPad + 0.65 * kLabelSize, y = f.top + 0.5 * f.plot_height;
    const std::string rotate =
        fmt::format(" transform=\"rotate(-90 {} {})\"", px(x), px(y + 0.35 * kLabelSize));
    out += text_element(x, y, y_label_, kLabelSize, kTextColor, Anchor::kMiddle, rotate) + '\n';
  }
  // Centred over the plot area like matplotlib, but shifted to stay on the canvas when long.
  const auto centred = [&](std::string_view line, double size) {
    const double half = 0.5 * text_width(line, size);
    return std::clamp(centre_x, kPad + half, std::max(kPad + half, f.width - kPad - half));
  };
  double y = kPad;
  for (const std::string& line : split_lines(title_)) {
    out += text_element(centred(line, kTitleSize), y + 0.6 * kTitleSize, line, kTitleSize, kTextColor,
                        Anchor::kMiddle, " font-weight=\"bold\"") +
           '\n';
    y += 1.3 * kTitleSize;
  }
  for (const std::string& line : split_lines(subtitle_)) {
    out += text_element(centred(line, kSubtitleSize), y + 0.6 * kSubtitleSize, line, kSubtitleSize,
                        kSubtitleColor, Anchor::kMiddle) +
           '\n';
    y += 1.35 * kSubtitleSize;
  }
}

void Figure::write_legend(std::string& out, const Frame& f, std::string_view gradient_id) const {
  // In a column right of the plot area, so that it never hides data.
  auto o = std::back_inserter(out);
  const double x = f.left + f.plot_width + kLegendGap;
  double y = f.top;
  if (!legend_.empty()) {
    const double h = legend_box_height();
    fmt::format_to(o,
                   "<g>\n<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" rx=\"3\" fill=\"#ffffff\" "
                   "stroke=\"#cccccc\" stroke-width=\"0.8\"/>\n",
                   px(x), px(y), px(legend_box_width()), px(h));
    for (std::size_t i = 0; i < legend_.size(); ++i) {
      const double cy = y + kLegendInner + kLegendRow * (static_cast<double>(i) + 0.5);
      const double x0 = x + kLegendInner, cx = x0 + 0.5 * kLegendSample;
      const LegendSample& sample = legend_[i].sample;
      if (const auto* line = std::get_if<LineStyle>(&sample)) {
        fmt::format_to(o, "<path d=\"M{} {}h{}\" {}/>\n", px(x0), px(cy), px(kLegendSample),
                       line_attributes(*line));
      } else if (const auto* marker = std::get_if<MarkerStyle>(&sample)) {
        MarkerStyle shown = *marker;
        shown.size = std::max(shown.size, 5.0);  // dots small enough for dense data vanish in a legend
        std::string d;
        put_marker(d, {cx, cy}, shown);
        fmt::format_to(o, "<path d=\"{}\" {}/>\n", d, marker_attributes(shown));
      } else if (const auto* ellipse = std::get_if<EllipseStyle>(&sample)) {
        fmt::format_to(o, "<ellipse cx=\"{}\" cy=\"{}\" rx=\"{}\" ry=\"{}\" {}/>\n", px(cx), px(cy),
                       px(0.4 * kLegendSample), px(0.3 * kLegendRow), ellipse_attributes(*ellipse));
      }
      out += text_element(x0 + kLegendSample + kLegendInner, cy, legend_[i].label, kLegendSize, kTextColor,
                          Anchor::kStart) +
             '\n';
    }
    out += "</g>\n";
    y += h + kLegendGap;
  }
  if (colorbar_) {
    const double bar_y = y + 1.6 * kLegendSize, bar_height = 12;
    out += text_element(x, y + 0.5 * kLegendSize, colorbar_->label, kLegendSize, kTextColor, Anchor::kStart) +
           '\n';
    fmt::format_to(o,
                   "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"url(#{})\" stroke=\"{}\" "
                   "stroke-width=\"0.8\"/>\n",
                   px(x), px(bar_y), px(kColorbarWidth), px(bar_height), gradient_id, kTickColor);
    const double span = colorbar_->hi - colorbar_->lo;
    const std::vector<double> values = linear_ticks(colorbar_->lo, colorbar_->hi, 4);
    const std::vector<std::string> labels = linear_labels(values);
    std::string marks;
    for (std::size_t i = 0; i < values.size(); ++i) {
      const double tick_x = x + (span > 0 ? (values[i] - colorbar_->lo) / span : 0.5) * kColorbarWidth;
      marks += fmt::format("M{} {}v{}", px(tick_x), px(bar_y + bar_height), px(kMinorTickLength));
      out += text_element(tick_x, bar_y + bar_height + kMinorTickLength + 2 + 0.6 * kTickSize, labels[i],
                          kTickSize, kTextColor, Anchor::kMiddle) +
             '\n';
    }
    fmt::format_to(o, "<path d=\"{}\" stroke=\"{}\" stroke-width=\"1\"/>\n", marks, kTickColor);
  }
}

void Figure::write_body(std::string& out, const Frame& f, std::string_view id_suffix) const {
  // Ids are unique within a document, so every figure of a stacked picture has its own.
  const std::string clip_id = fmt::format("{}{}", kClipId, id_suffix);
  const std::string gradient_id = fmt::format("{}{}", kGradientId, id_suffix);
  const Ticks ticks = compute_ticks(f);
  auto o = std::back_inserter(out);
  fmt::format_to(
      o, "<defs>\n<clipPath id=\"{}\"><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/></clipPath>\n",
      clip_id, px(f.left), px(f.top), px(f.plot_width), px(f.plot_height));
  if (colorbar_) {
    fmt::format_to(o, "<linearGradient id=\"{}\">", gradient_id);
    for (int i = 0; i <= 8; ++i)
      fmt::format_to(o, "<stop offset=\"{:g}\" stop-color=\"{}\"/>", i / 8.0,
                     sequential_color(i / 8.0).hex());
    out += "</linearGradient>\n";
  }
  out += "</defs>\n";
  write_grid(out, f, ticks);
  write_data(out, f, clip_id);
  write_axes(out, f, ticks);
  write_labels(out, f);
  write_legend(out, f, gradient_id);
}

std::string Figure::to_svg() const {
  const Frame f = frame();
  std::string out = svg_open(f.width, f.height, title_);
  write_body(out, f, "");
  out += "</svg>\n";
  return out;
}

std::string stacked_svg(std::vector<Figure> panels) {
  if (panels.empty()) throw std::invalid_argument("stacked figure: no panels");
  // The same margins for every panel, so that their plot areas line up.
  double left = 0, right = 0, width = 0;
  for (const Figure& panel : panels) {
    const Frame f = panel.frame();
    left = std::max(left, f.left);
    right = std::max(right, f.width - f.left - f.plot_width);
    width = std::max(width, f.width);
  }
  std::vector<Frame> frames;
  double height = 0;
  for (Figure& panel : panels) {
    panel.set_min_margins(std::floor(left), right);
    frames.push_back(panel.frame());
    height += frames.back().height;
  }
  std::string out = svg_open(width, height, panels.front().title_);
  double y = 0;
  for (std::size_t i = 0; i < panels.size(); ++i) {
    fmt::format_to(std::back_inserter(out), "<g transform=\"translate(0 {})\">\n", px(y));
    panels[i].write_body(out, frames[i], fmt::format("-{}", i + 1));
    out += "</g>\n";
    y += frames[i].height;
  }
  out += "</svg>\n";
  return out;
}

void Figure::save(const std::string& path) const {
  write_file_atomically(path, to_svg());
}

}  // namespace slamkit::plot
