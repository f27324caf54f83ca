// The occupancy grid: what one scan does to the cells it crosses and ends in (known answers for
// single beams, a wall, no-returns and the cut-off), the exact traversal, and copy-on-write tiles
// (a copy shares everything until one of the two writes, and then only the tile written is copied).
#include "slamkit/grid/occupancy_grid.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include "slamkit/core/angles.hpp"

namespace slamkit {
namespace {

/// A scan of one beam per reading, all along `bearing` (angle_increment 0) unless `increment` says.
RangeScanEvent beams_along(std::vector<float> ranges, double bearing = 0.0, double increment = 0.0,
                           double max_range = 30.0) {
  RangeScanEvent scan;
  scan.angle_min = bearing;
  scan.angle_increment = increment;
  scan.max_range = max_range;
  scan.ranges = std::move(ranges);
  return scan;
}

std::size_t count_observed_cells(const OccupancyGrid& grid) {
  std::size_t count = 0;
  const CellBox box = grid.bounds();
  for (int y = box.min.y; y <= box.max.y; ++y)
    for (int x = box.min.x; x <= box.max.x; ++x) count += grid.observed(GridCell{x, y}) ? 1 : 0;
  return count;
}

bool grids_hold_same_cells(const OccupancyGrid& a, const OccupancyGrid& b) {
  const CellBox box = a.bounds();
  if (!(box.min == b.bounds().min && box.max == b.bounds().max)) return false;
  for (int y = box.min.y; y <= box.max.y; ++y)
    for (int x = box.min.x; x <= box.max.x; ++x)
      if (a.log_odds(GridCell{x, y}) != b.log_odds(GridCell{x, y}) || a.observed(GridCell{x, y}) != b.observed(GridCell{x, y}))
        return false;
  return true;
}

const Pose2 kSensorInCellZero(0.01, 0.01, 0.0);  // the sensor inside cell (0, 0) at 5 cm resolution

TEST(OccupancyGridCells, CellOfAndCentreOfAgreeOnBothSidesOfTheOrigin) {
  const OccupancyGrid grid;
  EXPECT_EQ(grid.cell_of(Vector2(0.01, 0.049)), (GridCell{0, 0}));
  EXPECT_EQ(grid.cell_of(Vector2(-0.01, -0.06)), (GridCell{-1, -2}));
  EXPECT_NEAR(grid.centre_of(GridCell{-1, -2}).x(), -0.025, 1e-12);
  EXPECT_NEAR(grid.centre_of(GridCell{-1, -2}).y(), -0.075, 1e-12);
  EXPECT_THROW((void)grid.cell_of(Vector2(std::nan(""), 0.0)), std::out_of_range);
  EXPECT_THROW((void)grid.cell_of(Vector2(1e300, 0.0)), std::out_of_range);
  EXPECT_FALSE(grid.observed(GridCell{0, 0}));
  EXPECT_EQ(grid.log_odds(GridCell{1000, -1000}), 0.0f);
  EXPECT_DOUBLE_EQ(grid.probability(GridCell{0, 0}), 0.5);
  EXPECT_TRUE(grid.bounds().empty());
}

TEST(OccupancyGridCells, OptionsOutOfRangeAreRefused) {
  GridOptions options;
  options.resolution = 0.0;
  EXPECT_THROW(OccupancyGrid{options}, std::invalid_argument);
  options = GridOptions{};
  options.log_odds_free = 0.4f;
  EXPECT_THROW(OccupancyGrid{options}, std::invalid_argument);
  options = GridOptions{};
  options.log_odds_limit = std::numeric_limits<float>::infinity();
  EXPECT_THROW(OccupancyGrid{options}, std::invalid_argument);
  options = GridOptions{};
  options.max_cells = 0.0;
  EXPECT_THROW(OccupancyGrid{options}, std::invalid_argument);
}

TEST(OccupancyGridCells, AddClampsAndGrowsTheTableInAnyDirection) {
  OccupancyGrid grid;
  grid.add(GridCell{3, 4}, 2.5f);
  grid.add(GridCell{-1000, 2000}, -100.0f);
  grid.add(GridCell{5000, -7000}, 100.0f);
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{3, 4}), 2.5f);
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{-1000, 2000}), -6.0f);
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{5000, -7000}), 6.0f);
  EXPECT_TRUE(grid.observed(GridCell{-1000, 2000}));
  EXPECT_FALSE(grid.observed(GridCell{-1001, 2000}));
  EXPECT_EQ(grid.tile_count(), 3u);
  EXPECT_EQ(grid.bounds().min, (GridCell{-1000, -7000}));
  EXPECT_EQ(grid.bounds().max, (GridCell{5000, 2000}));
  EXPECT_NEAR(grid.probability(GridCell{3, 4}), 1.0 / (1.0 + std::exp(-2.5)), 1e-7);
  EXPECT_THROW(grid.add(GridCell{0, 0}, std::nanf("")), std::invalid_argument);
}

