// Occupancy grids as map_server files (exact round trips, the convention's pixel values and YAML,
// errors that name the file and line), as PNG pictures (valid chunks, size, pixels), and compared
// with a reference map.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdint>
#include <string>
#include <vector>

#include "slamkit/core/error.hpp"
#include "slamkit/grid/map_comparison.hpp"
#include "slamkit/grid/map_files.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

using test_data::input_error_at;
using test_data::read_text;
using test_data::ScratchDir;
using test_data::write_text;

/// A grid of walls around free space, with an unobserved hole and a wall inside, across negative
/// cell indices and several tiles.
OccupancyGrid walled_grid(double resolution = 0.05) {
  GridOptions options;
  options.resolution = resolution;
  OccupancyGrid grid(options);
  for (int y = -5; y <= 40; ++y) {
    for (int x = -37; x <= 60; ++x) {
      const bool border = x == -37 || x == 60 || y == -5 || y == 40;
      const bool inner_wall = x == 10 && y < 25;
      const bool hole = x > 30 && x < 40 && y > 10 && y < 20;
      if (hole) continue;
      grid.add(GridCell{x, y}, border || inner_wall ? 6.0f : -6.0f);
    }
  }
  return grid;
}

/// The bytes of a string literal, NULs included.
template <std::size_t N>
std::string literal_bytes(const char (&text)[N]) {
  return std::string(text, N - 1);
}

void expect_same_grid(const OccupancyGrid& a, const OccupancyGrid& b) {
  ASSERT_EQ(a.bounds().min, b.bounds().min);
  ASSERT_EQ(a.bounds().max, b.bounds().max);
  const CellBox box = a.bounds();
  for (int y = box.min.y; y <= box.max.y; ++y) {
    for (int x = box.min.x; x <= box.max.x; ++x) {
      ASSERT_EQ(a.observed(GridCell{x, y}), b.observed(GridCell{x, y})) << x << ", " << y;
      ASSERT_EQ(a.log_odds(GridCell{x, y}), b.log_odds(GridCell{x, y})) << x << ", " << y;
    }
  }
}

std::uint32_t big_endian_at(const std::string& bytes, std::size_t at) {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < 4; ++i) value = value << 8 | static_cast<unsigned char>(bytes[at + i]);
  return value;
}

struct PngChunk {
  std::string type;
  std::string data;
};

/// The chunks of a PNG, each CRC checked against zlib's crc32.
std::vector<PngChunk> png_chunks(const std::string& png) {
  std::vector<PngChunk> chunks;
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  std::size_t at = 8;
  while (at + 12 <= png.size()) {
    const std::uint32_t length = big_endian_at(png, at);
    const std::string typed = png.substr(at + 4, 4 + length);
    const auto crc = static_cast<std::uint32_t>(
        crc32(0L, reinterpret_cast<const Bytef*>(typed.data()), static_cast<uInt>(typed.size())));
    EXPECT_EQ(big_endian_at(png, at + 8 + length), crc) << "chunk " << typed.substr(0, 4);
    chunks.push_back({typed.substr(0, 4), typed.substr(4)});
    at += 12 + length;
  }
  EXPECT_EQ(at, png.size());
  return chunks;
}

TEST(GridMapFiles, ATrinaryMapSurvivesTheRoundTripExactly) {
  const ScratchDir dir;
  const OccupancyGrid grid = walled_grid();
  write_map_server(grid, dir.file("map.pgm"), dir.file("map.yaml"));
  const OccupancyGrid read = read_map_server(dir.file("map.yaml"));
  EXPECT_DOUBLE_EQ(read.resolution(), 0.05);
  expect_same_grid(grid, read);

  write_map_server(read, dir.file("again.pgm"), dir.file("again.yaml"));
  EXPECT_EQ(read_text(dir.file("again.pgm")), read_text(dir.file("map.pgm")));
  EXPECT_EQ(read_text(dir.file("again.yaml")).substr(read_text(dir.file("again.yaml")).find('\n')),
            read_text(dir.file("map.yaml")).substr(read_text(dir.file("map.yaml")).find('\n')));
}

