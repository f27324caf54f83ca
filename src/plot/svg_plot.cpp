#include "slamkit/plot/svg_plot.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string_view>

namespace slamkit::plot {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Typography and layout, in px. Sizes follow matplotlib's defaults at 100 dpi.
constexpr double kPad = 12;  // canvas edge to any content
constexpr double kTitleSize = 16;
constexpr double kSubtitleSize = 12.5;
constexpr double kLabelSize = 13;
constexpr double kTickSize = 11;
constexpr double kLegendSize = 12;
constexpr double kTickLength = 5;
constexpr double kMinorTickLength = 3;
constexpr double kTickGap = 4;       // tick to its label
constexpr double kTickSpacing = 80;  // aimed-for distance between major ticks
constexpr double kLegendGap = 16;    // plot area to legend column
constexpr double kLegendRow = 20;
constexpr double kLegendSample = 28;  // width of a legend's line sample
constexpr double kLegendInner = 8;
constexpr double kColorbarWidth = 170;
constexpr double kColorbarHeight = 54;  // label, bar and tick labels
constexpr double kAutoMargin = 0.04;    // fraction of the data span added on each side
// Text is not measured, only estimated: DejaVu Sans and Helvetica average about 0.6 em per glyph.
constexpr double kGlyphWidth = 0.6;
// Thinning and rounding keep files small without visible change: points closer than this to the
// previous kept one are dropped, and coordinates are written to 0.1 px (about 1/6000 of a plot's
// width, i.e. nearly 4 significant digits of the data range).
constexpr double kMinStep = 0.5;
// Points closer than this to the simplified line are dropped too: matplotlib's path simplification
// uses 1/9 px; smooth curves (uncertainty decaying over thousands of steps) shrink tenfold.
constexpr double kSimplifyTolerance = 0.1;
// Far-off points (explicit limits, a diverged landmark's ellipse) are clamped: renderers mishandle
// huge coordinates, and at this distance the clamp does not visibly change a line's direction.
constexpr double kMaxCoordinate = 1e6;

constexpr std::string_view kFontFamily = "DejaVu Sans, Helvetica, Arial, sans-serif";
constexpr std::string_view kTextColor = "#222222";
constexpr std::string_view kTickColor = "#444444";
constexpr std::string_view kGridColor = "#e3e3e3";
constexpr std::string_view kSubtitleColor = "#555555";
constexpr std::string_view kClipId = "slamkit-plot-area";
constexpr std::string_view kGradientId = "slamkit-colorbar";

bool finite(const Vector2& p) { return std::isfinite(p.x()) && std::isfinite(p.y()); }

// ---- Text ---------------------------------------------------------------------------------------

/// Length of the UTF-8 sequence starting with byte `lead`, or 0 if `lead` cannot start one.
int utf8_length(unsigned char lead) {
  if (lead < 0x80) return 1;
  if (lead >= 0xC2 && lead <= 0xDF) return 2;
  if (lead >= 0xE0 && lead <= 0xEF) return 3;
  if (lead >= 0xF0 && lead <= 0xF4) return 4;
  return 0;
}

/// Text for XML content and attributes. Browsers reject the whole file on a stray '<', on control
/// characters XML 1.0 forbids and on invalid UTF-8 (e.g. a Latin-1 file name in a title), so the
/// first are escaped, the second dropped and the last replaced by U+FFFD.
std::string escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    const int n = utf8_length(c);
    bool valid = n > 0 && i + n <= s.size();
    for (int k = 1; valid && k < n; ++k) valid = (static_cast<unsigned char>(s[i + k]) & 0xC0) == 0x80;
    if (!valid) {
      out += "\xEF\xBF\xBD";
      ++i;
      continue;
    }
    if (n > 1) {
      out.append(s.substr(i, n));
    } else if (c == '&') {
      out += "&amp;";
    } else if (c == '<') {
      out += "&lt;";
    } else if (c == '>') {
      out += "&gt;";
    } else if (c == '"') {
      out += "&quot;";
    } else if (c == '\'') {
      out += "&apos;";
    } else if (c >= 0x20 || c == '\t') {
      out += static_cast<char>(c);
    }
    i += n;
  }
  return out;
}