TEST(OccupancyGridIntegrate, OneBeamFreesTheCellsBeforeItsEndAndMarksTheEnd) {
  OccupancyGrid grid;
  grid.integrate(kSensorInCellZero, beams_along({2.01f}));  // ends at x = 2.02, in cell 40
  for (int x = 0; x < 40; ++x) EXPECT_FLOAT_EQ(grid.log_odds(GridCell{x, 0}), -0.4f) << "cell " << x;
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{40, 0}), 0.9f);
  EXPECT_FALSE(grid.observed(GridCell{41, 0}));
  EXPECT_FALSE(grid.observed(GridCell{20, 1}));
  EXPECT_EQ(count_observed_cells(grid), 41u);
  EXPECT_EQ(grid.bounds().min, (GridCell{0, 0}));
  EXPECT_EQ(grid.bounds().max, (GridCell{40, 0}));
}

TEST(OccupancyGridIntegrate, TheSensorOffsetIsAppliedInTheVehicleFrame) {
  OccupancyGrid grid;
  RangeScanEvent scan = beams_along({1.0f});
  scan.sensor_offset = Pose2(1.0, 0.0, 0.0);
  grid.integrate(Pose2(0.01, 0.01, kPi / 2), scan);  // sensor at (0.01, 1.01) looking along +y
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{0, 40}), 0.9f);
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{0, 20}), -0.4f);
  EXPECT_FALSE(grid.observed(GridCell{0, 19}));
  const Pose2 sensor = sensor_pose(Pose2(1.0, 2.0, kPi / 2), Pose2(0.5, 0.2, 0.1));
  EXPECT_NEAR(sensor.x(), 0.8, 1e-12);
  EXPECT_NEAR(sensor.y(), 2.5, 1e-12);
  EXPECT_NEAR(sensor.z(), kPi / 2 + 0.1, 1e-12);
}

TEST(OccupancyGridIntegrate, AWallIsMarkedOccupiedAndTheSpaceInFrontFree) {
  // Beams from -30 to +30 degrees onto the wall x = 2.02 m (cell column 40).
  std::vector<float> ranges;
  const double increment = kPi / 180.0;
  for (int i = -30; i <= 30; ++i) ranges.push_back(static_cast<float>(2.01 / std::cos(i * increment)));
  OccupancyGrid grid;
  grid.integrate(kSensorInCellZero, beams_along(ranges, -30 * increment, increment));
  for (int i = -30; i <= 30; ++i) {
    const double y = 0.01 + 2.01 * std::tan(i * increment);
    const GridCell end = grid.cell_of(Vector2(2.02, y));
    ASSERT_EQ(end.x, 40);
    EXPECT_GT(grid.probability(end), 0.65) << "beam " << i;
    // 3 cm back along the beam: in column 39, which no beam ends in, so free.
    const double angle = i * increment;
    const GridCell before = grid.cell_of(Vector2(2.02 - 0.03 * std::cos(angle), y - 0.03 * std::sin(angle)));
    ASSERT_EQ(before.x, 39);
    EXPECT_LT(grid.log_odds(before), 0.0f) << "beam " << i;
  }
  const CellBox box = grid.bounds();
  for (int y = box.min.y; y <= box.max.y; ++y) {
    for (int x = box.min.x; x < 40; ++x) EXPECT_LE(grid.log_odds(GridCell{x, y}), 0.0f) << x << ", " << y;
    EXPECT_FALSE(grid.observed(GridCell{41, y})) << "nothing is seen behind the wall";
  }
  EXPECT_EQ(box.max.x, 40);
}

