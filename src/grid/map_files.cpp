#include "slamkit/grid/map_files.hpp"

#include <fmt/format.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/checked_integer.hpp"
#include "slamkit/core/coordinates.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/input_file.hpp"
#include "slamkit/core/memory_budget.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

// map_server's pixel values for its three classes (negate 0: probability = (255 - value) / 255).
constexpr unsigned char kOccupiedPixel = 0;
constexpr unsigned char kUnknownPixel = 205;
constexpr unsigned char kFreePixel = 254;
// Larger sides are refused: no map_server map comes near, and products of two sides stay exact.
constexpr int kMaxImageSide = 1'000'000;

/// The box a file or picture shows: the observed cells, or one cell at the origin for an empty grid.
CellBox shown_box(const OccupancyGrid& grid) {
  const CellBox box = grid.bounds();
  return box.empty() ? CellBox{GridCell{0, 0}, GridCell{0, 0}} : box;
}

// ---- The YAML, read by yaml-cpp -----------------------------------------------------------------------------------

struct MapYaml {
  std::string image;
  double resolution = 0.0;
  std::size_t resolution_line = 0;
  Vector2 origin = Vector2::Zero();
  bool negate = false;
  double occupied_thresh = 0.0;
  double free_thresh = 0.0;
  std::size_t free_thresh_line = 0;
};

/// A yaml-cpp position as InputError's line: yaml-cpp counts from 0, InputError from 1 (0: no line).
std::size_t line_of(const YAML::Mark& mark) { return mark.is_null() ? 0 : static_cast<std::size_t>(mark.line) + 1; }

/// A value as a message quotes it.
std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Scalar:
      return fmt::format("'{}'", node.Scalar());
    case YAML::NodeType::Sequence:
      return "a sequence";
    case YAML::NodeType::Map:
      return "a map";
    default:
      return "nothing";
  }
}

class MapYamlReader {
 public:
  explicit MapYamlReader(std::string path) : path_(std::move(path)) {}

  MapYaml read() {
    std::vector<YAML::Node> documents;
    try {
      documents = YAML::LoadAll(read_input_file(path_));
    } catch (const YAML::DeepRecursion& e) {
      // Its own message is only "bad file".
      fail(e.mark, fmt::format("expected YAML nested less deeply (yaml-cpp stops at a depth of {})", e.depth()));
    } catch (const YAML::Exception& e) {
      fail(e.mark, fmt::format("expected well-formed YAML (column {}: {})", e.mark.column + 1, e.msg));
    }
    // yaml-cpp would read the first document alone: a second one is refused rather than ignored.
    if (documents.size() > 1) fail(documents[1].Mark(), "expected one YAML document, found a second");
    const YAML::Node root = documents.empty() ? YAML::Node() : documents.front();
    if (!root.IsMap())
      fail(root.IsNull() ? YAML::Mark::null_mark() : root.Mark(),
           fmt::format("expected a map of map_server's keys, found {}", describe(root)));
    // The pairs one by one, not root[key]: yaml-cpp keeps a repeated key and a lookup would see its first value.
    for (const auto& pair : root) assign(pair.first, pair.second);
    for (std::size_t i = 0; i < kKeys.size() - 1; ++i)  // all but the optional mode
      if (!seen_[i])
        throw InputError(path_, 0, fmt::format("the key '{}' is missing (map_server requires it)", kKeys[i]));
    if (!(yaml_.free_thresh < yaml_.occupied_thresh))
      throw InputError(path_, yaml_.free_thresh_line,
                       fmt::format("expected free_thresh ({}) below occupied_thresh ({})", yaml_.free_thresh,
                                   yaml_.occupied_thresh));
    return yaml_;
  }

 private:
  static constexpr std::array<std::string_view, 7> kKeys{"image",           "resolution",  "origin", "negate",
                                                         "occupied_thresh", "free_thresh", "mode"};

  [[noreturn]] void fail(const YAML::Mark& mark, const std::string& what) const {
    throw InputError(path_, line_of(mark), what);
  }

