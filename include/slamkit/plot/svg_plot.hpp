#pragma once
// SVG pictures of SLAM results: a map of trajectories and landmarks with their covariance ellipses,
// and the landmark standard deviations over time. SVG is written directly, without a plotting
// dependency, so every run can leave a picture that any browser opens.
//
// A small general core (Figure) does the layout work that makes a plot readable at a glance: 1-2-5
// ticks, a light grid, equal aspect for maps, log scale for uncertainties, a legend outside the data,
// and compact output (pixel coordinates rounded to 0.1 px, polylines thinned to 0.5 px steps and
// simplified to 0.1 px).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "slamkit/core/types.hpp"

namespace slamkit::plot {

struct Color {
  std::uint8_t r = 0, g = 0, b = 0;
  /// "#rrggbb".
  std::string hex() const;
  bool operator==(const Color&) const = default;
};

/// The Okabe-Ito palette, distinguishable under the common colour-vision deficiencies, plus the
/// neutral tones used for ground truth and reference data. Its yellow is left out: thin yellow lines
/// vanish on white.
namespace palette {
inline constexpr Color kBlack{0, 0, 0};
inline constexpr Color kDark{34, 34, 34};
inline constexpr Color kGrey{120, 120, 120};
inline constexpr Color kBlue{0, 114, 178};
inline constexpr Color kVermillion{213, 94, 0};
inline constexpr Color kGreen{0, 158, 115};
inline constexpr Color kPurple{204, 121, 167};
inline constexpr Color kOrange{230, 159, 0};
inline constexpr Color kSkyBlue{86, 180, 233};
}  // namespace palette

/// Number of distinct colours categorical_color() cycles through.
inline constexpr std::size_t kCategoricalColors = 7;
/// The i-th colour of the categorical palette (blue, vermillion, green, purple, orange, sky blue,
/// black), cycling after kCategoricalColors.
Color categorical_color(std::size_t i);
/// Viridis at t in [0, 1] (clamped), stopping short of its pale yellow end so that the last colour
/// still reads as a thin line on white. Perceptually uniform and colour-blind safe.
Color sequential_color(double t);

enum class Dash { kSolid, kDashed, kDotted, kDashDot };
enum class Marker { kCircle, kCross, kPlus, kTriangle };
enum class Anchor { kStart, kMiddle, kEnd };

struct LineStyle {
  Color color = palette::kBlue;
  double width = 1.5;  // px
  Dash dash = Dash::kSolid;
  double opacity = 1.0;
};

struct MarkerStyle {
  Marker shape = Marker::kCircle;
  Color color = palette::kBlue;
  double size = 6.0;          // px, outer diameter
  double stroke_width = 1.2;  // px; outline of crosses, pluses and unfilled shapes
  bool filled = true;         // circles and triangles only
  double opacity = 1.0;
};

struct EllipseStyle {
  LineStyle edge{palette::kVermillion, 1.0};
  double fill_opacity = 0.0;  // the fill has the edge colour
};

struct TextStyle {
  Color color = palette::kDark;
  double size = 11.0;  // px
  Anchor anchor = Anchor::kStart;
};

/// The resolved geometry of a figure: canvas, plot area in pixels and the data range it shows.
/// Pixel y grows downwards, as in SVG.
struct Frame {
  double width = 0, height = 0;                       // canvas, px
  double left = 0, top = 0;                           // plot area corner, px
  double plot_width = 0, plot_height = 0;             // px
  double x_min = 0, x_max = 1, y_min = 0, y_max = 1;  // data units (not logarithms)
  bool log_y = false;

  /// Pixel position of a data point; non-finite where the point cannot be shown (y <= 0 on a log
  /// axis, non-finite input).
  Vector2 to_pixel(const Vector2& p) const;
  Vector2 to_data(const Vector2& px) const;
};

/// Tick values at a 1, 2 or 5 x 10^k spacing inside [lo, hi], about target_count of them, none
/// more than one step from either end. Empty if the range is not finite or lo > hi.
std::vector<double> linear_ticks(double lo, double hi, double target_count);
/// Ticks for a log axis over [lo, hi], 0 < lo < hi: powers of ten when the range holds at least
/// three (every n-th one when it holds many), else 1-2-5 x 10^k values, else linear ticks.
std::vector<double> log_ticks(double lo, double hi);

/// A single plot: data added in drawing order (later on top), an automatic or explicit data range,
/// and title, axis labels and legend around it.
class Figure {
 public:
  /// Canvas size in px. With equal aspect the height is an upper bound: a map wider than the plot
  /// area gets a shorter canvas rather than empty bands above and below the data.
  explicit Figure(double width = 900, double height = 600);

