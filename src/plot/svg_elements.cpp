#include "svg_elements.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace slamkit::plot::svg {
namespace {

// Text is not measured, only estimated: DejaVu Sans and Helvetica average about 0.6 em per glyph.
constexpr double kGlyphWidth = 0.6;
// Points closer than this to the simplified line are dropped too: matplotlib's path simplification
// uses 1/9 px; smooth curves (uncertainty decaying over thousands of steps) shrink tenfold.
constexpr double kSimplifyTolerance = 0.1;
// Far-off points (explicit limits, a diverged landmark's ellipse) are clamped: renderers mishandle
// huge coordinates, and at this distance the clamp does not visibly change a line's direction.
constexpr double kMaxCoordinate = 1e6;

/// Length of the UTF-8 sequence starting with byte `lead`, or 0 if `lead` cannot start one.
int utf8_length(unsigned char lead) {
  if (lead < 0x80) return 1;
  if (lead >= 0xC2 && lead <= 0xDF) return 2;
  if (lead >= 0xE0 && lead <= 0xEF) return 3;
  if (lead >= 0xF0 && lead <= 0xF4) return 4;
  return 0;
}

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

std::string dash_array(Dash dash, double width) {
  // matplotlib's patterns, scaled with the line width so that thick dashed lines stay dashed.
  const auto scaled = [width](std::initializer_list<double> pattern) {
    std::string s;
    // Appended piece by piece: gcc 12 warns falsely (-Wrestrict) over "literal" + std::string.
    for (const double v : pattern) {
      if (!s.empty()) s += ' ';
      s += px(v * std::max(width, 1.0));
    }
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

bool marker_is_filled(const MarkerStyle& s) {
  return s.filled && (s.shape == Marker::kCircle || s.shape == Marker::kTriangle);
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

}  // namespace

bool finite(const Vector2& p) { return std::isfinite(p.x()) && std::isfinite(p.y()); }

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

std::string px(double v) {
  std::string s;
  put_tenths(s, tenths(v));
  return s;
}

std::string line_attributes(const LineStyle& s) { return "fill=\"none\" " + stroke_attributes(s); }

std::string ellipse_attributes(const EllipseStyle& s) {
  std::string a = s.fill_opacity > 0.0 ? fmt::format("fill=\"{}\"", s.edge.color.hex()) : "fill=\"none\"";
  a += opacity_attribute("fill-opacity", s.fill_opacity);
  return a + " " + stroke_attributes(s.edge);
}

std::string marker_attributes(const MarkerStyle& s) {
  std::string a = marker_is_filled(s) ? fmt::format("fill=\"{}\" stroke=\"none\"", s.color.hex())
                                      : fmt::format("fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"",
                                                    s.color.hex(), px(s.stroke_width));
  return a + opacity_attribute("opacity", s.opacity);
}

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
      d += 'h';
      d += px(2 * r);
      move(c.x(), c.y() - r);
      d += 'v';
      d += px(2 * r);
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

std::string text_element(double x, double y, std::string_view text, double size, std::string_view color,
                         Anchor anchor, std::string_view extra) {
  return fmt::format(
      R"(<text x="{}" y="{}" font-size="{}" fill="{}"{}{}>{}</text>)", px(x), px(y + 0.35 * size), px(size),
      color,
      anchor == Anchor::kStart ? std::string() : fmt::format(" text-anchor=\"{}\"", anchor_name(anchor)),
      extra, escape(text));
}

}  // namespace slamkit::plot::svg

namespace slamkit::plot {

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

}  // namespace slamkit::plot
