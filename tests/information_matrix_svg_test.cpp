// The information matrix's picture (SEIF's figure of the matrix before and after sparsification): which
// cells are drawn and how dark, binning of large maps, the caption's counts, determinism, bad input and
// the file writer.
#include "slamkit/plot/information_matrix_svg.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <locale>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "slamkit/core/error.hpp"
#include "svg_test_support.hpp"
#include "test_data.hpp"

using namespace slamkit;

// A named namespace, not an anonymous one: the tests are compiled in unity batches.
namespace information_matrix_svg_test {

using Sparse = Eigen::SparseMatrix<double>;
using Triplets = std::vector<Eigen::Triplet<double>>;

struct Cell {
  long x = 0, y = 0;  // column and row of the cell
  int grey = 0;       // 0 black .. 255 white
  bool operator<(const Cell& o) const { return std::tie(x, y) < std::tie(o.x, o.y); }
};

std::string attribute(const std::string& tag, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const std::size_t at = tag.find(key);
  if (at == std::string::npos) return {};
  const std::size_t start = at + key.size();
  return tag.substr(start, tag.find('"', start) - start);
}

/// The cells of each panel, read back from the <rect>s of its cell group.
std::vector<std::vector<Cell>> parse_cells(const std::string& svg) {
  std::vector<std::vector<Cell>> panels;
  for (std::size_t g = svg.find("<g class=\"cells\""); g != std::string::npos;
       g = svg.find("<g class=\"cells\"", g + 1)) {
    const std::size_t end = svg.find("</g>", g);
    std::vector<Cell> cells;
    for (std::size_t r = svg.find("<rect ", g); r != std::string::npos && r < end; r = svg.find("<rect ", r + 1)) {
      const std::string tag = svg.substr(r, svg.find("/>", r) - r);
      EXPECT_EQ(attribute(tag, "width"), "1") << tag;
      EXPECT_EQ(attribute(tag, "height"), "1") << tag;
      const std::string fill = attribute(tag, "fill");
      EXPECT_EQ(fill.size(), 7u) << tag;
      const int red = std::stoi(fill.substr(1, 2), nullptr, 16);
      EXPECT_EQ(fill.substr(1, 2), fill.substr(3, 2)) << "not grey: " << tag;
      EXPECT_EQ(fill.substr(1, 2), fill.substr(5, 2)) << "not grey: " << tag;
      cells.push_back({std::stol(attribute(tag, "x")), std::stol(attribute(tag, "y")), red});
    }
    panels.push_back(cells);
  }
  return panels;
}

Sparse from_triplets(Eigen::Index rows, const Triplets& t) {
  Sparse m(rows, rows);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

void add_symmetric(Triplets& t, int i, int j, double v) {
  t.emplace_back(i, j, v);
  if (i != j) t.emplace_back(j, i, v);
}

/// The vehicle and three landmarks, every diagonal entry 4: the vehicle linked to landmark 0 (at most
/// |-2| / 4 = 0.5), landmark 0 to landmark 1 (1 / 4 = 0.25), landmarks 1 and 2 only by stored zeros.
Sparse small_matrix() {
  Triplets t;
  for (int i = 0; i < 9; ++i) add_symmetric(t, i, i, 4.0);
  add_symmetric(t, 0, 1, 3.0);   // inside the vehicle's block: its own cell
  add_symmetric(t, 3, 0, 1.0);   // vehicle - landmark 0
  add_symmetric(t, 4, 1, -2.0);  // the stronger entry of that pair
  add_symmetric(t, 5, 3, 1.0);   // landmark 0 - landmark 1
  add_symmetric(t, 7, 5, 0.0);   // landmark 1 - landmark 2: stored, but zero
  return from_triplets(9, t);
}

std::string svg_of(const Sparse& m, std::size_t max_cells = 300, std::string title = "before") {
  const InformationMatrixPanel panel{std::move(title), m};
  return information_matrix_svg(std::span(&panel, 1), max_cells);
}

/// What a SEIF's matrix looks like: each landmark linked to its neighbours by index (landmarks seen
/// together), one far link (a loop closure) every `far_every` landmarks and the vehicle linked to the
/// latest landmarks.
Sparse seif_like(int landmarks, int window, int far_every, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::uniform_int_distribution<int> any(0, landmarks - 1);
  Triplets t;
  const int rows = 3 + 2 * landmarks;
  for (int i = 0; i < rows; ++i) add_symmetric(t, i, i, 4.0 + 0.001 * i);
  const auto link = [&](int a, int b) {  // variables, a > b
    const int ra = a == 0 ? 0 : 3 + 2 * (a - 1), rb = b == 0 ? 0 : 3 + 2 * (b - 1);
    add_symmetric(t, ra, rb, value(rng));
    add_symmetric(t, ra + 1, rb + 1, value(rng));
  };
  for (int k = 0; k < landmarks; ++k) {
    for (int d = 1; d <= window && k + d < landmarks; ++d) link(k + d + 1, k + 1);
    if (k % far_every == 0) {
      const int other = any(rng);
      if (other != k) link(std::max(other, k) + 1, std::min(other, k) + 1);
    }
  }
  for (int k = std::max(0, landmarks - 5); k < landmarks; ++k) link(k + 1, 0);
  return from_triplets(rows, t);
}

/// A copy without the entries of magnitude below `threshold`: what sparsification leaves, roughly.
Sparse thinned(const Sparse& m, double threshold) {
  Sparse out = m;
  out.prune([threshold](Eigen::Index r, Eigen::Index c, double v) { return r == c || std::abs(v) >= threshold; });
  return out;
}

/// Expected cells by brute force: the largest normalised magnitude of each (column cell, row cell),
/// the vehicle in a cell of its own and the landmarks in runs of ceil(landmarks / (max_cells - 1)).
std::map<std::pair<long, long>, double> expected_cells(const Sparse& m, std::size_t max_cells) {
  const std::size_t landmarks = (static_cast<std::size_t>(m.rows()) - 3) / 2;
  const std::size_t slots = std::min(landmarks + 1, max_cells) - 1;
  const std::size_t per_cell = (landmarks + slots - 1) / slots;
  const auto cell = [&](Eigen::Index row) {
    return row < 3 ? 0L : static_cast<long>(1 + (static_cast<std::size_t>(row) - 3) / 2 / per_cell);
  };
  std::map<std::pair<long, long>, double> out;
  for (Eigen::Index c = 0; c < m.outerSize(); ++c)
    for (Sparse::InnerIterator it(m, c); it; ++it) {
      if (it.value() == 0) continue;
      const double magnitude = std::abs(it.value()) / std::sqrt(m.coeff(it.row(), it.row()) * m.coeff(c, c));
      double& largest = out[{cell(c), cell(it.row())}];
      largest = std::max(largest, magnitude);
    }
  return out;
}

struct CommaLocale : std::numpunct<char> {
  char do_decimal_point() const override { return ','; }
  char do_thousands_sep() const override { return '.'; }
  std::string do_grouping() const override { return "\3"; }
};

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no std::invalid_argument thrown)";
}

}  // namespace information_matrix_svg_test