  void set_title(std::string title) { title_ = std::move(title); }
  /// A line of smaller grey text under the title, typically the run's headline metrics; '\n' starts
  /// a new line.
  void set_subtitle(std::string subtitle) { subtitle_ = std::move(subtitle); }
  void set_x_label(std::string label) { x_label_ = std::move(label); }
  void set_y_label(std::string label) { y_label_ = std::move(label); }
  /// One data unit spans the same number of pixels in x and y, as a map needs. Ignored with log_y.
  void set_equal_aspect(bool on) { equal_aspect_ = on; }
  /// Logarithmic y axis; points with y <= 0 are not drawn.
  void set_log_y(bool on) { log_y_ = on; }
  /// Fixed data ranges instead of the automatic ones; equal aspect may still widen one of them.
  /// Throws std::invalid_argument unless lo < hi are finite and, on a log y axis, lo > 0 (checked
  /// again by frame() and to_svg() for limits set before the axis became logarithmic).
  void set_x_limits(double lo, double hi);
  void set_y_limits(double lo, double hi);

  /// A polyline; non-finite points break it into separate pieces and are never written. Here and
  /// below, a series without any finite point is left out, legend entry included, and items that
  /// share a label share one legend entry; an empty label means no entry.
  void add_line(std::span<const Vector2> points, const LineStyle& style, std::string label = {});
  /// One marker at each finite point.
  void add_markers(std::span<const Vector2> points, const MarkerStyle& style, std::string label = {});
  /// The n_sigma contour of a Gaussian with covariance `cov` around `centre`. Returns false, drawing
  /// nothing, when the ellipse does not exist: non-finite input, a covariance that is not positive
  /// semi-definite, or one of zero size. A rank-one covariance is drawn as the flat ellipse it is.
  bool add_ellipse(const Vector2& centre, const Matrix2& cov, double n_sigma, const EllipseStyle& style,
                   std::string label = {});
  void add_text(const Vector2& at, std::string text, const TextStyle& style = {});
  /// A raster image (PNG bytes, embedded in the SVG) stretched over the data rectangle from
  /// `lower_left` spanning `size`; its first row is drawn at the top. Drawn in order like the rest, so
  /// add it first to have the data over it.
  void add_image(std::string png, const Vector2& lower_left, const Vector2& size);

  /// Legend entries that explain a style rather than name one item, e.g. "one line per landmark".
  void add_legend_entry(std::string label, const LineStyle& style);
  void add_legend_entry(std::string label, const MarkerStyle& style);
  /// A colour bar under the legend for data coloured with sequential_color((v - lo) / (hi - lo)).
  void set_colorbar(std::string label, double lo, double hi);

  /// Margins left and right of the plot area of at least these sizes [px], so that figures drawn one
  /// above the other line up (stacked_svg sets them).
  void set_min_margins(double left, double right) {
    min_left_ = left;
    min_right_ = right;
  }

  /// Layout after automatic ranging and equal-aspect adjustment, as to_svg() draws it. Throws
  /// std::invalid_argument if titles, labels and legend leave no room for the plot area.
  Frame frame() const;
  std::string to_svg() const;
  /// Throws std::runtime_error naming the path if the file cannot be written.
  void save(const std::string& path) const;

 private:
  struct Line {
    std::vector<Vector2> points;
    LineStyle style;
  };
  struct Markers {
    std::vector<Vector2> points;
    MarkerStyle style;
  };
  struct Ellipse {
    Vector2 centre;
    Vector2 major, minor;  // semi-axis vectors, data units
    EllipseStyle style;
  };
  struct Text {
    Vector2 at;
    std::string text;
    TextStyle style;
  };
  struct Image {
    std::string png;
    Vector2 lower_left, size;
  };
  using Item = std::variant<Line, Markers, Ellipse, Text, Image>;
  using LegendSample = std::variant<LineStyle, MarkerStyle, EllipseStyle>;
  struct LegendEntry {
    std::string label;
    LegendSample sample;
  };
  struct Colorbar {
    std::string label;
    double lo = 0, hi = 1;
  };
  struct Limits {
    bool set = false;
    double lo = 0, hi = 1;
  };