TEST(GridMapFiles, PixelsAndKeysFollowMapServersConvention) {
  GridOptions options;
  options.resolution = 0.1;
  OccupancyGrid grid(options);
  grid.add(GridCell{10, 20}, 6.0f);
  grid.add(GridCell{11, 20}, -6.0f);
  grid.add(GridCell{10, 21}, -6.0f);
  grid.add(GridCell{11, 21}, 0.3f);  // p = 0.57: observed but neither occupied nor free
  grid.add(GridCell{12, 21}, 6.0f);  // (12, 20) is never observed
  const ScratchDir dir;
  write_map_server(grid, dir.file("map.pgm"), dir.file("map.yaml"));
  EXPECT_EQ(read_text(dir.file("map.pgm")), literal_bytes("P5\n3 2\n255\n\xfe\xcd\x00\x00\xfe\xcd"))
      << "the top row is the largest y";
  EXPECT_EQ(read_text(dir.file("map.yaml")),
            "image: map.pgm\nresolution: 0.1\norigin: [1, 2, 0.0]\nnegate: 0\noccupied_thresh: 0.65\n"
            "free_thresh: 0.196\n");
  // map_server reads a pixel v as occupancy (255 - v) / 255 against the thresholds.
  const auto occupancy = [](int value) { return (255 - value) / 255.0; };
  EXPECT_GT(occupancy(0), kOccupiedThreshold);
  EXPECT_LT(occupancy(254), kFreeThreshold);
  EXPECT_GT(occupancy(205), kFreeThreshold);
  EXPECT_LT(occupancy(205), kOccupiedThreshold);
  EXPECT_EQ(cell_class(grid, GridCell{11, 21}), CellClass::unknown);
  EXPECT_EQ(cell_class(grid, GridCell{12, 20}), CellClass::unknown);
}

TEST(GridMapFiles, TheImageIsNamedRelativeToTheYaml) {
  const ScratchDir dir;
  std::filesystem::create_directories(dir.path() / "maps");
  const OccupancyGrid grid = walled_grid(0.1);
  write_map_server(grid, dir.file("maps/floor one.pgm"), dir.file("map.yaml"));
  EXPECT_EQ(read_text(dir.file("map.yaml")).substr(0, 27), "image: maps/floor one.pgm\nr");
  expect_same_grid(grid, read_map_server(dir.file("map.yaml")));
  // Names YAML would read as something else (null, a comment, a key) are quoted.
  for (const std::string name : {"null", "#2 floor.pgm", "a: b.pgm"}) {
    write_map_server(grid, dir.file(name), dir.file("map.yaml"));
    EXPECT_EQ(read_text(dir.file("map.yaml")).substr(0, 8 + name.size()), "image: \"" + name) << name;
    expect_same_grid(grid, read_map_server(dir.file("map.yaml")));
  }
}

TEST(GridMapFiles, AnEmptyGridIsOneUnknownPixel) {
  const ScratchDir dir;
  write_map_server(OccupancyGrid(), dir.file("empty.pgm"), dir.file("empty.yaml"));
  EXPECT_EQ(read_text(dir.file("empty.pgm")), "P5\n1 1\n255\n\xcd");
  EXPECT_TRUE(read_map_server(dir.file("empty.yaml")).bounds().empty());
}

TEST(GridMapFiles, AHandWrittenRosMapIsRead) {
  const ScratchDir dir;
  // negate 1 (white is occupied), maxval 100, a comment in the header, CRLF and comments in the YAML,
  // an origin half a cell off the grid (rounded to the nearest cell).
  write_text(dir.file("lab.pgm"), literal_bytes("P5\n# from a scanner\n2 2\n100\n\x64\x00\x32\x00"));
  write_text(dir.file("lab.yaml"),
             "# the lab\r\nimage: 'lab.pgm'  # beside me\r\nmode: trinary\r\nresolution: 0.5\r\n"
             "origin: [ -1.26, 2.0 , 0 ]\r\nnegate: 1\r\n\r\noccupied_thresh: 0.65\r\nfree_thresh: 0.196\r\n");
  const OccupancyGrid grid = read_map_server(dir.file("lab.yaml"));
  EXPECT_DOUBLE_EQ(grid.resolution(), 0.5);
  EXPECT_EQ(grid.bounds().min, (GridCell{-3, 4}));
  EXPECT_EQ(grid.bounds().max, (GridCell{-2, 5}));
  EXPECT_EQ(cell_class(grid, GridCell{-3, 5}), CellClass::occupied);  // top left, 100 of 100
  EXPECT_EQ(cell_class(grid, GridCell{-2, 5}), CellClass::free);
  EXPECT_FALSE(grid.observed(GridCell{-3, 4}));  // 50 of 100: unknown
  EXPECT_EQ(cell_class(grid, GridCell{-2, 4}), CellClass::free);
}