using namespace information_matrix_svg_test;
using plot::test_svg::count;
using plot::test_svg::xml_error;

TEST(InformationMatrixSvg, DrawsOneCellPerLinkedVariablePairWithItsGrey) {
  const Sparse m = small_matrix();
  ASSERT_EQ(m.nonZeros(), 19) << "the two stored zeros are kept by setFromTriplets";
  const std::string svg = svg_of(m);
  EXPECT_EQ(xml_error(svg), "");
  const auto panels = parse_cells(svg);
  ASSERT_EQ(panels.size(), 1u);
  std::vector<Cell> cells = panels[0];
  std::sort(cells.begin(), cells.end());
  // Diagonal: 1, black. Vehicle - landmark 0: 0.5, 230 (1 - sqrt(0.5)) = 67.4. Landmark 0 - 1: 0.25, 115.
  // Landmarks 1 and 2 are linked only by a stored zero: no cell.
  const std::vector<std::tuple<long, long, int>> expected = {{0, 0, 0},   {0, 1, 67},  {1, 0, 67}, {1, 1, 0},
                                                             {1, 2, 115}, {2, 1, 115}, {2, 2, 0},  {3, 3, 0}};
  ASSERT_EQ(cells.size(), expected.size()) << svg;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    EXPECT_EQ(cells[i].x, std::get<0>(expected[i])) << i;
    EXPECT_EQ(cells[i].y, std::get<1>(expected[i])) << i;
    EXPECT_EQ(cells[i].grey, std::get<2>(expected[i])) << "cell " << cells[i].x << ", " << cells[i].y;
  }
  // One cell per variable: 480 px over 4 variables.
  EXPECT_NE(svg.find("scale(120)"), std::string::npos);
}