  void add_to_legend(std::string label, LegendSample sample);
  double legend_box_width() const;
  double legend_box_height() const;
  /// The column right of the plot area that holds the legend box and the colour bar.
  double legend_width() const;
  double legend_height() const;
  void write_data(std::string& out, const Frame& f, std::string_view clip_id) const;
  void write_labels(std::string& out, const Frame& f) const;
  void write_legend(std::string& out, const Frame& f, std::string_view gradient_id) const;
  /// Everything inside the root element but the background; `id_suffix` makes its ids unique.
  void write_body(std::string& out, const Frame& f, std::string_view id_suffix) const;
  friend std::string stacked_svg(std::vector<Figure> panels);

  double width_, height_;
  std::string title_, subtitle_, x_label_, y_label_;
  bool equal_aspect_ = false;
  bool log_y_ = false;
  double min_left_ = 0, min_right_ = 0;
  Limits x_limits_, y_limits_;
  std::vector<Item> items_;
  std::vector<LegendEntry> legend_;
  std::optional<Colorbar> colorbar_;
};

/// The panels one above the other in one SVG, their plot areas lined up (e.g. curves over one time
/// axis in different units); each keeps its own title, labels and legend, and the document takes the
/// first one's title. Throws std::invalid_argument without panels.
std::string stacked_svg(std::vector<Figure> panels);

// ---- SLAM pictures --------------------------------------------------------------------------------

struct MapPlotData {
  std::string title;
  std::string subtitle;
  std::vector<Vector2> true_trajectory;
  std::vector<Vector2> estimated_trajectory;
  std::vector<Vector2> dead_reckoning;
  std::vector<Vector2> reference_points;  // e.g. GPS fixes, drawn as small dots
  std::vector<Landmark> true_landmarks;
  std::vector<Landmark> estimated_landmarks;
  double ellipse_sigma = 2.0;  // contour drawn around each estimated landmark
  /// An occupancy grid map under everything else (PNG bytes over the rectangle from grid_lower_left
  /// spanning grid_size [m]); empty for landmark maps.
  std::string grid_png;
  Vector2 grid_lower_left = Vector2::Zero();
  Vector2 grid_size = Vector2::Zero();
  /// The grid's part worth looking at (the box of its occupied cells [m]); when set (max > min), the
  /// picture frames it and the trajectories, not the whole grid, whose far edges only beams through
  /// a window or a door reached.
  Vector2 grid_focus_min = Vector2::Zero();
  Vector2 grid_focus_max = Vector2::Zero();
};

/// The map: equal aspect, metres on both axes; empty series are left out of the legend.
Figure map_figure(const MapPlotData& data);
void write_map_svg(const std::string& path, const MapPlotData& data);

struct StdSeries {
  int id = 0;
  std::vector<double> t;      // s
  std::vector<double> std_x;  // m
  std::vector<double> std_y;  // m
};

struct StdPlotData {
  std::string title;
  std::string subtitle;
  std::vector<StdSeries> series;
  bool log_y = true;
};

/// Landmark standard deviation over time (Figure 3 of Durrant-Whyte & Bailey's SLAM tutorial). Each
/// landmark is one thin line of max(std_x, std_y): the worse axis is the uncertainty that matters,
/// and one line per landmark keeps 100+ landmarks legible where two would not. Up to
/// kCategoricalColors landmarks get a colour and a legend entry each; more are coloured by id through
/// sequential_color() and explained by a colour bar. Throws std::invalid_argument if a series' t,
/// std_x and std_y differ in length.
Figure landmark_std_figure(const StdPlotData& data);
void write_landmark_std_svg(const std::string& path, const StdPlotData& data);

/// Pose NEES over time, of one run or averaged over Monte Carlo runs, with the interval it stays in
/// 95% of the time if the filter is consistent.
struct NeesPlotData {
  std::string title;
  std::string subtitle;
  std::vector<Vector2> nees;  // (t [s], NEES)
  double band_lo = 0.0, band_hi = 0.0;
  double dof = 3.0;  // the consistent mean
  int runs = 1;      // averaged over this many runs
};

/// Log y axis (an inconsistent filter's NEES spans decades); the band and the consistent mean as
/// dashed lines. Throws std::invalid_argument without finite points or with band_lo >= band_hi.
Figure nees_figure(const NeesPlotData& data);

}  // namespace slamkit::plot