TEST(GridMapFiles, AFlowMapWithQuotedValuesIsRead) {
  const ScratchDir dir;
  // YAML as other tools write it: one flow map over several lines with comments, quoted values (a
  // quoted number reads as the number, as in map_server), and in block style an origin as a list.
  write_text(dir.file("lab map.pgm"), literal_bytes("P5\n2 1\n255\n\x00\xfe"));
  write_text(dir.file("flow.yaml"),
             "# the lab\n{image: \"lab map.pgm\", resolution: '0.5',  # half a metre\n"
             " origin: [-1.0, 2.0, 0], negate: 0,\n occupied_thresh: 0.65, free_thresh: \"0.196\", mode: trinary}\n");
  write_text(dir.file("block.yaml"),
             "image: lab map.pgm\nresolution: 0.5\norigin:\n  - -1.0\n  - 2.0\n  - 0.0\nnegate: 0\n"
             "occupied_thresh: 0.65\nfree_thresh: 0.196\n");
  for (const char* yaml : {"flow.yaml", "block.yaml"}) {
    const OccupancyGrid grid = read_map_server(dir.file(yaml));
    EXPECT_DOUBLE_EQ(grid.resolution(), 0.5) << yaml;
    EXPECT_EQ(grid.bounds().min, (GridCell{-2, 4})) << yaml;
    EXPECT_EQ(grid.bounds().max, (GridCell{-1, 4})) << yaml;
    EXPECT_EQ(cell_class(grid, GridCell{-2, 4}), CellClass::occupied) << yaml;
    EXPECT_EQ(cell_class(grid, GridCell{-1, 4}), CellClass::free) << yaml;
  }
  // A flow map's errors name the line of the value.
  write_text(dir.file("flow.yaml"),
             "{image: map.pgm, resolution: 0.5,\n origin: [0, 0, 0], negate: 3,\n"
             " occupied_thresh: 0.65, free_thresh: 0.196}\n");
  const std::string message = input_error_at([&] { read_map_server(dir.file("flow.yaml")); }, dir.file("flow.yaml"), 2);
  EXPECT_NE(message.find("negate: 0 or 1, found '3'"), std::string::npos) << message;
}