  /// A number, read with from_chars rather than yaml-cpp's as<double>, which converts through a
  /// stringstream in the global locale (a decimal comma under de_DE); the writer's fmt is locale-free too.
  double number(const YAML::Node& node, std::string_view what) const {
    const std::string& text = node.Scalar();
    double value = 0.0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (!node.IsScalar() || error != std::errc() || end != text.data() + text.size() || !std::isfinite(value))
      fail(node.Mark(), fmt::format("expected a number for {}, found {}", what, describe(node)));
    return value;
  }

  double probability(const YAML::Node& node, std::string_view what) const {
    const double value = number(node, what);
    if (!(value >= 0.0 && value <= 1.0))
      fail(node.Mark(), fmt::format("expected {} from 0 to 1, found {}", what, value));
    return value;
  }

  void assign(const YAML::Node& key_node, const YAML::Node& value) {
    const auto known = std::find(kKeys.begin(), kKeys.end(), key_node.Scalar());
    if (!key_node.IsScalar() || known == kKeys.end())
      fail(key_node.Mark(), fmt::format("unknown key {}; expected image, resolution, origin, negate, "
                                        "occupied_thresh, free_thresh or mode",
                                        describe(key_node)));
    const std::string_view key = *known;
    bool& seen = seen_[static_cast<std::size_t>(known - kKeys.begin())];
    if (seen) fail(key_node.Mark(), fmt::format("the key '{}' appears twice", key));
    seen = true;
    // An empty value's position is where the next token starts, often the next line: the key's line is named.
    if (value.IsNull()) fail(key_node.Mark(), fmt::format("expected a value for {}, found nothing", key));
    if (key == "image") {
      if (!value.IsScalar() || value.Scalar().empty())
        fail(value.Mark(), fmt::format("expected the image's file name, found {}", describe(value)));
      yaml_.image = value.Scalar();
    } else if (key == "resolution") {
      yaml_.resolution = number(value, "resolution");
      yaml_.resolution_line = line_of(value.Mark());
    } else if (key == "origin") {
      read_origin(value);
    } else if (key == "negate") {
      if (!value.IsScalar() || (value.Scalar() != "0" && value.Scalar() != "1"))
        fail(value.Mark(), fmt::format("expected negate: 0 or 1, found {}", describe(value)));
      yaml_.negate = value.Scalar() == "1";
    } else if (key == "occupied_thresh") {
      yaml_.occupied_thresh = probability(value, "occupied_thresh");
    } else if (key == "free_thresh") {
      yaml_.free_thresh = probability(value, "free_thresh");
      yaml_.free_thresh_line = line_of(value.Mark());
    } else if (!value.IsScalar() || value.Scalar() != "trinary") {
      fail(value.Mark(),
           fmt::format("expected mode: trinary (scale and raw maps are not read), found {}", describe(value)));
    }
  }

  void read_origin(const YAML::Node& value) {
    if (!value.IsSequence()) fail(value.Mark(), fmt::format("expected origin: [x, y, yaw], found {}", describe(value)));
    if (value.size() != 3)
      fail(value.Mark(), fmt::format("expected origin: [x, y, yaw] with three numbers, found {} values", value.size()));
    const double x = number(value[0], "origin"), y = number(value[1], "origin"), yaw = number(value[2], "origin");
    if (yaw != 0.0)
      fail(value[2].Mark(), fmt::format("expected an origin yaw of 0 (rotated maps are not read), found {}", yaw));
    yaml_.origin = Vector2(x, y);
    if (!within_coordinates(yaml_.origin))
      fail(value.Mark(), fmt::format("expected an origin within {} m, found [{}, {}]", kMaxAbsCoordinate, x, y));
  }

  std::string path_;
  std::array<bool, kKeys.size()> seen_{};
  MapYaml yaml_;
};

// ---- The PGM -----------------------------------------------------------------------------------------------------

struct Pgm {
  int width = 0;
  int height = 0;
  int maxval = 0;
  std::string pixels;  // row by row, the first at the top
};