double text_width(std::string_view s, double size) {
  const auto glyphs = std::count_if(s.begin(), s.end(), [](char c) {
    return (static_cast<unsigned char>(c) & 0xC0) != 0x80;  // count lead bytes only
  });
  return static_cast<double>(glyphs) * kGlyphWidth * size;
}

std::vector<std::string> split_lines(const std::string& s) {
  std::vector<std::string> lines;
  if (s.empty()) return lines;
  std::size_t start = 0;
  for (std::size_t nl; (nl = s.find('\n', start)) != std::string::npos; start = nl + 1)
    lines.push_back(s.substr(start, nl - start));
  lines.push_back(s.substr(start));
  return lines;
}

/// Typographic minus, as matplotlib writes it: a hyphen looks too short next to digits.
std::string with_minus_sign(std::string s) {
  if (!s.empty() && s[0] == '-') s.replace(0, 1, "\u2212");
  return s;
}

std::string superscript(int k) {
  static constexpr std::array<std::string_view, 10> kDigits = {
      "\u2070", "\u00B9", "\u00B2", "\u00B3", "\u2074", "\u2075", "\u2076", "\u2077", "\u2078", "\u2079"};
  std::string out = k < 0 ? "\u207B" : "";
  for (const char c : std::to_string(std::abs(k))) out += kDigits[c - '0'];
  return out;
}

// ---- Numbers ------------------------------------------------------------------------------------

/// A pixel coordinate in tenths of a pixel.
long tenths(double px) { return std::lround(std::clamp(px, -kMaxCoordinate, kMaxCoordinate) * 10.0); }

void put_tenths(std::string& out, long v) {
  if (v < 0) {
    out += '-';
    v = -v;
  }
  out += std::to_string(v / 10);
  if (v % 10 != 0) {
    out += '.';
    out += static_cast<char>('0' + v % 10);
  }
}

/// A pixel quantity (coordinate, size) rounded to 0.1 px.
std::string px(double v) {
  std::string s;
  put_tenths(s, tenths(v));
  return s;
}

double nice_step(double raw) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / magnitude;
  // Geometric midpoints between 1, 2, 5 and 10 keep the tick count within ~40% of the target.
  if (f < std::sqrt(2.0)) return magnitude;
  if (f < std::sqrt(10.0)) return 2 * magnitude;
  if (f < std::sqrt(50.0)) return 5 * magnitude;
  return 10 * magnitude;
}

int decimals_for_step(double step) {
  return std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
}

std::string linear_label(double v, int decimals) {
  if (v == 0.0) v = 0.0;  // -0.0 (from ceil(-0.5) * step) would print as "-0"
  return with_minus_sign(fmt::format("{:.{}f}", v, decimals));
}

/// Plain decimals ("0.01") while they stay short, powers of ten ("10⁻⁶") beyond.
std::vector<std::string> log_labels(const std::vector<double>& ticks) {
  const bool plain = std::all_of(ticks.begin(), ticks.end(), [](double v) { return v >= 1e-4 && v < 1e5; });
  std::vector<std::string> labels;
  for (const double v : ticks) {
    if (plain) {
      labels.push_back(fmt::format("{:g}", v));
      continue;
    }
    const int k = static_cast<int>(std::floor(std::log10(v) + 1e-9));
    const double mantissa = v / std::pow(10.0, k);
    const std::string power = "10" + superscript(k);
    labels.push_back(std::abs(mantissa - 1.0) < 1e-6 ? power : fmt::format("{:g}\u00D7{}", mantissa, power));
  }
  return labels;
}

// ---- Layout ---------------------------------------------------------------------------------------

struct Ticks {
  std::vector<double> x, y, y_minor;
  std::vector<std::string> x_labels, y_labels;
};