TEST(OccupancyGridIntegrate, ANoReturnFreesUpToTheCutOffAndMarksNothing) {
  GridOptions options;
  options.range_cutoff = 1.0;
  OccupancyGrid grid(options);
  // A no-return (at max_range) and a reading beyond the cut-off, both along +x: free to x = 1.01.
  grid.integrate(kSensorInCellZero, beams_along({4.0f, 3.0f}, 0.0, 0.0, 4.0));
  for (int x = 0; x < 20; ++x) EXPECT_FLOAT_EQ(grid.log_odds(GridCell{x, 0}), -0.8f) << "cell " << x;
  EXPECT_FALSE(grid.observed(GridCell{20, 0}));
  EXPECT_EQ(grid.bounds().max, (GridCell{19, 0}));

  // A no-return short of the cut-off frees only to the reading: the sensor saw no farther.
  OccupancyGrid short_range;
  short_range.integrate(kSensorInCellZero, beams_along({2.0f}, 0.0, 0.0, 2.0));
  EXPECT_FLOAT_EQ(short_range.log_odds(GridCell{39, 0}), -0.4f);
  EXPECT_FALSE(short_range.observed(GridCell{40, 0}));
  EXPECT_EQ(short_range.bounds().max, (GridCell{39, 0}));
}

TEST(OccupancyGridIntegrate, ReadingsThatAreNotFiniteOrNotPositiveAreSkipped) {
  OccupancyGrid grid;
  const float inf = std::numeric_limits<float>::infinity();
  grid.integrate(kSensorInCellZero, beams_along({std::nanf(""), inf, -inf, 0.0f, -1.0f}, 0.0, 0.1));
  EXPECT_TRUE(grid.bounds().empty());
  EXPECT_EQ(grid.tile_count(), 0u);
}

// A scan that observes nothing (no usable reading, or a no-return ending in the sensor's own cell)
// must not grow the tile table: a table grown where nothing is observed escapes max_cells, which
// bounds the observed cells (the fuzzer found a later scan far away asking for a 4 GB table).
TEST(OccupancyGridIntegrate, AScanThatObservesNothingLeavesTheTileTableAsItWas) {
  GridOptions options;
  options.max_cells = 1e6;
  OccupancyGrid grid(options);
  grid.integrate(Pose2(1e5, 1e5, 0.0), beams_along({std::nanf(""), -1.0f}));
  grid.integrate(Pose2(1e5, 1e5, 0.0), beams_along({0.01f}, 0.0, 0.0, 0.001));
  EXPECT_EQ(grid.bytes(), 0u);
  grid.integrate(kSensorInCellZero, beams_along({5.0f}));
  const std::size_t bytes = grid.bytes();
  grid.integrate(Pose2(-1e5, 1e5, 0.0), beams_along({std::nanf("")}));
  EXPECT_EQ(grid.bytes(), bytes);
  EXPECT_THROW(grid.integrate(Pose2(-1e5, 1e5, 0.0), beams_along({5.0f})), GridExtentError);
}

TEST(OccupancyGridIntegrate, APoseOrScanThatIsNotANumberIsRefusedBeforeAnyChange) {
  OccupancyGrid grid;
  EXPECT_THROW(grid.integrate(Pose2(std::nan(""), 0.0, 0.0), beams_along({1.0f})), std::invalid_argument);
  EXPECT_THROW(grid.integrate(Pose2(3e6, 0.0, 0.0), beams_along({1.0f})), GridExtentError);
  EXPECT_THROW(grid.integrate(kSensorInCellZero, beams_along({1.0f}, std::nan(""))), std::invalid_argument);
  EXPECT_TRUE(grid.bounds().empty());
}

// A pose kilometres from the rest of the map (a jump in a log) would make the tile table span both:
// the scan is refused, naming the setting, and the grid is left as it was.
TEST(OccupancyGridIntegrate, AScanThatWouldStretchTheMapBeyondMaxCellsIsRefusedBeforeAnyChange) {
  GridOptions options;
  options.max_cells = 1e6;  // 50 m x 50 m at 5 cm
  OccupancyGrid grid(options);
  grid.integrate(kSensorInCellZero, beams_along({5.0f, 5.0f}, 0.0, 1.0));
  const OccupancyGrid before = grid;
  const std::size_t bytes_before = grid.bytes();
  try {
    grid.integrate(Pose2(1e5, 0.0, 0.0), beams_along({5.0f}));
    FAIL() << "a scan 100 km away was integrated";
  } catch (const GridExtentError& e) {
    EXPECT_NE(std::string(e.what()).find("max_cells"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("(100003, 0.025) m"), std::string::npos) << e.what();
  }
  EXPECT_THROW(grid.add(GridCell{0, 20000}, 1.0f), GridExtentError);
  EXPECT_TRUE(grids_hold_same_cells(grid, before));
  EXPECT_EQ(grid.bytes(), bytes_before);

  // Within the bound the map grows as before: 40 m away is still inside 50 m x 50 m.
  grid.integrate(Pose2(40.0, 0.0, 0.0), beams_along({5.0f}));
  EXPECT_GT(grid.bounds().max.x, 800);
}

TEST(OccupancyGridIntegrate, ACellAScanEndsInIsNotFreedByTheSameScansOtherBeams) {
  OccupancyGrid grid;
  // Both along +x: the first ends in cell 20, the second crosses it on the way to cell 40.
  grid.integrate(kSensorInCellZero, beams_along({1.0f, 2.0f}));
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{20, 0}), 0.9f);
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{19, 0}), -0.8f);
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{30, 0}), -0.4f);
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{40, 0}), 0.9f);
  // A later scan that passes through it does free it.
  grid.integrate(kSensorInCellZero, beams_along({2.0f}));
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{20, 0}), 0.5f);
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{40, 0}), 1.8f);
}