Pgm read_pgm(const std::string& path) {
  const std::string text = read_input_file(path);
  std::size_t at = 0, line = 1;
  const auto fail = [&](const std::string& what) { throw InputError(path, line, what); };
  if (text.compare(0, 2, "P5") != 0) {
    if (text.compare(0, 2, "P2") == 0) fail("expected a binary PGM (P5); an ASCII PGM (P2) is not read");
    fail("expected a binary PGM, which starts with P5");
  }
  at = 2;
  const auto skip_blanks_and_comments = [&] {
    while (at < text.size()) {
      if (text[at] == '#') {
        while (at < text.size() && text[at] != '\n') ++at;
      } else if (std::isspace(static_cast<unsigned char>(text[at])) != 0) {
        if (text[at] == '\n') ++line;
        ++at;
      } else {
        return;
      }
    }
  };
  const auto header_number = [&](std::string_view what, int max) {
    const std::size_t before = at;
    skip_blanks_and_comments();
    if (at == before) fail(fmt::format("expected white space before the {}", what));
    int value = 0;
    const auto [end, error] = std::from_chars(text.data() + at, text.data() + text.size(), value);
    const std::size_t digits = static_cast<std::size_t>(end - (text.data() + at));
    if (error != std::errc() || digits == 0 || value < 1 || value > max)
      fail(fmt::format("expected the {} as a whole number from 1 to {}", what, max));
    at += digits;
    return value;
  };
  Pgm pgm;
  pgm.width = header_number("width", kMaxImageSide);
  pgm.height = header_number("height", kMaxImageSide);
  pgm.maxval = header_number("maximum grey value (16-bit PGMs are not read)", 255);
  if (at >= text.size() || std::isspace(static_cast<unsigned char>(text[at])) == 0)
    fail("expected one white space character after the maximum grey value, then the pixels");
  if (text[at] == '\n') ++line;
  ++at;
  const std::size_t expected = static_cast<std::size_t>(pgm.width) * static_cast<std::size_t>(pgm.height);
  if (text.size() - at != expected)
    fail(fmt::format("expected {} x {} = {} bytes of pixels after the header, found {}{}", pgm.width, pgm.height,
                     expected, text.size() - at, text.size() - at < expected ? " (the file is truncated)" : ""));
  pgm.pixels = text.substr(at);
  return pgm;
}

// ---- The PNG -----------------------------------------------------------------------------------------------------

void append_be32(std::string& out, std::uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((value >> shift) & 0xffu);
}

void append_chunk(std::string& out, std::string_view type, std::string_view data) {
  append_be32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t typed = out.size();
  out.append(type);
  out.append(data);
  const auto* bytes = reinterpret_cast<const Bytef*>(out.data() + typed);
  append_be32(out, static_cast<std::uint32_t>(crc32(0L, bytes, static_cast<uInt>(type.size() + data.size()))));
}

/// The grey of an occupancy probability: 254 at 0, 205 at 0.5, 0 at 1, linear between.
unsigned char shade(double probability) {
  const double grey = probability <= 0.5 ? kFreePixel - (kFreePixel - kUnknownPixel) * (probability / 0.5)
                                         : kUnknownPixel * (1.0 - probability) / 0.5;
  return static_cast<unsigned char>(std::lround(std::clamp(grey, 0.0, 255.0)));
}

}  // namespace

CellClass cell_class(const OccupancyGrid& grid, GridCell cell) {
  // The thresholds as log-odds, so a cell costs a comparison rather than an exponential.
  static const float occupied_above = static_cast<float>(std::log(kOccupiedThreshold / (1.0 - kOccupiedThreshold)));
  static const float free_below = static_cast<float>(std::log(kFreeThreshold / (1.0 - kFreeThreshold)));
  const float log_odds = grid.log_odds(cell);
  return log_odds > occupied_above ? CellClass::occupied : log_odds < free_below ? CellClass::free : CellClass::unknown;
}