Ticks compute_ticks(const Frame& f) {
  Ticks t;
  // Fewer x ticks while their labels would collide (long numbers on a narrow axis).
  for (double target = f.plot_width / kTickSpacing;; target *= 0.7) {
    t.x = linear_ticks(f.x_min, f.x_max, std::max(target, 1.0));
    t.x_labels.clear();
    double widest = 0;
    const int decimals = t.x.size() > 1 ? decimals_for_step(t.x[1] - t.x[0]) : 0;
    for (const double v : t.x) {
      t.x_labels.push_back(linear_label(v, decimals));
      widest = std::max(widest, text_width(t.x_labels.back(), kTickSize));
    }
    const double spacing = f.plot_width * (t.x.size() > 1 ? (t.x[1] - t.x[0]) / (f.x_max - f.x_min) : 1.0);
    if (widest + 10 <= spacing || target <= 1.0) break;
  }
  if (f.log_y) {
    t.y = log_ticks(f.y_min, f.y_max);
    t.y_labels = log_labels(t.y);
    // Minor ticks at every m x 10^k unless the labels skip decades, where they would crowd.
    const bool skips_decades = t.y.size() > 1 && t.y[1] / t.y[0] > 10 * (1 + 1e-6);
    if (!skips_decades) {
      for (int k = static_cast<int>(std::floor(std::log10(f.y_min))); k <= std::ceil(std::log10(f.y_max));
           ++k)
        for (int m = 1; m <= 9; ++m) {
          const double v = m * std::pow(10.0, k);
          const bool major =
              std::any_of(t.y.begin(), t.y.end(), [v](double u) { return std::abs(u - v) <= 1e-9 * v; });
          if (v >= f.y_min && v <= f.y_max && !major) t.y_minor.push_back(v);
        }
    }
  } else {
    t.y = linear_ticks(f.y_min, f.y_max, std::max(f.plot_height / kTickSpacing, 1.0));
    const int decimals = t.y.size() > 1 ? decimals_for_step(t.y[1] - t.y[0]) : 0;
    for (const double v : t.y) t.y_labels.push_back(linear_label(v, decimals));
  }
  return t;
}

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

// ---- SVG pieces ---------------------------------------------------------------------------------

std::string dash_array(Dash dash, double width) {
  // matplotlib's patterns, scaled with the line width so that thick dashed lines stay dashed.
  const auto scaled = [width](std::initializer_list<double> pattern) {
    std::string s;
    for (const double v : pattern) s += (s.empty() ? "" : " ") + px(v * std::max(width, 1.0));
    return s;
  };
  switch (dash) {
    case Dash::kSolid:
      return {};
    case Dash::kDashed:
      return scaled({3.7, 1.6});
    case Dash::kDotted:
      return scaled({1.0, 1.65});
    case Dash::kDashDot:
      return scaled({6.4, 1.6, 1.0, 1.6});
  }
  return {};
}

std::string opacity_attribute(std::string_view name, double opacity) {
  return opacity < 1.0 ? fmt::format(" {}=\"{:.3g}\"", name, std::clamp(opacity, 0.0, 1.0)) : std::string();
}

std::string stroke_attributes(const LineStyle& s) {
  std::string a = fmt::format("stroke=\"{}\" stroke-width=\"{}\"", s.color.hex(), px(s.width));
  a += opacity_attribute("stroke-opacity", s.opacity);
  const std::string dashes = dash_array(s.dash, s.width);
  if (dashes.empty()) {
    a += " stroke-linecap=\"round\"";
  } else {
    a += fmt::format(" stroke-dasharray=\"{}\"", dashes);
  }
  return a + " stroke-linejoin=\"round\"";
}

std::string line_attributes(const LineStyle& s) { return "fill=\"none\" " + stroke_attributes(s); }

std::string ellipse_attributes(const EllipseStyle& s) {
  std::string a = s.fill_opacity > 0.0 ? fmt::format("fill=\"{}\"", s.edge.color.hex()) : "fill=\"none\"";
  a += opacity_attribute("fill-opacity", s.fill_opacity);
  return a + " " + stroke_attributes(s.edge);
}

bool marker_is_filled(const MarkerStyle& s) {
  return s.filled && (s.shape == Marker::kCircle || s.shape == Marker::kTriangle);
}