TEST(OccupancyGridIntegrate, EvidenceIsClampedAtTheLimit) {
  OccupancyGrid grid;
  for (int i = 0; i < 20; ++i) grid.integrate(kSensorInCellZero, beams_along({1.0f}));
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{20, 0}), 6.0f);
  EXPECT_FLOAT_EQ(grid.log_odds(GridCell{5, 0}), -6.0f);
}

TEST(OccupancyGridIntegrate, AnOccupiedCellKeepsTheMeanOfWhereItsHitsEnded) {
  OccupancyGrid grid;
  const GridCell end{40, 0}, tile{end.x >> OccupancyGrid::kTileShift, 0};
  const auto offsets = [&] {
    const std::int8_t* at = grid.tile_cells(tile).hit_offsets + 2 * OccupancyGrid::local_index(end);
    return std::array<int, 2>{at[0], at[1]};
  };
  // From (0.01, 0.01) a beam of 2.015 m ends at x = 2.025, the centre of cell 40 along x (offset 0),
  // 0.3 of a cell below its centre along y (-77 of 256).
  grid.integrate(kSensorInCellZero, beams_along({2.015f}));
  EXPECT_NEAR(offsets()[0], 0, 1);
  EXPECT_EQ(offsets()[1], -77);
  // An occupied cell's point moves a quarter of the way to each new hit: one at x = 2.045 (+102).
  grid.integrate(kSensorInCellZero, beams_along({2.035f}));
  EXPECT_NEAR(offsets()[0], 25, 1);
  EXPECT_EQ(offsets()[1], -77);
  // A cell freed below zero again takes its next hit as it is.
  for (int i = 0; i < 5; ++i) grid.integrate(kSensorInCellZero, beams_along({3.0f}));
  ASSERT_LT(grid.log_odds(end), 0.0f);
  grid.integrate(kSensorInCellZero, beams_along({2.015f}));
  EXPECT_NEAR(offsets()[0], 0, 1);
}

TEST(OccupancyGridIntegrate, TheTraversalVisitsExactlyTheCellsTheSegmentCrosses) {
  // A segment in general position, crossing tile borders and negative coordinates.
  const Pose2 sensor(-0.613, 0.521, 2.4);
  const double range = 3.7;
  OccupancyGrid grid;
  grid.integrate(sensor, beams_along({static_cast<float>(range)}));
  std::set<std::pair<int, int>> crossed;
  const Vector2 direction(std::cos(sensor.z()), std::sin(sensor.z()));
  const Vector2 end = sensor.head<2>() + range * direction;
  const GridCell end_cell = grid.cell_of(end);
  for (int i = 0; i <= 200000; ++i) {
    const GridCell cell = grid.cell_of(sensor.head<2>() + range * (i / 200000.0) * direction);
    if (!(cell == end_cell)) crossed.insert({cell.x, cell.y});
  }
  std::set<std::pair<int, int>> freed;
  const CellBox box = grid.bounds();
  for (int y = box.min.y; y <= box.max.y; ++y)
    for (int x = box.min.x; x <= box.max.x; ++x)
      if (grid.log_odds(GridCell{x, y}) < 0.0f) freed.insert({x, y});
  EXPECT_EQ(freed, crossed);
  EXPECT_FLOAT_EQ(grid.log_odds(end_cell), 0.9f);
  const GridCell start = grid.cell_of(sensor.head<2>());
  EXPECT_EQ(freed.size(), static_cast<std::size_t>(std::abs(end_cell.x - start.x) + std::abs(end_cell.y - start.y)));
}

