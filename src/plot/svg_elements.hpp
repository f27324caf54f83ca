#pragma once
// The SVG writing core under the plots (axes.cpp, figure.cpp): text as SVG needs it, pixel numbers
// rounded to 0.1 px, style attributes, markers, and polyline paths thinned and simplified to keep
// files small. Private to the plot module.
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "slamkit/plot/svg_plot.hpp"

namespace slamkit::plot::svg {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Thinning and rounding keep files small without visible change: points closer than this to the
// previous kept one are dropped, and coordinates are written to 0.1 px (about 1/6000 of a plot's
// width, i.e. nearly 4 significant digits of the data range).
inline constexpr double kMinStep = 0.5;

inline constexpr std::string_view kTextColor = "#222222";
inline constexpr std::string_view kTickColor = "#444444";

bool finite(const Vector2& p);

/// Text for XML content and attributes. Browsers reject the whole file on a stray '<', on control
/// characters XML 1.0 forbids and on invalid UTF-8 (e.g. a Latin-1 file name in a title), so the
/// first are escaped, the second dropped and the last replaced by U+FFFD.
std::string escape(std::string_view s);
/// Text is not measured, only estimated from its glyph count.
double text_width(std::string_view s, double size);
std::vector<std::string> split_lines(const std::string& s);

/// A pixel quantity (coordinate, size) rounded to 0.1 px.
std::string px(double v);

std::string line_attributes(const LineStyle& s);
std::string ellipse_attributes(const EllipseStyle& s);
std::string marker_attributes(const MarkerStyle& s);
/// Path data of one marker centred on pixel `c`.
void put_marker(std::string& d, const Vector2& c, const MarkerStyle& s);
/// Path data of a polyline in pixels: broken at non-finite points, thinned to kMinStep, simplified,
/// and written as relative moves between rounded positions so that rounding never accumulates.
std::string polyline_path(const std::vector<Vector2>& pixels);
/// One `<text>` element; `y` is the visual centre of the text, not its baseline.
std::string text_element(double x, double y, std::string_view text, double size, std::string_view color,
                         Anchor anchor, std::string_view extra = {});

}  // namespace slamkit::plot::svg