TEST(InformationMatrixSvg, TheDiagonalIsTheDarkestAndTheWeakestLinkStaysVisible) {
  Triplets t;
  for (int i = 0; i < 7; ++i) add_symmetric(t, i, i, 1e6);
  add_symmetric(t, 5, 3, 1e-6);  // landmarks 0 and 1, normalised magnitude 1e-12
  const auto cells = parse_cells(svg_of(from_triplets(7, t)));
  ASSERT_EQ(cells.size(), 1u);
  ASSERT_EQ(cells[0].size(), 5u);
  int darkest_off_diagonal = 255, lightest_diagonal = 0;
  for (const Cell& c : cells[0]) {
    if (c.x == c.y) {
      lightest_diagonal = std::max(lightest_diagonal, c.grey);
    } else {
      darkest_off_diagonal = std::min(darkest_off_diagonal, c.grey);
    }
  }
  EXPECT_EQ(lightest_diagonal, 0);
  EXPECT_GT(darkest_off_diagonal, lightest_diagonal);
  EXPECT_LT(darkest_off_diagonal, 240) << "a link of any strength must show on white";
}

TEST(InformationMatrixSvg, CaptionCountsStoredNonZerosAndLinkedPairs) {
  const std::string svg = svg_of(small_matrix());
  EXPECT_NE(svg.find(">9 \u00D7 9 matrix, 17 stored non-zeros<"), std::string::npos) << svg;
  EXPECT_NE(svg.find(">2 of 6 variable pairs linked (33.3%)<"), std::string::npos) << svg;
  EXPECT_NE(svg.find(">vehicle + 3 landmarks; a cell per variable pair<"), std::string::npos) << svg;
  // "vehicle" on both axes, each landmark by its index on both (the axes' labels come before the cells;
  // the legend's, also 0 and 1, after them).
  const std::string axes = svg.substr(0, svg.find("<g class=\"cells\""));
  EXPECT_EQ(count(axes, ">vehicle</text>"), 2u);
  for (const char* index : {">0</text>", ">1</text>", ">2</text>"}) EXPECT_EQ(count(axes, index), 2u) << index;
  EXPECT_NE(svg.find("<title>before</title>"), std::string::npos);
}

TEST(InformationMatrixSvg, BinsLandmarksAndKeepsTheStrongestLinkOfABin) {
  // Two cells: the vehicle keeps its own; the three landmarks share the other, where the landmark 0 - 1
  // link falls inside the diagonal cell.
  std::string svg = svg_of(small_matrix(), 2);
  auto panels = parse_cells(svg);
  ASSERT_EQ(panels.size(), 1u);
  std::vector<Cell> cells = panels[0];
  std::sort(cells.begin(), cells.end());
  ASSERT_EQ(cells.size(), 4u);
  EXPECT_EQ(std::make_tuple(cells[0].x, cells[0].y, cells[0].grey), std::make_tuple(0L, 0L, 0));
  EXPECT_EQ(std::make_tuple(cells[1].x, cells[1].y, cells[1].grey), std::make_tuple(0L, 1L, 67));
  EXPECT_EQ(std::make_tuple(cells[2].x, cells[2].y, cells[2].grey), std::make_tuple(1L, 0L, 67));
  EXPECT_EQ(std::make_tuple(cells[3].x, cells[3].y, cells[3].grey), std::make_tuple(1L, 1L, 0));
  EXPECT_NE(svg.find("vehicle + 3 landmarks; up to 3 landmarks a cell"), std::string::npos) << svg;
  EXPECT_NE(svg.find(">0\u20132</text>"), std::string::npos) << "the landmarks' cell is labelled with its range";

  // Three cells: {vehicle}, {landmarks 0, 1}, {landmark 2}.
  svg = svg_of(small_matrix(), 3);
  panels = parse_cells(svg);
  ASSERT_EQ(panels.size(), 1u);
  cells = panels[0];
  std::sort(cells.begin(), cells.end());
  const std::vector<std::tuple<long, long, int>> expected = {{0, 0, 0}, {0, 1, 67}, {1, 0, 67}, {1, 1, 0}, {2, 2, 0}};
  ASSERT_EQ(cells.size(), expected.size()) << svg;
  for (std::size_t i = 0; i < cells.size(); ++i)
    EXPECT_EQ(std::make_tuple(cells[i].x, cells[i].y, cells[i].grey), expected[i]) << i;
  EXPECT_NE(svg.find(">0\u20131</text>"), std::string::npos);
  EXPECT_NE(svg.find(">2</text>"), std::string::npos);

  // One cell: everything in it.
  panels = parse_cells(svg_of(small_matrix(), 1));
  ASSERT_EQ(panels.size(), 1u);
  ASSERT_EQ(panels[0].size(), 1u);
  EXPECT_EQ(panels[0][0].grey, 0);
}

