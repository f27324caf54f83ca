#include "axes.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <string_view>

#include "svg_elements.hpp"

namespace slamkit::plot::svg {
namespace {

constexpr double kTickSpacing = 80;  // aimed-for distance between major ticks
constexpr std::string_view kGridColor = "#e3e3e3";

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

double nice_step(double raw) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / magnitude;
  // Geometric midpoints between 1, 2, 5 and 10 keep the tick count within ~40% of the target.
  if (f < std::sqrt(2.0)) return magnitude;
  if (f < std::sqrt(10.0)) return 2 * magnitude;
  if (f < std::sqrt(50.0)) return 5 * magnitude;
  return 10 * magnitude;
}

int decimal_exponent(double v) { return static_cast<int>(std::floor(std::log10(std::abs(v)) + 1e-9)); }

/// Plain decimals ("0.01") while they stay short, powers of ten ("10⁻⁶") beyond.
std::vector<std::string> log_labels(const std::vector<double>& ticks) {
  const bool plain = std::all_of(ticks.begin(), ticks.end(), [](double v) { return v >= 1e-4 && v < 1e5; });
  std::vector<std::string> labels;
  for (const double v : ticks) {
    if (plain) {
      labels.push_back(fmt::format("{:g}", v));
      continue;
    }
    const int k = decimal_exponent(v);
    const double mantissa = v / std::pow(10.0, k);
    const std::string power = "10" + superscript(k);
    labels.push_back(std::abs(mantissa - 1.0) < 1e-6 ? power : fmt::format("{:g}\u00D7{}", mantissa, power));
  }
  return labels;
}

/// Digits of a plain label beyond which ticks are written as m×10^k.
constexpr int kMaxPlainDigits = 10;

}  // namespace

std::vector<std::string> linear_labels(const std::vector<double>& ticks) {
  double largest = 0;
  for (const double v : ticks) largest = std::max(largest, std::abs(v));
  const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : 0.0;
  // Decimals that tell the ticks apart.
  const int decimals = step > 0 ? std::max(0, -decimal_exponent(step)) : 0;
  const int integer_digits = largest >= 1 ? decimal_exponent(largest) + 1 : 1;
  // A plot of an estimate that has run off to 1e300 m, or of steps of 1e-12, still gets labels a
  // few characters wide: a mantissa with the digits the step needs, times a power of ten, where
  // that is the shorter form.
  const int k = largest > 0 ? decimal_exponent(largest) : 0;
  const int mantissa_decimals = step > 0 ? std::max(0, k - decimal_exponent(step)) : 0;
  const bool plain = integer_digits + decimals <= std::max(kMaxPlainDigits, mantissa_decimals + 4);
  std::vector<std::string> labels;
  for (double v : ticks) {
    if (v == 0.0) v = 0.0;  // -0.0 (from ceil(-0.5) * step) would print as "-0"
    if (plain || v == 0.0)
      labels.push_back(with_minus_sign(fmt::format("{:.{}f}", v, plain ? decimals : 0)));
    else
      labels.push_back(with_minus_sign(
          fmt::format("{:.{}f}\u00D7{}", v / std::pow(10.0, k), mantissa_decimals, "10" + superscript(k))));
  }
  return labels;
}

Ticks compute_ticks(const Frame& f) {
  Ticks t;
  // Fewer x ticks while their labels would collide (long numbers on a narrow axis).
  for (double target = f.plot_width / kTickSpacing;; target *= 0.7) {
    t.x = linear_ticks(f.x_min, f.x_max, std::max(target, 1.0));
    t.x_labels = linear_labels(t.x);
    double widest = 0;
    for (const std::string& label : t.x_labels) widest = std::max(widest, text_width(label, kTickSize));
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
    t.y_labels = linear_labels(t.y);
  }
  return t;
}

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

}  // namespace slamkit::plot::svg

namespace slamkit::plot {

using namespace svg;

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

}  // namespace slamkit::plot