std::string marker_attributes(const MarkerStyle& s) {
  std::string a = marker_is_filled(s) ? fmt::format("fill=\"{}\" stroke=\"none\"", s.color.hex())
                                      : fmt::format("fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"",
                                                    s.color.hex(), px(s.stroke_width));
  return a + opacity_attribute("opacity", s.opacity);
}

/// Path data of one marker centred on pixel `c`.
void put_marker(std::string& d, const Vector2& c, const MarkerStyle& s) {
  const double r = s.size / 2;
  const auto move = [&d](double x, double y) {
    d += 'M';
    d += px(x) + ' ' + px(y);
  };
  switch (s.shape) {
    case Marker::kCircle:
      move(c.x() - r, c.y());
      d += fmt::format("a{0} {0} 0 1 0 {1} 0a{0} {0} 0 1 0 -{1} 0z", px(r), px(2 * r));
      break;
    case Marker::kPlus:
      move(c.x() - r, c.y());
      d += "h" + px(2 * r);
      move(c.x(), c.y() - r);
      d += "v" + px(2 * r);
      break;
    case Marker::kCross: {
      const double h = r * std::numbers::sqrt2 / 2;  // same stroke length as the plus
      move(c.x() - h, c.y() - h);
      d += fmt::format("l{0} {0}m0 -{0}l-{0} {0}", px(2 * h));
      break;
    }
    case Marker::kTriangle:  // pointing up, centroid on the point
      move(c.x(), c.y() - r);
      d += fmt::format("l{} {}h-{}z", px(r * std::sqrt(3.0) / 2), px(1.5 * r), px(r * std::sqrt(3.0)));
      break;
  }
}

double segment_distance(const Vector2& p, const Vector2& a, const Vector2& b) {
  const Vector2 d = b - a;
  const double length2 = d.squaredNorm();
  const double t = length2 > 0 ? std::clamp((p - a).dot(d) / length2, 0.0, 1.0) : 0.0;
  return (p - (a + t * d)).norm();
}

/// Douglas-Peucker simplification to kSimplifyTolerance. It runs on chunks of bounded length, whose
/// ends are kept, so that input that defeats it (every split at an end) still costs O(n * chunk).
void simplify(std::vector<Vector2>& pts) {
  constexpr std::size_t kChunk = 1024;
  if (pts.size() < 3) return;
  std::vector<char> keep(pts.size(), 0);
  std::vector<std::pair<std::size_t, std::size_t>> todo;
  for (std::size_t start = 0; start + 1 < pts.size(); start += kChunk) {
    const std::size_t end = std::min(start + kChunk, pts.size() - 1);
    keep[start] = keep[end] = 1;
    todo.emplace_back(start, end);
  }
  while (!todo.empty()) {
    const auto [i, j] = todo.back();
    todo.pop_back();
    double farthest = kSimplifyTolerance;
    std::size_t split = 0;
    for (std::size_t k = i + 1; k < j; ++k) {
      const double d = segment_distance(pts[k], pts[i], pts[j]);
      if (d > farthest) {
        farthest = d;
        split = k;
      }
    }
    if (split == 0) continue;
    keep[split] = 1;
    todo.emplace_back(i, split);
    todo.emplace_back(split, j);
  }
  std::size_t n = 0;
  for (std::size_t k = 0; k < pts.size(); ++k)
    if (keep[k]) pts[n++] = pts[k];
  pts.resize(n);
}