TEST(InformationMatrixSvg, ALargeMapIsBinnedToAtMostMaxCellsSquaredPerPanel) {
  // 10,000 landmarks (20,003 rows), each linked to its 8 neighbours, every tenth to a random other.
  const Sparse before = seif_like(10000, 8, 10, 7);
  const Sparse after = thinned(before, 0.5);
  ASSERT_EQ(before.rows(), 20003);
  ASSERT_LT(after.nonZeros(), before.nonZeros());
  const std::vector<InformationMatrixPanel> panels = {{"before sparsification", before},
                                                      {"after sparsification", after}};
  for (const std::size_t max_cells : {std::size_t{300}, std::size_t{50}}) {
    const std::string svg = information_matrix_svg(panels, max_cells);
    RecordProperty("bytes_at_" + std::to_string(max_cells), static_cast<int>(svg.size()));
    EXPECT_EQ(xml_error(svg), "");
    const auto drawn = parse_cells(svg);
    ASSERT_EQ(drawn.size(), 2u);
    for (std::size_t p = 0; p < 2; ++p) {
      EXPECT_LE(drawn[p].size(), max_cells * max_cells);
      // Exactly the cells a brute-force binning expects, and a stronger link never lighter.
      const auto expected = expected_cells(panels[p].information, max_cells);
      ASSERT_EQ(drawn[p].size(), expected.size()) << "panel " << p;
      std::vector<std::pair<double, int>> magnitude_and_grey;
      for (const Cell& c : drawn[p]) {
        ASSERT_GE(c.x, 0);
        ASSERT_LT(c.x, static_cast<long>(max_cells));
        ASSERT_GE(c.y, 0);
        ASSERT_LT(c.y, static_cast<long>(max_cells));
        const auto it = expected.find({c.x, c.y});
        ASSERT_NE(it, expected.end()) << "unexpected cell " << c.x << ", " << c.y;
        magnitude_and_grey.emplace_back(it->second, c.grey);
        if (c.x == c.y) {
          EXPECT_EQ(c.grey, 0);
        }
      }
      std::sort(magnitude_and_grey.begin(), magnitude_and_grey.end());
      for (std::size_t i = 1; i < magnitude_and_grey.size(); ++i)
        EXPECT_GE(magnitude_and_grey[i - 1].second, magnitude_and_grey[i].second);
    }
    EXPECT_LT(drawn[1].size(), drawn[0].size()) << "sparsification removed cells";
    EXPECT_NE(svg.find(">20,003 \u00D7 20,003 matrix, "), std::string::npos);
    EXPECT_NE(
        svg.find(max_cells == 300 ? ">vehicle + 10,000 landmarks; up to 34 landmarks a cell, its strongest link"
                                  : ">vehicle + 10,000 landmarks; up to 205 landmarks a cell, its strongest link"),
        std::string::npos);
    // Landmark ranges on the axes, e.g. "0–1999", each range label written on both axes.
    EXPECT_NE(svg.find(">0\u2013"), std::string::npos);
  }
}

TEST(InformationMatrixSvg, TheSameInputGivesTheSameBytesWhateverTheLocaleOrStorageMode) {
  const Sparse m = seif_like(200, 3, 4, 11);
  const std::vector<InformationMatrixPanel> panels = {{"before", m}, {"after", thinned(m, 0.3)}};
  const std::string first = information_matrix_svg(panels, 60);
  EXPECT_EQ(information_matrix_svg(panels, 60), first);

  const std::locale previous = std::locale::global(std::locale(std::locale::classic(), new CommaLocale));
  const std::string under_comma_locale = information_matrix_svg(panels, 60);
  std::locale::global(previous);
  EXPECT_EQ(under_comma_locale, first);

  // The same matrix assembled entry by entry and left uncompressed.
  std::vector<InformationMatrixPanel> uncompressed = panels;
  for (InformationMatrixPanel& p : uncompressed) {
    Sparse copy(p.information.rows(), p.information.cols());
    copy.reserve(Eigen::VectorXi::Constant(copy.cols(), 16));
    for (Eigen::Index c = 0; c < p.information.outerSize(); ++c)
      for (Sparse::InnerIterator it(p.information, c); it; ++it) copy.insert(it.row(), c) = it.value();
    ASSERT_FALSE(copy.isCompressed());
    p.information = copy;
  }
  EXPECT_EQ(information_matrix_svg(uncompressed, 60), first);
}

