#include "slamkit/plot/information_matrix_svg.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "slamkit/core/atomic_file.hpp"
#include "svg_elements.hpp"

// The helpers live in a namespace of their own: the plot module is compiled in unity batches, where
// the anonymous namespaces of its files meet.
namespace slamkit::plot::information_svg {
namespace {

using Sparse = Eigen::SparseMatrix<double>;

// Layout, in px. The picture is a fixed square whatever the matrix's size: pictures of the same filter
// before and after sparsification, or of two maps, are compared side by side, cell by cell.
constexpr double kSide = 480;
constexpr double kPad = 12;
constexpr double kTitleSize = 14;
constexpr double kLabelSize = 11;
constexpr double kCaptionSize = 11.5;
constexpr double kCaptionLine = 1.45 * kCaptionSize;
constexpr double kTickLength = 4;
constexpr double kTickGap = 3;       // tick to its label
constexpr double kLabelSpacing = 6;  // the least room between two labels of one axis
constexpr double kPanelGap = 28;
constexpr double kLegendGap = 10;
constexpr double kLegendBarWidth = 14;
constexpr double kLegendBarHeight = 180;
constexpr double kLegendWidth = 150;
constexpr std::size_t kMaxSegments = 8;  // landmark ranges labelled per axis, at most
constexpr int kCaptionLines = 3;

constexpr std::string_view kFont = "DejaVu Sans, Helvetica, Arial, sans-serif";
constexpr std::string_view kCaptionColor = "#555555";
constexpr std::string_view kScaleId = "slamkit-information-scale";
constexpr std::string_view kVehicle = "vehicle";

// The lightest grey of a drawn cell: a link of tiny magnitude is still a link (it costs the filter
// as much as a strong one), so it must stay visible on the white of "no link".
constexpr double kLightestGrey = 230;

/// Grey level of a normalised magnitude: darker for stronger. The square root spreads the weak links,
/// which are most of a SEIF's and which sparsification is about, over more of the grey range.
int grey_level(double magnitude) {
  return static_cast<int>(std::lround(kLightestGrey * (1.0 - std::sqrt(std::clamp(magnitude, 0.0, 1.0)))));
}

std::string grey_hex(int level) { return fmt::format("#{0:02x}{0:02x}{0:02x}", level); }

/// An integer with thousands separated by commas: 3,000,000 is read at a glance, 3000000 is counted.
std::string grouped(std::uint64_t v) {
  const std::string digits = std::to_string(v);
  std::string out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

/// A share of `total` as a percentage with two significant digits below 10%: the linked share of a
/// large sparse map is a small number whose size is what matters.
std::string percentage(std::uint64_t part, std::uint64_t total) {
  if (part == 0) return "0%";
  if (part == total) return "100%";
  const double p = 100.0 * static_cast<double>(part) / static_cast<double>(total);
  int decimals = std::clamp(1 - static_cast<int>(std::floor(std::log10(p))), 1, 8);
  std::string text = fmt::format("{:.{}f}%", p, decimals);
  // 99.97% is not all: more decimals until the rounding says so too.
  while (text.starts_with("100") && decimals < 8) text = fmt::format("{:.{}f}%", p, ++decimals);
  return text;
}

std::size_t variable_of_row(std::size_t row) { return row < 3 ? 0 : 1 + (row - 3) / 2; }
std::size_t first_row_of(std::size_t variable) { return variable == 0 ? 0 : 3 + 2 * (variable - 1); }

/// The cells of an axis: the vehicle keeps a cell of its own (its links are the ones SEIF's
/// sparsification is about, and a bin would hide them among landmarks'), the landmarks share the others
/// in runs of `per_cell` by index, as many per cell as max_cells requires. Only max_cells = 1 puts the
/// vehicle with them.
struct Binning {
  std::size_t variables = 1;  // the vehicle and the landmarks
  std::size_t cells = 1;      // along each axis
  std::size_t per_cell = 1;   // landmarks a landmark cell covers

  static Binning of(std::size_t variables, std::size_t max_cells) {
    const std::size_t landmarks = variables - 1;
    if (landmarks == 0 || max_cells == 1) return {variables, 1, landmarks};
    const std::size_t slots = std::min(variables, max_cells) - 1;
    const std::size_t per_cell = (landmarks + slots - 1) / slots;
    return {variables, 1 + (landmarks + per_cell - 1) / per_cell, per_cell};
  }
  std::size_t cell_of(std::size_t variable) const {
    return cells == 1 || variable == 0 ? 0 : 1 + (variable - 1) / per_cell;
  }
  /// The first variable of a cell; `variables` for the end of the last.
  std::size_t first_of(std::size_t cell) const {
    if (cell == 0) return 0;
    if (cells == 1) return variables;
    return std::min(variables, 1 + (cell - 1) * per_cell);
  }
  double cell_px() const { return kSide / static_cast<double>(cells); }
  /// Where landmark index `l` (fractional between landmarks) falls along an axis, in px from its start.
  double landmark_px(double l) const { return cell_px() * (1.0 + l / static_cast<double>(per_cell)); }
};

struct Picture {
  std::string cells;  // the <rect>s, in cell units
  Binning binning;
  std::size_t rows = 0;
  std::uint64_t stored_nonzeros = 0;
  std::uint64_t linked_pairs = 0;
};

std::string panel_name(std::size_t index, const InformationMatrixPanel& panel) {
  return panel.title.empty() ? fmt::format("information matrix panel {}", index + 1)
                             : fmt::format("information matrix panel {} (\"{}\")", index + 1, panel.title);
}

/// The diagonal, checked: the normalisation divides by it, and the rows' grouping into variables
/// needs the vehicle's 3 rows and whole landmarks.
std::vector<double> checked_diagonal(const Sparse& m, const std::string& name) {
  if (m.rows() != m.cols())
    throw std::invalid_argument(fmt::format("{}: the matrix is {} x {}, not square", name, m.rows(), m.cols()));
  if (m.rows() < 3)
    throw std::invalid_argument(
        fmt::format("{}: the matrix has {} rows; it needs at least 3 (the vehicle's pose)", name, m.rows()));
  if ((m.rows() - 3) % 2 != 0)
    throw std::invalid_argument(
        fmt::format("{}: the matrix has {} rows, so an odd number ({}) of landmark rows; each landmark has 2", name,
                    m.rows(), m.rows() - 3));
  std::vector<double> diagonal(static_cast<std::size_t>(m.rows()), 0.0);
  for (Eigen::Index col = 0; col < m.outerSize(); ++col)
    for (Sparse::InnerIterator it(m, col); it; ++it) {
      if (it.row() == col) {
        diagonal[static_cast<std::size_t>(col)] = it.value();
      } else if (!std::isfinite(it.value())) {
        throw std::invalid_argument(
            fmt::format("{}: the entry at row {}, column {} is {}, not finite", name, it.row(), col, it.value()));
      }
    }
  for (std::size_t row = 0; row < diagonal.size(); ++row)
    if (!(std::isfinite(diagonal[row]) && diagonal[row] > 0))
      throw std::invalid_argument(
          fmt::format("{}: the diagonal entry of row {} is {}; an information matrix's diagonal is positive and finite",
                      name, row, diagonal[row]));
  return diagonal;
}

/// One pass over the stored entries, a column of cells at a time (its matrix columns are consecutive
/// in column-major storage), keeping the largest magnitude of each cell of that column it reaches:
/// time linear in the entries, memory linear in the rows, output bounded by the cells.
Picture draw_cells(const Sparse& m, const std::vector<double>& diagonal, std::size_t max_cells) {
  Picture p;
  p.rows = diagonal.size();
  const std::size_t variables = variable_of_row(p.rows - 1) + 1;
  p.binning = Binning::of(variables, max_cells);
  const Binning& bins = p.binning;

  std::vector<double> inverse_sqrt(p.rows);
  std::vector<std::uint32_t> cell_of_row(p.rows);
  for (std::size_t r = 0; r < p.rows; ++r) {
    inverse_sqrt[r] = 1.0 / std::sqrt(diagonal[r]);
    cell_of_row[r] = static_cast<std::uint32_t>(bins.cell_of(variable_of_row(r)));
  }
  constexpr double kUntouched = -1;
  std::vector<double> largest(bins.cells, kUntouched);
  std::vector<std::uint32_t> touched;
  // The column variable that last linked each row variable: a pair is counted once however many of
  // its rows hold entries.
  std::vector<std::size_t> linked_from(variables, std::numeric_limits<std::size_t>::max());

  auto out = std::back_inserter(p.cells);
  for (std::size_t x = 0; x < bins.cells; ++x) {
    const std::size_t col_end = first_row_of(bins.first_of(x + 1));
    for (std::size_t col = first_row_of(bins.first_of(x)); col < col_end; ++col) {
      const std::size_t col_variable = variable_of_row(col);
      const double col_scale = inverse_sqrt[col];
      for (Sparse::InnerIterator it(m, static_cast<Eigen::Index>(col)); it; ++it) {
        if (it.value() == 0) continue;
        const auto row = static_cast<std::size_t>(it.row());
        ++p.stored_nonzeros;
        // Both triangles are stored: the pairs are counted in the lower one.
        const std::size_t row_variable = variable_of_row(row);
        if (row_variable > col_variable && linked_from[row_variable] != col_variable) {
          linked_from[row_variable] = col_variable;
          ++p.linked_pairs;
        }
        const double magnitude = std::abs(it.value()) * inverse_sqrt[row] * col_scale;
        const std::uint32_t cell = cell_of_row[row];
        if (largest[cell] == kUntouched) touched.push_back(cell);
        largest[cell] = std::max(largest[cell], magnitude);
      }
    }
    for (const std::uint32_t cell : touched) {
      fmt::format_to(out, "<rect x=\"{0}\" y=\"{1}\" width=\"1\" height=\"1\" fill=\"#{2:02x}{2:02x}{2:02x}\"/>\n", x,
                     cell, grey_level(largest[cell]));
      largest[cell] = kUntouched;
    }
    touched.clear();
  }
  return p;
}

// ---- Axis labels ------------------------------------------------------------------------------------

struct AxisLabel {
  double at = 0;  // px from the picture's edge: centre, or end with end_anchored
  std::string text;
  bool end_anchored = false;
};

struct Axis {
  std::vector<double> ticks;  // px from the picture's edge
  std::vector<AxisLabel> top, left;
};

std::string index_range(std::size_t first, std::size_t last) {
  return first == last ? std::to_string(first) : fmt::format("{}\u2013{}", first, last);
}

std::size_t next_125(std::size_t step) {
  std::size_t decade = 1;
  while (step >= 10 * decade) decade *= 10;
  const std::size_t mantissa = step / decade;
  return (mantissa == 1 ? 2 : mantissa == 2 ? 5 : 10) * decade;
}

/// A run of landmarks by index and where it is drawn, in px from the start of an axis.
struct Segment {
  std::size_t first = 0, last = 0;
  double start = 0, end = 0;
};

/// The runs of landmarks the axes label. A cell each when every cell has room for its label: the
/// ranges are then exactly the cells'. Else runs of a 1-2-5 number of landmarks, the least whose
/// labels fit their runs across the columns (the narrow direction for labels) but no less than a
/// cell's worth, since a tick inside a cell would divide what the cell does not.
std::vector<Segment> landmark_segments(const Binning& bins) {
  const std::size_t landmarks = bins.variables - 1;
  const double cell = bins.cell_px();
  std::vector<Segment> out;
  const auto range_width = [](std::size_t first, std::size_t last) {
    return svg::text_width(index_range(first, last), kLabelSize);
  };
  // Even a one-digit label needs this much, which bounds the cells checked one by one.
  if (cell >= svg::text_width("0", kLabelSize) + kLabelSpacing) {
    bool fits = true;
    for (std::size_t c = 1; c < bins.cells; ++c) {
      const std::size_t first = (c - 1) * bins.per_cell, last = std::min(landmarks, c * bins.per_cell) - 1;
      fits = fits && cell >= range_width(first, last) + kLabelSpacing;
      out.push_back({first, last, cell * static_cast<double>(c), cell * static_cast<double>(c + 1)});
    }
    if (fits) return out;
    out.clear();
  }
  std::size_t step = 1;
  while (step < bins.per_cell) step = next_125(step);
  for (;; step = next_125(step)) {
    const std::size_t segments = (landmarks + step - 1) / step;
    const std::size_t full = landmarks / step;
    double widest = range_width((segments - 1) * step, landmarks - 1);
    if (full > 0) widest = std::max(widest, range_width((full - 1) * step, full * step - 1));
    const double segment_px = cell * static_cast<double>(step) / static_cast<double>(bins.per_cell);
    if (step >= landmarks || (segments <= kMaxSegments && segment_px >= widest + kLabelSpacing)) break;
  }
  for (std::size_t first = 0; first < landmarks; first += step) {
    const std::size_t last = std::min(landmarks, first + step) - 1;
    out.push_back(
        {first, last, bins.landmark_px(static_cast<double>(first)), bins.landmark_px(static_cast<double>(last + 1))});
  }
  return out;
}

/// The vehicle by name, the landmarks by index ranges. Labels that would touch a neighbour of their
/// axis are left out, their ticks kept.
Axis axis_labels(const Binning& bins) {
  Axis axis;
  const std::size_t landmarks = bins.variables - 1;
  if (bins.cells == 1) {
    const std::string all = landmarks == 0 ? std::string(kVehicle)
                                           : fmt::format("{}, landmark{} {}", kVehicle, landmarks == 1 ? "" : "s",
                                                         index_range(0, landmarks - 1));
    axis.top.push_back({kSide / 2, all, false});
    axis.left.push_back({kSide / 2, all, false});
    return axis;
  }
  const double cell = bins.cell_px();
  const double vehicle_width = svg::text_width(kVehicle, kLabelSize);
  // Across the columns the name sits over the vehicle's cell when it fits there, else it ends at the
  // cell's edge and reaches into the empty corner above the rows' labels.
  if (cell >= vehicle_width + kLabelSpacing) {
    axis.top.push_back({cell / 2, std::string(kVehicle), false});
  } else {
    axis.top.push_back({cell, std::string(kVehicle), true});
  }
  axis.left.push_back({cell / 2, std::string(kVehicle), false});
  double top_end = cell, left_end = cell / 2 + kLabelSize / 2;
  for (const Segment& s : landmark_segments(bins)) {
    axis.ticks.push_back(s.start);
    const std::string text = index_range(s.first, s.last);
    const double centre = (s.start + s.end) / 2;
    const double half_width = svg::text_width(text, kLabelSize) / 2;
    if (centre - half_width >= top_end + kLabelSpacing) {
      axis.top.push_back({centre, text, false});
      top_end = centre + half_width;
    }
    if (centre - kLabelSize / 2 >= left_end + kLabelSpacing / 2) {
      axis.left.push_back({centre, text, false});
      left_end = centre + kLabelSize / 2;
    }
  }
  return axis;
}

double left_margin(const Axis& axis) {
  double widest = 0;
  for (const AxisLabel& l : axis.left) widest = std::max(widest, svg::text_width(l.text, kLabelSize));
  return kPad + widest + kTickLength + kTickGap;
}

// ---- The document -----------------------------------------------------------------------------------

constexpr double kTopMargin = kPad + kTitleSize + 10 + kLabelSize + kTickGap + kTickLength;

std::vector<std::string> caption_lines(const Picture& p) {
  const std::uint64_t variables = p.binning.variables;
  const std::uint64_t pairs = variables * (variables - 1) / 2;
  std::vector<std::string> lines;
  lines.push_back(
      fmt::format("{0} \u00D7 {0} matrix, {1} stored non-zeros", grouped(p.rows), grouped(p.stored_nonzeros)));
  lines.push_back(pairs == 0 ? std::string("no landmarks, so no variable pairs")
                             : fmt::format("{} of {} variable pairs linked ({})", grouped(p.linked_pairs),
                                           grouped(pairs), percentage(p.linked_pairs, pairs)));
  const std::string variables_text =
      fmt::format("vehicle + {} landmark{}", grouped(variables - 1), variables == 2 ? "" : "s");
  if (variables == 1) {
    lines.push_back("the vehicle alone");
  } else if (p.binning.cells == variables) {
    lines.push_back(variables_text + "; a cell per variable pair");
  } else if (p.binning.cells == 1) {
    lines.push_back(variables_text + " in one cell, its strongest link");
  } else {
    lines.push_back(fmt::format("{}; up to {} landmarks a cell, its strongest link shown", variables_text,
                                grouped(p.binning.per_cell)));
  }
  return lines;
}

void write_panel(std::string& out, double x0, const std::string& title, const Picture& p, const Axis& axis) {
  auto o = std::back_inserter(out);
  const double y0 = kTopMargin;
  out += "<g>\n";
  if (!title.empty())
    out += svg::text_element(x0 + kSide / 2, kPad + kTitleSize / 2, title, kTitleSize, svg::kTextColor, Anchor::kMiddle,
                             " font-weight=\"bold\"") +
           '\n';
  const double top_y = y0 - kTickLength - kTickGap - kLabelSize / 2;
  for (const AxisLabel& l : axis.top)
    out += svg::text_element(x0 + l.at, top_y, l.text, kLabelSize, svg::kTextColor,
                             l.end_anchored ? Anchor::kEnd : Anchor::kMiddle) +
           '\n';
  for (const AxisLabel& l : axis.left)
    out +=
        svg::text_element(x0 - kTickLength - kTickGap, y0 + l.at, l.text, kLabelSize, svg::kTextColor, Anchor::kEnd) +
        '\n';
  std::string ticks;
  for (const double t : axis.ticks) {
    ticks += fmt::format("M{} {}v-{}", svg::px(x0 + t), svg::px(y0), svg::px(kTickLength));
    ticks += fmt::format("M{} {}h-{}", svg::px(x0), svg::px(y0 + t), svg::px(kTickLength));
  }
  if (!ticks.empty())
    fmt::format_to(o, "<path d=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1\"/>\n", ticks, svg::kTickColor);
  // Cells are written in cell units under one transform: each <rect> is short, and neighbouring
  // cells share their edges exactly, so no seams show between them.
  fmt::format_to(o, "<g class=\"cells\" transform=\"translate({} {}) scale({:.6g})\" shape-rendering=\"crispEdges\">\n",
                 svg::px(x0), svg::px(y0), kSide / static_cast<double>(p.binning.cells));
  out += p.cells;
  out += "</g>\n";
  fmt::format_to(o,
                 "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"{}\" "
                 "stroke-width=\"1\"/>\n",
                 svg::px(x0), svg::px(y0), svg::px(kSide), svg::px(kSide), svg::kTickColor);
  const std::vector<std::string> lines = caption_lines(p);
  for (std::size_t i = 0; i < lines.size(); ++i)
    out += svg::text_element(x0, y0 + kSide + 14 + kCaptionLine * (static_cast<double>(i) + 0.5), lines[i],
                             kCaptionSize, kCaptionColor, Anchor::kStart) +
           '\n';
  out += "</g>\n";
}

/// The grey scale, once for all panels: its bar is drawn through the same grey_level() as the cells,
/// sampled finely enough that the gradient between samples stays within a grey level or two of it.
void write_legend(std::string& out, double x) {
  auto o = std::back_inserter(out);
  const double y = kTopMargin;
  out += "<g>\n";
  out += svg::text_element(x, y + kLabelSize / 2, "partial correlation", kLabelSize, svg::kTextColor, Anchor::kStart) +
         '\n';
  out += svg::text_element(x, y + 1.5 * kLabelSize + 4, "|\u03A9ij| / \u221A(\u03A9ii \u03A9jj)", kLabelSize,
                           svg::kTextColor, Anchor::kStart) +
         '\n';
  const double bar_y = y + 2 * kLabelSize + 16;
  fmt::format_to(o,
                 "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"url(#{})\" stroke=\"{}\" "
                 "stroke-width=\"0.8\"/>\n",
                 svg::px(x), svg::px(bar_y), svg::px(kLegendBarWidth), svg::px(kLegendBarHeight), kScaleId,
                 svg::kTickColor);
  std::string marks;
  for (int i = 0; i <= 4; ++i) {
    const double magnitude = 1.0 - 0.25 * i;
    const double tick_y = bar_y + kLegendBarHeight * (1.0 - magnitude);
    marks += fmt::format("M{} {}h{}", svg::px(x + kLegendBarWidth), svg::px(tick_y), svg::px(kTickLength));
    out += svg::text_element(x + kLegendBarWidth + kTickLength + kTickGap, tick_y, fmt::format("{:g}", magnitude),
                             kLabelSize, svg::kTextColor, Anchor::kStart) +
           '\n';
  }
  fmt::format_to(o, "<path d=\"{}\" stroke=\"{}\" stroke-width=\"1\"/>\n", marks, svg::kTickColor);
  const double empty_y = bar_y + kLegendBarHeight + 16;
  fmt::format_to(o,
                 "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"#ffffff\" stroke=\"{}\" "
                 "stroke-width=\"0.8\"/>\n",
                 svg::px(x), svg::px(empty_y), svg::px(kLegendBarWidth), svg::px(kLegendBarWidth), svg::kTickColor);
  out += svg::text_element(x + kLegendBarWidth + kTickLength + kTickGap, empty_y + kLegendBarWidth / 2, "no link",
                           kLabelSize, svg::kTextColor, Anchor::kStart) +
         '\n';
  out += "</g>\n";
}

std::string document(std::span<const InformationMatrixPanel> panels, std::size_t max_cells) {
  if (panels.empty()) throw std::invalid_argument("information matrix picture: no panels");
  if (max_cells < 1) throw std::invalid_argument("information matrix picture: max_cells must be at least 1, not 0");
  std::vector<Picture> pictures;
  std::vector<Axis> axes;
  pictures.reserve(panels.size());
  axes.reserve(panels.size());
  for (std::size_t i = 0; i < panels.size(); ++i) {
    const Sparse& m = panels[i].information;
    pictures.push_back(draw_cells(m, checked_diagonal(m, panel_name(i, panels[i])), max_cells));
    axes.push_back(axis_labels(pictures.back().binning));
  }

  std::vector<double> x0(panels.size());
  double x = 0;
  for (std::size_t i = 0; i < panels.size(); ++i) {
    x0[i] = x + left_margin(axes[i]);
    x = x0[i] + kSide + kPanelGap;
  }
  const double legend_x = x - kPanelGap + kLegendGap + kPad;
  const double width = legend_x + kLegendWidth + kPad;
  const double height = kTopMargin + kSide + 14 + kCaptionLines * kCaptionLine + kPad;

  std::string out = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"{2}\">\n",
      svg::px(width), svg::px(height), kFont);
  const std::string& title = panels.front().title;
  out += "<title>" + svg::escape(title.empty() ? std::string("information matrix") : title) + "</title>\n";
  out += "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
  fmt::format_to(std::back_inserter(out), "<defs>\n<linearGradient id=\"{}\" x1=\"0\" y1=\"0\" x2=\"0\" y2=\"1\">",
                 kScaleId);
  constexpr int kScaleStops = 16;
  for (int i = 0; i <= kScaleStops; ++i) {
    const double t = static_cast<double>(i) / kScaleStops;
    fmt::format_to(std::back_inserter(out), "<stop offset=\"{:g}\" stop-color=\"{}\"/>", t,
                   grey_hex(grey_level(1.0 - t)));
  }
  out += "</linearGradient>\n</defs>\n";
  for (std::size_t i = 0; i < panels.size(); ++i) write_panel(out, x0[i], panels[i].title, pictures[i], axes[i]);
  write_legend(out, legend_x);
  out += "</svg>\n";
  return out;
}

}  // namespace
}  // namespace slamkit::plot::information_svg

namespace slamkit {

std::string information_matrix_svg(std::span<const InformationMatrixPanel> panels, std::size_t max_cells) {
  return plot::information_svg::document(panels, max_cells);
}

void write_information_matrix_svg(const std::string& path, std::span<const InformationMatrixPanel> panels,
                                  std::size_t max_cells) {
  write_file_atomically(path, information_matrix_svg(panels, max_cells));
}

}  // namespace slamkit