/// Path data of a polyline in pixels: broken at non-finite points, thinned to kMinStep, simplified,
/// and written as relative moves between rounded positions so that rounding never accumulates.
std::string polyline_path(const std::vector<Vector2>& pixels) {
  std::string d;
  std::vector<Vector2> piece;
  const auto flush = [&] {
    simplify(piece);
    if (piece.size() >= 2) {
      long x = tenths(piece[0].x()), y = tenths(piece[0].y());
      std::string moves;
      for (std::size_t i = 1; i < piece.size(); ++i) {
        const long nx = tenths(piece[i].x()), ny = tenths(piece[i].y());
        if (nx == x && ny == y) continue;
        moves += moves.empty() ? "l" : " ";
        put_tenths(moves, nx - x);
        moves += ' ';
        put_tenths(moves, ny - y);
        x = nx;
        y = ny;
      }
      if (!moves.empty()) {
        d += 'M';
        put_tenths(d, tenths(piece[0].x()));
        d += ' ';
        put_tenths(d, tenths(piece[0].y()));
        d += moves;
      }
    }
    piece.clear();
  };
  // The last of a run of dropped points is kept at a break so that a line ends where its data ends.
  bool dropped = false;
  Vector2 last = Vector2::Zero();
  for (const Vector2& p : pixels) {
    if (!finite(p)) {
      if (dropped) piece.push_back(last);
      dropped = false;
      flush();
    } else if (piece.empty() || (p - piece.back()).norm() >= kMinStep) {
      piece.push_back(p);
      dropped = false;
    } else {
      dropped = true;
      last = p;
    }
  }
  if (dropped) piece.push_back(last);
  flush();
  return d;
}

std::string_view anchor_name(Anchor a) {
  switch (a) {
    case Anchor::kStart:
      return "start";
    case Anchor::kMiddle:
      return "middle";
    case Anchor::kEnd:
      return "end";
  }
  return "start";
}

/// One `<text>` element; `y` is the visual centre of the text, not its baseline.
std::string text_element(double x, double y, std::string_view text, double size, std::string_view color,
                         Anchor anchor, std::string_view extra = {}) {
  return fmt::format(
      R"(<text x="{}" y="{}" font-size="{}" fill="{}"{}{}>{}</text>)", px(x), px(y + 0.35 * size), px(size),
      color,
      anchor == Anchor::kStart ? std::string() : fmt::format(" text-anchor=\"{}\"", anchor_name(anchor)),
      extra, escape(text));
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

/// The grid goes behind the data, at the major ticks.
void write_grid(std::string& out, const Frame& f, const Ticks& t) {
  const double right = f.left + f.plot_width, bottom = f.top + f.plot_height;
  std::string d;
  for (const double v : t.x)
    d += fmt::format("M{} {}V{}", px(f.to_pixel({v, f.y_min}).x()), px(f.top), px(bottom));
  for (const double v : t.y)
    d += fmt::format("M{} {}H{}", px(f.left), px(f.to_pixel({f.x_min, v}).y()), px(right));
  if (!d.empty())
    fmt::format_to(std::back_inserter(out),
                   "<path d=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"0.8\"/>\n", d, kGridColor);
}

/// Frame, ticks and tick labels go on top of the data.
void write_axes(std::string& out, const Frame& f, const Ticks& t) {
  auto o = std::back_inserter(out);
  const double bottom = f.top + f.plot_height;
  fmt::format_to(o,
                 "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"{}\" "
                 "stroke-width=\"1\"/>\n",
                 px(f.left), px(f.top), px(f.plot_width), px(f.plot_height), kTickColor);
  std::string d;
  const auto y_tick = [&](double v, double length) {
    d += fmt::format("M{} {}h-{}", px(f.left), px(f.to_pixel({f.x_min, v}).y()), px(length));
  };
  for (const double v : t.x)
    d += fmt::format("M{} {}v{}", px(f.to_pixel({v, f.y_min}).x()), px(bottom), px(kTickLength));
  for (const double v : t.y) y_tick(v, kTickLength);
  for (const double v : t.y_minor) y_tick(v, kMinorTickLength);
  fmt::format_to(o, "<path d=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1\"/>\n", d, kTickColor);
  for (std::size_t i = 0; i < t.x.size(); ++i)
    out += text_element(f.to_pixel({t.x[i], f.y_min}).x(), bottom + kTickLength + kTickGap + 0.6 * kTickSize,
                        t.x_labels[i], kTickSize, kTextColor, Anchor::kMiddle) +
           '\n';
  for (std::size_t i = 0; i < t.y.size(); ++i)
    out += text_element(f.left - kTickLength - kTickGap, f.to_pixel({f.x_min, t.y[i]}).y(), t.y_labels[i],
                        kTickSize, kTextColor, Anchor::kEnd) +
           '\n';
}

}  // namespace

// ---- Colours ----------------------------------------------------------------------------------------