TEST(InformationMatrixSvg, PanelsStandSideBySideWithEscapedTitles) {
  const std::vector<InformationMatrixPanel> panels = {{"<before> & after", small_matrix()}, {"after", small_matrix()}};
  const std::string svg = information_matrix_svg(panels);
  EXPECT_EQ(xml_error(svg), "");
  EXPECT_NE(svg.find("&lt;before&gt; &amp; after"), std::string::npos);
  std::vector<double> x;
  for (std::size_t at = svg.find("translate("); at != std::string::npos; at = svg.find("translate(", at + 1))
    x.push_back(std::stod(svg.substr(at + 10)));
  ASSERT_EQ(x.size(), 2u);
  EXPECT_GE(x[1], x[0] + 480) << "the second picture starts right of the first";
}

TEST(InformationMatrixSvg, RejectsBadInputNamingTheProblem) {
  const auto diagonal = [](Eigen::Index rows, Eigen::Index cols) {
    Triplets t;
    for (Eigen::Index i = 0; i < std::min(rows, cols); ++i) t.emplace_back(i, i, 2.0);
    Sparse m(rows, cols);
    m.setFromTriplets(t.begin(), t.end());
    return m;
  };
  EXPECT_NE(message_of([&] { svg_of(diagonal(9, 7)); }).find("9 x 7, not square"), std::string::npos);
  EXPECT_NE(message_of([&] { svg_of(diagonal(2, 2)); }).find("at least 3"), std::string::npos);
  EXPECT_NE(message_of([&] { svg_of(diagonal(8, 8)); }).find("odd number (5) of landmark rows"), std::string::npos);

  Sparse m = small_matrix();
  m.coeffRef(5, 5) = 0.0;
  EXPECT_NE(message_of([&] { svg_of(m); }).find("diagonal entry of row 5 is 0"), std::string::npos);
  m = small_matrix();
  m.coeffRef(2, 2) = -1.5;
  EXPECT_NE(message_of([&] { svg_of(m); }).find("diagonal entry of row 2 is -1.5"), std::string::npos);
  m = small_matrix();
  m.coeffRef(4, 4) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message_of([&] { svg_of(m); }).find("diagonal entry of row 4 is nan"), std::string::npos);
  m = small_matrix();
  m.coeffRef(6, 6) = std::numeric_limits<double>::infinity();
  EXPECT_NE(message_of([&] { svg_of(m); }).find("diagonal entry of row 6 is inf"), std::string::npos);
  m = small_matrix();
  m.prune([](Eigen::Index r, Eigen::Index c, double) { return !(r == 8 && c == 8); });  // not stored at all
  EXPECT_NE(message_of([&] { svg_of(m); }).find("diagonal entry of row 8 is 0"), std::string::npos);
  m = small_matrix();
  m.coeffRef(3, 0) = std::numeric_limits<double>::infinity();
  EXPECT_NE(message_of([&] { svg_of(m); }).find("row 3, column 0 is inf, not finite"), std::string::npos);

  // The panel is named, by number and title.
  Sparse bad = small_matrix();
  bad.coeffRef(1, 1) = 0.0;
  const std::vector<InformationMatrixPanel> two = {{"before", small_matrix()}, {"after", bad}};
  EXPECT_NE(message_of([&] { information_matrix_svg(two); }).find("panel 2 (\"after\")"), std::string::npos);

  EXPECT_NE(message_of([&] { information_matrix_svg({}); }).find("no panels"), std::string::npos);
  EXPECT_NE(message_of([&] { svg_of(small_matrix(), 0); }).find("max_cells must be at least 1"), std::string::npos);
}

TEST(InformationMatrixSvg, TheWriterLeavesTheWholePictureAndNoTemporary) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("slamkit_information_svg_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::vector<InformationMatrixPanel> panels = {{"before", small_matrix()}, {"after", small_matrix()}};
  const fs::path path = dir / "information.svg";
  write_information_matrix_svg(path.string(), panels, 10);
  EXPECT_EQ(test_data::read_text(path), information_matrix_svg(panels, 10));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);

  const fs::path missing = dir / "no such folder" / "information.svg";
  EXPECT_THROW(write_information_matrix_svg(missing.string(), panels), InputError);
  EXPECT_FALSE(fs::exists(missing));
  // Bad input throws before anything is written.
  EXPECT_THROW(write_information_matrix_svg((dir / "empty.svg").string(), {}), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir / "empty.svg"));
  fs::remove_all(dir);
}
