#pragma once
// The axes of a plot: tick positions and their labels for a Frame, and the grid, frame and tick
// marks drawn around the data. Private to the plot module.
#include <string>
#include <vector>

#include "slamkit/plot/svg_plot.hpp"

namespace slamkit::plot::svg {

// Typography of the axes, shared with the figure's layout around them, in px (matplotlib's defaults
// at 100 dpi).
inline constexpr double kTickSize = 11;
inline constexpr double kTickLength = 5;
inline constexpr double kMinorTickLength = 3;
inline constexpr double kTickGap = 4;  // tick to its label

struct Ticks {
  std::vector<double> x, y, y_minor;
  std::vector<std::string> x_labels, y_labels;
};

Ticks compute_ticks(const Frame& f);

/// Labels of evenly spaced ticks (linear_ticks): plain decimals with the decimals that tell them
/// apart while those stay short, else a mantissa times a shared power of ten.
std::vector<std::string> linear_labels(const std::vector<double>& ticks);

/// The grid goes behind the data, at the major ticks.
void write_grid(std::string& out, const Frame& f, const Ticks& t);
/// Frame, ticks and tick labels go on top of the data.
void write_axes(std::string& out, const Frame& f, const Ticks& t);

}  // namespace slamkit::plot::svg