TEST(GridMapFiles, MalformedYamlIsAnErrorAtItsLine) {
  const ScratchDir dir;
  write_map_server(walled_grid(), dir.file("map.pgm"), dir.file("good.yaml"));
  const std::string good = read_text(dir.file("good.yaml"));
  const std::string head = "image: map.pgm\nresolution: 0.05\n";
  const std::string tail = "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
  const std::string origin = "origin: [0.0, 0.0, 0.0]\n";
  struct Case {
    std::string text;
    std::size_t line;
    std::string expected;
  };
  const std::vector<Case> cases{
      // YAML's own syntax, as yaml-cpp reports it (at the line where it notices).
      {head + origin + "  negate: 0\n", 4, "expected well-formed YAML (column 3: end of map not found)"},
      {head + "origin: [0.0, 0.0, 0.0\n" + tail, 4, "end of sequence flow not found"},
      {head + "origin: [0.0, 0.0, 0.0]]\n" + tail, 3, "illegal flow end"},
      {"image: 'map.pgm' x\n", 1, "expected well-formed YAML"},
      {"image: map.pgm\n\tresolution: 0.05\n", 2, "illegal tab"},
      {head + "origin: " + std::string(5000, '[') + "\n", 4, "nested less deeply"},
      {"image map.pgm\n", 1, "expected a map of map_server's keys, found 'image map.pgm'"},
      {"", 0, "expected a map of map_server's keys, found nothing"},
      {head + origin + tail + "---\nimage: other.pgm\n", 8, "expected one YAML document"},
      // map_server's keys and values.
      {head + "colour: red\n" + origin + tail, 3, "unknown key 'colour'"},
      {head + "resolution: 0.1\n" + origin + tail, 3, "appears twice"},
      {"image:\nresolution: 0.05\n" + origin + tail, 1, "expected a value for image"},
      {"image: ''\nresolution: 0.05\n" + origin + tail, 1, "expected the image's file name, found ''"},
      {"image: map.pgm\nresolution: fine\n" + origin + tail, 2, "expected a number for resolution, found 'fine'"},
      {"image: map.pgm\nresolution: {m: 0.05}\n" + origin + tail, 2, "for resolution, found a map"},
      {"image: map.pgm\nresolution: 0\n" + origin + tail, 2, "resolution must be from 0.001"},
      {head + "origin: [0.0, 0.0]\n" + tail, 3, "three numbers"},
      {head + "origin: 0.0, 0.0, 0.0\n" + tail, 3, "expected origin: [x, y, yaw], found '0.0, 0.0, 0.0'"},
      {head + "origin: [0.0, north, 0.0]\n" + tail, 3, "expected a number for origin, found 'north'"},
      {head + "origin: [0.0, 0.0, 0.5]\n" + tail, 3, "rotated maps are not read"},
      {head + "origin: [3e6, 0.0, 0.0]\n" + tail, 3, "expected an origin within"},
      {head + origin + "negate: 2\noccupied_thresh: 0.65\nfree_thresh: 0.196\n", 4, "negate: 0 or 1"},
      {head + origin + "negate: [0]\noccupied_thresh: 0.65\nfree_thresh: 0.196\n", 4, "found a sequence"},
      {head + origin + "negate: 0\noccupied_thresh: 1.5\nfree_thresh: 0.196\n", 5, "from 0 to 1"},
      {head + origin + "negate: 0\noccupied_thresh: .nan\nfree_thresh: 0.196\n", 5, "expected a number"},
      {head + origin + "negate: 0\noccupied_thresh: 0.5\nfree_thresh: 0.6\n", 6, "below occupied_thresh"},
      {head + origin + tail + "mode: scale\n", 7, "mode: trinary"},
      {head + tail, 0, "'origin' is missing"},
  };
  for (const Case& c : cases) {
    write_text(dir.file("bad.yaml"), c.text);
    const std::string message =
        input_error_at([&] { read_map_server(dir.file("bad.yaml")); }, dir.file("bad.yaml"), c.line);
    EXPECT_NE(message.find(c.expected), std::string::npos) << message;
  }
  write_text(dir.file("bad.yaml"), good + "\n");
  EXPECT_NO_THROW(read_map_server(dir.file("bad.yaml")));
  write_text(dir.file("lost.yaml"), "image: nowhere.pgm\nresolution: 0.05\n" + origin + tail);
  input_error_at([&] { read_map_server(dir.file("lost.yaml")); }, dir.file("nowhere.pgm"), 0);
  input_error_at([&] { read_map_server(dir.file("absent.yaml")); }, dir.file("absent.yaml"), 0);
}

TEST(GridMapFiles, MalformedPgmIsAnErrorAtItsLine) {
  const ScratchDir dir;
  write_text(dir.file("map.yaml"),
             "image: map.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\n"
             "free_thresh: 0.196\n");
  struct Case {
    std::string pgm;
    std::size_t line;
    std::string expected;
  };
  const std::vector<Case> cases{
      {"P2\n2 1\n255\n0 254\n", 1, "ASCII PGM"},
      {"GIF89a", 1, "starts with P5"},
      {"P5\n# made by hand\n2 x\n255\n", 3, "expected the height"},
      {literal_bytes("P5\n2 1\n65535\n\x00\x00\x00\x00"), 3, "16-bit"},
      {"P5\n2 0\n255\n", 2, "expected the height"},
      {literal_bytes("P5\n2 2\n255\n\x00\xfe\xfe"), 4, "found 3 (the file is truncated)"},
      {literal_bytes("P5\n2 1\n255\n\x00\xfe\xfe"), 4, "found 3"},
      {"P5\n2 1\n255", 3, "one white space character"},
  };
  for (const Case& c : cases) {
    write_text(dir.file("map.pgm"), c.pgm);
    const std::string message =
        input_error_at([&] { read_map_server(dir.file("map.yaml")); }, dir.file("map.pgm"), c.line);
    EXPECT_NE(message.find(c.expected), std::string::npos) << message;
  }
}