std::string Color::hex() const { return fmt::format("#{:02x}{:02x}{:02x}", r, g, b); }

Color categorical_color(std::size_t i) {
  static constexpr std::array<Color, kCategoricalColors> kColors = {
      palette::kBlue,   palette::kVermillion, palette::kGreen, palette::kPurple,
      palette::kOrange, palette::kSkyBlue,    palette::kBlack};
  return kColors[i % kColors.size()];
}

Color sequential_color(double t) {
  // Viridis sampled at eighths; linear interpolation between them is within a few levels of it.
  static constexpr std::array<std::array<double, 3>, 9> kViridis = {{{68, 1, 84},
                                                                     {71, 45, 123},
                                                                     {59, 82, 139},
                                                                     {44, 114, 142},
                                                                     {33, 145, 140},
                                                                     {40, 174, 128},
                                                                     {94, 201, 98},
                                                                     {173, 220, 48},
                                                                     {253, 231, 37}}};
  constexpr double kLast = 0.85;  // beyond this viridis turns too pale for thin lines on white
  const double s = (std::isfinite(t) ? std::clamp(t, 0.0, 1.0) : 0.0) * kLast * 8;
  const int i = std::min(static_cast<int>(s), 7);
  const double w = s - i;
  const auto channel = [&](int k) {
    return static_cast<std::uint8_t>(std::lround((1 - w) * kViridis[i][k] + w * kViridis[i + 1][k]));
  };
  return {channel(0), channel(1), channel(2)};
}

// ---- Ticks and frame ------------------------------------------------------------------------------

std::vector<double> linear_ticks(double lo, double hi, double target_count) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi) return {};
  if (lo == hi) return {lo};
  const double step = nice_step((hi - lo) / std::max(target_count, 1.0));
  // Ticks are integer multiples of the step, not accumulated sums, so they carry no drift; the
  // tolerance keeps a tick that sits on an end despite rounding in the division.
  const double first = std::ceil(lo / step - 1e-9), last = std::floor(hi / step + 1e-9);
  std::vector<double> ticks;
  for (double k = first; k <= last; ++k) ticks.push_back(k * step);
  return ticks;
}

std::vector<double> log_ticks(double lo, double hi) {
  if (!(lo > 0) || !std::isfinite(hi) || lo >= hi) return {};
  constexpr double kTol = 1e-9;
  const int first = static_cast<int>(std::ceil(std::log10(lo) - kTol));
  const int last = static_cast<int>(std::floor(std::log10(hi) + kTol));
  std::vector<double> ticks;
  // Two powers of ten are too few labels to read values off; 1-2-5 steps fill in up to three.
  if (last - first + 1 >= 3) {
    constexpr int kMaxLabels = 8;
    const int every = (last - first) / kMaxLabels + 1;
    for (int k = first; k <= last; k += every) ticks.push_back(std::pow(10.0, k));
    return ticks;
  }
  for (int k = first - 1; k <= last; ++k)
    for (const double m : {1.0, 2.0, 5.0}) {
      const double v = m * std::pow(10.0, k);
      if (v >= lo * (1 - kTol) && v <= hi * (1 + kTol)) ticks.push_back(v);
    }
  if (ticks.size() >= 2) return ticks;
  return linear_ticks(lo, hi, 4);
}

Vector2 Frame::to_pixel(const Vector2& p) const {
  const double x = left + (p.x() - x_min) / (x_max - x_min) * plot_width;
  double v = p.y(), lo = y_min, hi = y_max;
  if (log_y) {
    v = v > 0 ? std::log10(v) : kNaN;
    lo = std::log10(lo);
    hi = std::log10(hi);
  }
  return {x, top + plot_height - (v - lo) / (hi - lo) * plot_height};
}

Vector2 Frame::to_data(const Vector2& p) const {
  const double x = x_min + (p.x() - left) / plot_width * (x_max - x_min);
  const double u = (top + plot_height - p.y()) / plot_height;
  if (log_y) return {x, std::pow(10.0, std::log10(y_min) + u * (std::log10(y_max) - std::log10(y_min)))};
  return {x, y_min + u * (y_max - y_min)};
}