void write_map_server(const OccupancyGrid& grid, const std::string& pgm_path, const std::string& yaml_path) {
  const CellBox box = shown_box(grid);
  std::string pgm = fmt::format("P5\n{} {}\n255\n", box.width(), box.height());
  pgm.reserve(pgm.size() + static_cast<std::size_t>(box.width()) * static_cast<std::size_t>(box.height()));
  for (int y = box.max.y; y >= box.min.y; --y) {
    for (int x = box.min.x; x <= box.max.x; ++x) {
      const CellClass kind = cell_class(grid, GridCell{x, y});
      pgm += static_cast<char>(kind == CellClass::occupied ? kOccupiedPixel
                               : kind == CellClass::free   ? kFreePixel
                                                           : kUnknownPixel);
    }
  }
  const fs::path image = fs::absolute(pgm_path).lexically_normal();
  const fs::path relative = image.lexically_relative(fs::absolute(yaml_path).parent_path().lexically_normal());
  // yaml-cpp's emitter quotes and escapes the name exactly when YAML needs it (a name like `null`, `#x` or
  // one with a line break), so the reader gets the same string back. The rest is fixed text and numbers,
  // formatted by fmt: its shortest round-trip floats, where the emitter writes 17 digits through a
  // stringstream in the global locale.
  YAML::Emitter name;
  name << (relative.empty() ? image.string() : relative.generic_string());
  const Vector2 origin = Vector2(box.min.x, box.min.y) * grid.resolution();
  const std::string yaml =
      fmt::format("image: {}\nresolution: {}\norigin: [{}, {}, 0.0]\nnegate: 0\noccupied_thresh: {}\nfree_thresh: {}\n",
                  name.c_str(), grid.resolution(), origin.x(), origin.y(), kOccupiedThreshold, kFreeThreshold);
  // The PGM first: a YAML never names an image that is not there yet.
  write_file_atomically(pgm_path, pgm);
  write_file_atomically(yaml_path, yaml);
}

OccupancyGrid read_map_server(const std::string& yaml_path, const GridOptions& options) {
  validate(options);
  const MapYaml yaml = MapYamlReader(yaml_path).read();
  GridOptions file_options = options;
  file_options.resolution = yaml.resolution;
  try {
    validate(file_options);
  } catch (const std::invalid_argument& e) {
    throw InputError(yaml_path, yaml.resolution_line, e.what());
  }
  fs::path image(yaml.image);
  if (image.is_relative()) image = fs::path(yaml_path).parent_path() / image;
  const Pgm pgm = read_pgm(image.string());

  OccupancyGrid grid(file_options);
  const GridCell origin{checked_integer<int>(std::round(yaml.origin.x() / yaml.resolution), "the origin's cell x"),
                    checked_integer<int>(std::round(yaml.origin.y() / yaml.resolution), "the origin's cell y")};
  const float limit = file_options.log_odds_limit;
  const double maxval = pgm.maxval;
  for (int row = 0; row < pgm.height; ++row) {
    for (int column = 0; column < pgm.width; ++column) {
      const double value =
          static_cast<unsigned char>(pgm.pixels[static_cast<std::size_t>(row) * static_cast<std::size_t>(pgm.width) +
                                                static_cast<std::size_t>(column)]);
      const double occupancy = yaml.negate ? value / maxval : (maxval - value) / maxval;
      const GridCell cell{origin.x + column, origin.y + pgm.height - 1 - row};
      if (occupancy > yaml.occupied_thresh)
        grid.add(cell, limit);
      else if (occupancy < yaml.free_thresh)
        grid.add(cell, -limit);
    }
  }
  return grid;
}

namespace {

/// An 8-bit greyscale PNG of `raster`: `height` rows of a filter byte (0: none) and `width` pixels.
std::string encode_png(std::size_t width, std::size_t height, const std::string& raster) {
  uLongf compressed_size = compressBound(static_cast<uLong>(raster.size()));
  std::string compressed(compressed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(compressed.data()), &compressed_size,
                reinterpret_cast<const Bytef*>(raster.data()), static_cast<uLong>(raster.size()), Z_BEST_SPEED) != Z_OK)
    throw std::runtime_error("grid image: zlib could not compress the picture");
  compressed.resize(compressed_size);

  std::string header;
  append_be32(header, static_cast<std::uint32_t>(width));
  append_be32(header, static_cast<std::uint32_t>(height));
  header += std::string("\x08\x00\x00\x00\x00", 5);  // 8 bits, greyscale, deflate, no filter, no interlace

  std::string png = "\x89PNG\r\n\x1a\n";
  append_chunk(png, "IHDR", header);
  // Chunks are limited to 2^31 - 1 bytes; decoders read consecutive IDAT chunks as one stream.
  constexpr std::size_t kChunkBytes = std::size_t{1} << 24;
  for (std::size_t at = 0; at < compressed.size(); at += kChunkBytes)
    append_chunk(png, "IDAT", std::string_view(compressed).substr(at, kChunkBytes));
  append_chunk(png, "IEND", {});
  return png;
}

}  // namespace