TEST(GridMapPicture, ThePngIsValidAndShowsTheGridAsThePgmDoes) {
  GridOptions options;
  options.resolution = 0.1;
  OccupancyGrid grid(options);
  grid.add(GridCell{-2, 3}, 6.0f);
  grid.add(GridCell{0, 3}, -6.0f);
  grid.add(GridCell{0, 4}, 0.0f);  // observed, p = 0.5: the grey of the unknown
  const GridImage image = grid_png(grid, 2);
  EXPECT_NEAR(image.origin_x, -0.2, 1e-12);
  EXPECT_NEAR(image.origin_y, 0.3, 1e-12);
  EXPECT_NEAR(image.width_m, 0.3, 1e-12);
  EXPECT_NEAR(image.height_m, 0.2, 1e-12);

  const std::vector<PngChunk> chunks = png_chunks(image.png);
  ASSERT_GE(chunks.size(), 3u);
  EXPECT_EQ(chunks.front().type, "IHDR");
  EXPECT_EQ(big_endian_at(chunks.front().data, 0), 6u);  // 3 cells x 2
  EXPECT_EQ(big_endian_at(chunks.front().data, 4), 4u);
  EXPECT_EQ(chunks.front().data.substr(8), literal_bytes("\x08\x00\x00\x00\x00"));
  EXPECT_EQ(chunks.back().type, "IEND");
  std::string compressed;
  for (const PngChunk& chunk : chunks)
    if (chunk.type == "IDAT") compressed += chunk.data;
  std::string raster(4 * 7, '\x01');
  uLongf size = raster.size();
  ASSERT_EQ(uncompress(reinterpret_cast<Bytef*>(raster.data()), &size,
                       reinterpret_cast<const Bytef*>(compressed.data()), compressed.size()),
            Z_OK);
  ASSERT_EQ(size, raster.size());
  // Each row starts with its filter type, 0. At the limit, 6, occupied is p = 0.9975: grey 1.
  const std::string top = literal_bytes("\x00\xcd\xcd\xcd\xcd\xcd\xcd");     // y = 4: unknown, unknown, p = 0.5
  const std::string bottom = literal_bytes("\x00\x01\x01\xcd\xcd\xfe\xfe");  // y = 3: occupied, unknown, free
  EXPECT_EQ(raster, top + top + bottom + bottom);

  const std::vector<PngChunk> empty = png_chunks(grid_png(OccupancyGrid()).png);
  EXPECT_EQ(big_endian_at(empty.front().data, 0), 1u);
  EXPECT_THROW(grid_png(grid, 0), std::invalid_argument);
}

TEST(GridMapPicture, IntermediateProbabilitiesAreShadedBetween) {
  OccupancyGrid grid;
  grid.add(GridCell{0, 0}, -1.0f);
  grid.add(GridCell{1, 0}, 1.0f);
  const std::vector<PngChunk> chunks = png_chunks(grid_png(grid).png);
  std::string raster(3, '\0');
  uLongf size = raster.size();
  ASSERT_EQ(uncompress(reinterpret_cast<Bytef*>(raster.data()), &size,
                       reinterpret_cast<const Bytef*>(chunks[1].data.data()), chunks[1].data.size()),
            Z_OK);
  const auto light = static_cast<unsigned char>(raster[1]), dark = static_cast<unsigned char>(raster[2]);
  EXPECT_GT(light, 205);
  EXPECT_LT(light, 254);
  EXPECT_GT(dark, 0);
  EXPECT_LT(dark, 205);
}