TEST(OccupancyGridSharing, ACopySharesEveryTileUntilOneOfThemWrites) {
  OccupancyGrid original;
  std::vector<float> ranges(360, 4.0f);  // a circle of radius 4 m: several tiles
  const RangeScanEvent circle = beams_along(ranges, -kPi, 2 * kPi / 360);
  original.integrate(kSensorInCellZero, circle);
  const std::size_t tiles = original.tile_count();
  ASSERT_GT(tiles, 4u);
  const std::size_t table = original.bytes() - tiles * OccupancyGrid::tile_bytes();

  OccupancyGrid copy = original;
  const std::vector<const OccupancyGrid*> both{&original, &copy};
  EXPECT_EQ(copy.tile_count(), tiles);
  EXPECT_EQ(OccupancyGrid::distinct_bytes(both), tiles * OccupancyGrid::tile_bytes() + 2 * table)
      << "the copy costs its table only";

  const GridCell written{20, 0};
  const float before = original.log_odds(written);
  copy.add(written, 1.0f);
  EXPECT_EQ(OccupancyGrid::distinct_bytes(both), (tiles + 1) * OccupancyGrid::tile_bytes() + 2 * table)
      << "one write copies one tile";
  EXPECT_EQ(original.log_odds(written), before);
  EXPECT_FLOAT_EQ(copy.log_odds(written), before + 1.0f);
  copy.add(written, 1.0f);
  EXPECT_EQ(OccupancyGrid::distinct_bytes(both), (tiles + 1) * OccupancyGrid::tile_bytes() + 2 * table)
      << "a tile copied once is the copy's own";

  const GridCell other{-20, -20};
  const float shared_value = copy.log_odds(other);
  original.add(other, -1.0f);
  EXPECT_EQ(OccupancyGrid::distinct_bytes(both), (tiles + 2) * OccupancyGrid::tile_bytes() + 2 * table);
  EXPECT_EQ(copy.log_odds(other), shared_value);
  EXPECT_FLOAT_EQ(original.log_odds(other), std::max(shared_value - 1.0f, -6.0f));
}

TEST(OccupancyGridSharing, EachOfTwoGridsSharingTilesSeesOnlyItsOwnScans) {
  std::vector<float> ranges(360, 4.0f);
  const RangeScanEvent circle = beams_along(ranges, -kPi, 2 * kPi / 360);
  const Pose2 first(0.01, 0.01, 0.0), copy_next(1.0, 0.5, 0.3), copy_far(30.0, -20.0, 0.0),
      original_next(-1.0, 0.2, -0.4);
  OccupancyGrid original, expected_original, expected_copy;
  for (OccupancyGrid* grid : {&original, &expected_original, &expected_copy}) grid->integrate(first, circle);

  OccupancyGrid copy = original;
  copy.integrate(copy_next, circle);
  copy.integrate(copy_far, circle);  // grows the copy's table
  original.integrate(original_next, circle);
  expected_copy.integrate(copy_next, circle);
  expected_copy.integrate(copy_far, circle);
  expected_original.integrate(original_next, circle);
  EXPECT_TRUE(grids_hold_same_cells(original, expected_original));
  EXPECT_TRUE(grids_hold_same_cells(copy, expected_copy));
  EXPECT_FALSE(grids_hold_same_cells(copy, original));
}

TEST(OccupancyGridSharing, GridsSharingTilesCanBeWrittenOnDifferentThreads) {
  std::vector<float> ranges(360, 4.0f);
  const RangeScanEvent circle = beams_along(ranges, -kPi, 2 * kPi / 360);
  OccupancyGrid base;
  base.integrate(kSensorInCellZero, circle);
  std::vector<OccupancyGrid> copies(4, base), expected(4, base);
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < copies.size(); ++i)
    threads.emplace_back([&copies, &circle, i] {
      for (int k = 0; k < 20; ++k) copies[i].integrate(Pose2(0.1 * k, 0.05 * static_cast<double>(i), 0.1), circle);
    });
  for (std::thread& thread : threads) thread.join();
  for (std::size_t i = 0; i < expected.size(); ++i) {
    for (int k = 0; k < 20; ++k) expected[i].integrate(Pose2(0.1 * k, 0.05 * static_cast<double>(i), 0.1), circle);
    EXPECT_TRUE(grids_hold_same_cells(copies[i], expected[i])) << "copy " << i;
  }
}

}  // namespace
}  // namespace slamkit