GridImage grid_png(const OccupancyGrid& grid, int scale) {
  if (scale < 1 || scale > 64)
    throw std::invalid_argument(fmt::format("grid image: scale must be from 1 to 64, found {}", scale));
  const CellBox box = shown_box(grid);
  const std::size_t width = static_cast<std::size_t>(box.width()) * static_cast<std::size_t>(scale);
  const std::size_t height = static_cast<std::size_t>(box.height()) * static_cast<std::size_t>(scale);
  constexpr std::size_t kMaxPngSide = 0x7fffffff;
  if (width > kMaxPngSide || height > kMaxPngSide)
    throw std::invalid_argument(fmt::format("grid image: {} x {} pixels exceed the PNG limit", width, height));
  const std::size_t row_bytes = width + 1;  // each row starts with its filter type, 0: none
  const std::size_t raster_bytes = row_bytes * height;
  require_memory(2.5 * static_cast<double>(raster_bytes), "the picture of an occupancy grid");

  std::string raster(raster_bytes, '\0');
  std::size_t row_start = 0;
  for (int y = box.max.y; y >= box.min.y; --y) {
    char* pixel = raster.data() + row_start + 1;
    for (int x = box.min.x; x <= box.max.x; ++x)
      pixel = std::fill_n(pixel, scale, static_cast<char>(shade(grid.probability(GridCell{x, y}))));
    for (int copy = 1; copy < scale; ++copy)
      std::copy_n(raster.data() + row_start, row_bytes,
                  raster.data() + row_start + static_cast<std::size_t>(copy) * row_bytes);
    row_start += static_cast<std::size_t>(scale) * row_bytes;
  }
  GridImage image;
  image.png = encode_png(width, height, raster);
  image.origin_x = box.min.x * grid.resolution();
  image.origin_y = box.min.y * grid.resolution();
  image.width_m = box.width() * grid.resolution();
  image.height_m = box.height() * grid.resolution();
  return image;
}

GridImage grid_png(const GridMap& map, int max_side) {
  if (max_side < 1) throw std::invalid_argument(fmt::format("grid image: max_side must be >= 1, found {}", max_side));
  GridImage image;
  if (map.empty()) {
    std::string raster{'\0', static_cast<char>(kUnknownPixel)};
    image.png = encode_png(1, 1, raster);
    return image;
  }
  const int cells_per_pixel = (std::max(map.width, map.height) + max_side - 1) / max_side;
  const int width = (map.width + cells_per_pixel - 1) / cells_per_pixel;
  const int height = (map.height + cells_per_pixel - 1) / cells_per_pixel;
  const std::size_t row_bytes = static_cast<std::size_t>(width) + 1;
  // Each pixel shows the most occupied observed cell it covers, so that a wall one cell thick stays
  // on a picture of a map many times larger than it; a pixel no beam touched is unknown.
  std::vector<float> most(static_cast<std::size_t>(width) * static_cast<std::size_t>(height),
                          -std::numeric_limits<float>::infinity());
  for (int j = 0; j < map.height; ++j)
    for (int i = 0; i < map.width; ++i) {
      const std::size_t cell = map.index(i, j);
      if (map.observed[cell] == 0) continue;
      float& pixel = most[static_cast<std::size_t>(j / cells_per_pixel) * static_cast<std::size_t>(width) +
                          static_cast<std::size_t>(i / cells_per_pixel)];
      pixel = std::max(pixel, map.log_odds[cell]);
    }
  std::string raster(row_bytes * static_cast<std::size_t>(height), '\0');
  for (int row = 0; row < height; ++row) {  // the first row at the top: the largest y
    const int y = height - 1 - row;
    for (int x = 0; x < width; ++x) {
      const float log_odds = most[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)];
      raster[static_cast<std::size_t>(row) * row_bytes + 1 + static_cast<std::size_t>(x)] = static_cast<char>(
          std::isinf(log_odds) ? kUnknownPixel : shade(1.0 / (1.0 + std::exp(-double{log_odds}))));
    }
  }
  image.png = encode_png(static_cast<std::size_t>(width), static_cast<std::size_t>(height), raster);
  image.origin_x = map.origin.x();
  image.origin_y = map.origin.y();
  image.width_m = width * cells_per_pixel * map.resolution;
  image.height_m = height * cells_per_pixel * map.resolution;
  return image;
}

}  // namespace slamkit