// A filter's map shrunk to fit a side: each pixel the most occupied observed cell under it, so a
// one-cell wall survives, and unknown only where no cell under it was observed.
TEST(GridMapPicture, AShrunkRasterKeepsItsWallsAndItsExtent) {
  GridMap map;
  map.resolution = 0.1;
  map.origin = Vector2(-1.0, 2.0);
  map.width = 5;
  map.height = 3;
  map.log_odds.assign(15, -6.0f);
  map.observed.assign(15, 1);
  map.log_odds[map.index(3, 0)] = 6.0f;                                    // a wall cell
  for (int i = 0; i < 2; ++i) map.observed[map.index(i, 2)] = 0;           // unobserved top left
  map.log_odds[map.index(0, 2)] = map.log_odds[map.index(1, 2)] = 0.0f;
  const GridImage image = grid_png(map, 3);  // 2 cells a pixel: 3 x 2 pixels
  EXPECT_NEAR(image.origin_x, -1.0, 1e-12);
  EXPECT_NEAR(image.origin_y, 2.0, 1e-12);
  EXPECT_NEAR(image.width_m, 0.6, 1e-12);
  EXPECT_NEAR(image.height_m, 0.4, 1e-12);
  const std::vector<PngChunk> chunks = png_chunks(image.png);
  EXPECT_EQ(big_endian_at(chunks.front().data, 0), 3u);
  EXPECT_EQ(big_endian_at(chunks.front().data, 4), 2u);
  std::string raster(2 * 4, '\x01');
  uLongf size = raster.size();
  ASSERT_EQ(uncompress(reinterpret_cast<Bytef*>(raster.data()), &size,
                       reinterpret_cast<const Bytef*>(chunks[1].data.data()), chunks[1].data.size()),
            Z_OK);
  // Top row (cells y = 2): unknown, free, free; bottom row (y = 0, 1): free, the wall, free.
  EXPECT_EQ(raster, literal_bytes("\x00\xcd\xfe\xfe\x00\xfe\x01\xfe"));
  EXPECT_EQ(big_endian_at(png_chunks(grid_png(GridMap{}, 10).png).front().data, 0), 1u);
  EXPECT_THROW(grid_png(map, 0), std::invalid_argument);
}

/// A room's walls as a reference, with the wall at x = `wall_x` (cells) from y = 0 to 39.
OccupancyGrid room_with_wall(int wall_x, bool doubled_at = false, int second_wall_x = 0) {
  OccupancyGrid grid;
  for (int y = 0; y < 40; ++y) {
    for (int x = 0; x < 60; ++x) {
      const bool wall = x == wall_x || (doubled_at && x == second_wall_x);
      grid.add(GridCell{x, y}, wall ? 6.0f : -6.0f);
    }
  }
  return grid;
}

TEST(GridMapAgreement, IdenticalMapsAgreeFully) {
  const OccupancyGrid map = room_with_wall(20);
  const MapAgreement agreement = compare_maps(map, map);
  EXPECT_EQ(agreement.estimate_occupied, 40u);
  EXPECT_EQ(agreement.reference_occupied, 40u);
  EXPECT_DOUBLE_EQ(agreement.precision, 1.0);
  EXPECT_DOUBLE_EQ(agreement.recall, 1.0);
  EXPECT_EQ(agreement.cells_compared, 60u * 40u);
  EXPECT_DOUBLE_EQ(agreement.cell_agreement, 1.0);
}

TEST(GridMapAgreement, ADoubledWallHalvesPrecisionAndKeepsRecall) {
  const MapAgreement agreement = compare_maps(room_with_wall(20, true, 35), room_with_wall(20));
  EXPECT_EQ(agreement.estimate_occupied, 80u);
  EXPECT_DOUBLE_EQ(agreement.precision, 0.5);
  EXPECT_DOUBLE_EQ(agreement.recall, 1.0);
  EXPECT_DOUBLE_EQ(agreement.cell_agreement, 1.0 - 40.0 / 2400.0);
}

TEST(GridMapAgreement, AWallOneCellOffCountsWithinTheTolerance) {
  const OccupancyGrid estimate = room_with_wall(21), reference = room_with_wall(20);
  const MapAgreement within = compare_maps(estimate, reference, 1);
  EXPECT_DOUBLE_EQ(within.precision, 1.0);
  EXPECT_DOUBLE_EQ(within.recall, 1.0);
  const MapAgreement exact = compare_maps(estimate, reference, 0);
  EXPECT_DOUBLE_EQ(exact.precision, 0.0);
  EXPECT_DOUBLE_EQ(exact.recall, 0.0);
  EXPECT_DOUBLE_EQ(exact.cell_agreement, 1.0 - 80.0 / 2400.0);

  const MapAgreement nothing = compare_maps(OccupancyGrid(), reference);
  EXPECT_EQ(nothing.estimate_occupied, 0u);
  EXPECT_DOUBLE_EQ(nothing.precision, 0.0);
  EXPECT_DOUBLE_EQ(nothing.recall, 0.0);
  EXPECT_EQ(nothing.cells_compared, 0u);

  GridOptions coarse;
  coarse.resolution = 0.1;
  EXPECT_THROW(compare_maps(OccupancyGrid(coarse), reference), std::invalid_argument);
  EXPECT_THROW(compare_maps(estimate, reference, -1), std::invalid_argument);
}

}  // namespace
}  // namespace slamkit