// ---- Figure -----------------------------------------------------------------------------------------

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
  items_.emplace_back(std::in_place_type<Text>, at, std::move(text), style);
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
  const double right = kPad + (legend_w > 0 ? legend_w + kLegendGap : 8);

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
    const double needed =
        kPad + (y_label_.empty() ? 0 : 1.3 * kLabelSize + 6) + widest + kTickLength + kTickGap;
    if (std::abs(needed - left) < 1) break;
    left = needed;
  }
  return f;
}

void Figure::write_data(std::string& out, const Frame& f) const {
  // Clipped to the plot area. Consecutive items with the same style share one group so that a
  // hundred ellipses do not repeat a hundred sets of style attributes.
  fmt::format_to(std::back_inserter(out), "<g clip-path=\"url(#{})\">\n", kClipId);
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

void Figure::write_legend(std::string& out, const Frame& f) const {
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
                   px(x), px(bar_y), px(kColorbarWidth), px(bar_height), kGradientId, kTickColor);
    const double span = colorbar_->hi - colorbar_->lo;
    const std::vector<double> values = linear_ticks(colorbar_->lo, colorbar_->hi, 4);
    const int decimals = values.size() > 1 ? decimals_for_step(values[1] - values[0]) : 0;
    std::string marks;
    for (const double v : values) {
      const double tick_x = x + (span > 0 ? (v - colorbar_->lo) / span : 0.5) * kColorbarWidth;
      marks += fmt::format("M{} {}v{}", px(tick_x), px(bar_y + bar_height), px(kMinorTickLength));
      out += text_element(tick_x, bar_y + bar_height + kMinorTickLength + 2 + 0.6 * kTickSize,
                          linear_label(v, decimals), kTickSize, kTextColor, Anchor::kMiddle) +
             '\n';
    }
    fmt::format_to(o, "<path d=\"{}\" stroke=\"{}\" stroke-width=\"1\"/>\n", marks, kTickColor);
  }
}

std::string Figure::to_svg() const {
  const Frame f = frame();
  const Ticks ticks = compute_ticks(f);
  std::string out;
  auto o = std::back_inserter(out);
  fmt::format_to(o,
                 "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                 "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" "
                 "viewBox=\"0 0 {0} {1}\" font-family=\"{2}\">\n",
                 px(f.width), px(f.height), kFontFamily);
  if (!title_.empty()) out += "<title>" + escape(title_) + "</title>\n";
  out += "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
  fmt::format_to(
      o, "<defs>\n<clipPath id=\"{}\"><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/></clipPath>\n",
      kClipId, px(f.left), px(f.top), px(f.plot_width), px(f.plot_height));
  if (colorbar_) {
    fmt::format_to(o, "<linearGradient id=\"{}\">", kGradientId);
    for (int i = 0; i <= 8; ++i)
      fmt::format_to(o, "<stop offset=\"{:g}\" stop-color=\"{}\"/>", i / 8.0,
                     sequential_color(i / 8.0).hex());
    out += "</linearGradient>\n";
  }
  out += "</defs>\n";
  write_grid(out, f, ticks);
  write_data(out, f);
  write_axes(out, f, ticks);
  write_labels(out, f);
  write_legend(out, f);
  out += "</svg>\n";
  return out;
}

void Figure::save(const std::string& path) const {
  const std::string svg = to_svg();
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw std::runtime_error(fmt::format("cannot open '{}' for writing the plot", path));
  file << svg;
  file.close();
  if (!file) throw std::runtime_error(fmt::format("cannot write the plot to '{}'", path));
}

// ---- SLAM pictures ----------------------------------------------------------------------------------

Figure map_figure(const MapPlotData& data) {
  Figure fig(960, 800);
  fig.set_title(data.title);
  fig.set_subtitle(data.subtitle);
  fig.set_x_label("x [m]");
  fig.set_y_label("y [m]");
  fig.set_equal_aspect(true);

  // Drawing order, bottom to top: reference data first so the estimate stays visible over it, true
  // landmarks last because a thin '+' does not hide the estimate's dot under it.
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

}  // namespace slamkit::plot
