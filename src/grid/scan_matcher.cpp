#include "slamkit/grid/scan_matcher.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/coordinates.hpp"

namespace slamkit {
namespace {

constexpr int kMaxSearchCells = 20;

/// A beam the matcher uses, in the vehicle frame: its end point [m] and its unit direction.
struct MatchedBeam {
  Vector2 end;
  Vector2 direction;
};

/// The used beams of the scan being matched. Per thread, because filters match their particles in
/// parallel with one matcher; reused, so that matching allocates only on a thread's first scans.
thread_local std::vector<MatchedBeam> matched_beams;

void prepare_beams(const RangeScanEvent& scan, const ScanMatcherOptions& options) {
  if (!(std::isfinite(scan.angle_min) && std::isfinite(scan.angle_increment) && !std::isnan(scan.max_range)))
    throw std::invalid_argument("scan matcher: a scan's angle_min, angle_increment or max_range is not a number");
  const double max_range = std::min(options.max_range, scan.max_range);
  const Pose2& offset = scan.sensor_offset;
  matched_beams.clear();
  for (std::size_t i = 0; i < scan.ranges.size(); i += static_cast<std::size_t>(options.beam_stride)) {
    const double range = scan.ranges[i];
    if (!(std::isfinite(range) && range > 0.0 && range < max_range)) continue;
    const double angle = offset.z() + scan.bearing(i);
    const Vector2 direction(std::cos(angle), std::sin(angle));
    matched_beams.push_back(MatchedBeam{offset.head<2>() + range * direction, direction});
  }
}

/// The log-odds and hit offsets of cells near each other, looking each tile up once while the reads
/// stay in it.
class TileReader {
 public:
  explicit TileReader(const OccupancyGrid& map) : map_(map) {}
  float at(int x, int y) {
    look_up(x, y);
    return cells_.log_odds == nullptr ? 0.0f : cells_.log_odds[OccupancyGrid::local_index(GridCell{x, y})];
  }
  const std::int8_t* offset(int x, int y) {
    static constexpr std::int8_t kCentre[2] = {0, 0};
    look_up(x, y);
    return cells_.hit_offsets == nullptr ? kCentre
                                         : cells_.hit_offsets + 2 * OccupancyGrid::local_index(GridCell{x, y});
  }

 private:
  void look_up(int x, int y) {
    const GridCell tile{x >> OccupancyGrid::kTileShift, y >> OccupancyGrid::kTileShift};
    if (tile == key_) return;
    key_ = tile;
    cells_ = map_.tile_cells(tile);
  }

  const OccupancyGrid& map_;
  GridCell key_{INT_MIN, INT_MIN};  // no cell's tile: every index fits in an int, so tiles are 32 times smaller
  OccupancyGrid::TileCells cells_;
};

/// The neighbour of a cell towards the sensor for a beam going along `direction`: the one of the
/// eight whose direction is nearest the beam's reverse (sectors of 45 degrees, edges at 22.5).
int towards_sensor(double direction_component) {
  constexpr double kSectorEdge = 0.38268343236508984;  // sin(22.5 degrees)
  return direction_component > kSectorEdge ? -1 : direction_component < -kSectorEdge ? 1 : 0;
}

/// The squared distance [cells^2] from an end point to the mean hit point of the nearest obstacle
/// cell of the window, or infinity. `read(i, j)` is the log-odds of window cell (i, j), 0 <= i, j <= 2
/// reach (and one cell beyond, for the neighbour towards the sensor at (i + back_x, j + back_y)),
/// `offset(i, j)` its hit offsets (OccupancyGrid::tile_cells); `from_x[i]`, `from_y[j]` the
/// offset of its centre from the end point. Written without branches on the cells: whether a cell near
/// a wall is an obstacle is a coin toss the branch predictor would lose.
template <bool kFreeBeforeHit, typename Read, typename Offset>
double nearest_obstacle(Read&& read, Offset&& offset, int reach, int back_x, int back_y, float threshold,
                        const double* from_x, const double* from_y) {
  constexpr double kPerStep = 1.0 / 256.0;
  double nearest = std::numeric_limits<double>::infinity();
  for (int j = 0; j <= 2 * reach; ++j) {
    for (int i = 0; i <= 2 * reach; ++i) {
      bool obstacle = read(i, j) > threshold;
      if constexpr (kFreeBeforeHit) obstacle = obstacle & !(read(i + back_x, j + back_y) > threshold);
      const std::int8_t* hit = offset(i, j);
      const double dx = from_x[i] + kPerStep * hit[0], dy = from_y[j] + kPerStep * hit[1];
      const double distance = dx * dx + dy * dy;
      nearest = (obstacle & (distance < nearest)) ? distance : nearest;
    }
  }
  return nearest;
}

template <bool kFreeBeforeHit>
ScanMatch score(const OccupancyGrid& map, const Pose2& pose, const ScanMatcherOptions& options) {
  if (!(within_coordinates(pose.head<2>()) && std::isfinite(pose.z())))
    throw GridExtentError(fmt::format("scan matcher: pose ({}, {}, {}) is not finite or beyond {} m", pose.x(),
                                      pose.y(), pose.z(), kMaxAbsCoordinate));
  // Everything in cell units, where cell (i, j) spans [i, i+1) x [j, j+1) and has its centre at +0.5.
  const double cells_per_metre = 1.0 / map.resolution();
  const double c = std::cos(pose.z()), s = std::sin(pose.z());
  const Matrix2 rotation = (Matrix2() << c, -s, s, c).finished();
  const Matrix2 to_cells = rotation * cells_per_metre;
  const Vector2 origin = pose.head<2>() * cells_per_metre;
  const double per_square_cell = -map.resolution() * map.resolution() / (2.0 * options.sigma * options.sigma);
  const float threshold = options.occupied_log_odds;
  const int reach = options.search_cells;
  constexpr int kSide = OccupancyGrid::kTileSide;
  // The window and the neighbours towards the sensor, relative to the end point's cell.
  const int margin = reach + (kFreeBeforeHit ? 1 : 0);

  TileReader cells(map);
  std::array<double, 2 * kMaxSearchCells + 1> from_x{}, from_y{};
  ScanMatch result;
  result.pose = pose;
  result.beams_used = static_cast<int>(matched_beams.size());
  for (const MatchedBeam& beam : matched_beams) {
    const Vector2 end = origin + to_cells * beam.end;
    const int end_x = static_cast<int>(std::floor(end.x())), end_y = static_cast<int>(std::floor(end.y()));
    int back_x = 0, back_y = 0;
    if constexpr (kFreeBeforeHit) {
      const Vector2 direction = rotation * beam.direction;
      back_x = towards_sensor(direction.x());
      back_y = towards_sensor(direction.y());
    }
    const int low_x = end_x - reach, low_y = end_y - reach;
    for (int k = 0; k <= 2 * reach; ++k) {
      from_x[k] = low_x + k + 0.5 - end.x();
      from_y[k] = low_y + k + 0.5 - end.y();
    }
    double nearest = 0.0;
    const int local_x = end_x & (kSide - 1), local_y = end_y & (kSide - 1);
    if (local_x >= margin && local_x < kSide - margin && local_y >= margin && local_y < kSide - margin) {
      // Most windows lie inside one tile: read it directly, or not at all where the tile is empty.
      const OccupancyGrid::TileCells tile =
          map.tile_cells(GridCell{end_x >> OccupancyGrid::kTileShift, end_y >> OccupancyGrid::kTileShift});
      if (tile.log_odds == nullptr) {
        nearest = std::numeric_limits<double>::infinity();
      } else {
        const int corner = (local_y - reach) * kSide + (local_x - reach);
        const float* window = tile.log_odds + corner;
        const std::int8_t* offsets = tile.hit_offsets + 2 * corner;
        nearest = nearest_obstacle<kFreeBeforeHit>(
            [window](int i, int j) { return window[j * kSide + i]; },
            [offsets](int i, int j) { return offsets + 2 * (j * kSide + i); }, reach, back_x, back_y, threshold,
            from_x.data(), from_y.data());
      }
    } else {
      nearest = nearest_obstacle<kFreeBeforeHit>(
          [&cells, low_x, low_y](int i, int j) { return cells.at(low_x + i, low_y + j); },
          [&cells, low_x, low_y](int i, int j) { return cells.offset(low_x + i, low_y + j); }, reach, back_x,
          back_y, threshold, from_x.data(), from_y.data());
    }
    if (nearest < std::numeric_limits<double>::infinity()) {
      ++result.beams_matched;
      result.log_likelihood += std::max(per_square_cell * nearest, options.outlier_log_likelihood);
    } else {
      result.log_likelihood += options.outlier_log_likelihood;
    }
  }
  return result;
}

ScanMatch score(const OccupancyGrid& map, const Pose2& pose, const ScanMatcherOptions& options) {
  return options.free_before_hit ? score<true>(map, pose, options) : score<false>(map, pose, options);
}

}  // namespace

void validate(const ScanMatcherOptions& o) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("scan matcher: " + what); };
  if (!(o.sigma > 0.0 && std::isfinite(o.sigma))) fail(fmt::format("sigma must be finite and > 0, found {}", o.sigma));
  if (o.search_cells < 0 || o.search_cells > kMaxSearchCells)
    fail(fmt::format("search_cells must be from 0 to {}, found {}", kMaxSearchCells, o.search_cells));
  if (!(o.outlier_log_likelihood <= 0.0 && std::isfinite(o.outlier_log_likelihood)))
    fail(fmt::format("outlier_log_likelihood must be finite and <= 0, found {}", o.outlier_log_likelihood));
  if (o.beam_stride < 1) fail(fmt::format("beam_stride must be >= 1, found {}", o.beam_stride));
  if (!(o.max_range > 0.0 && o.max_range <= 1e4))
    fail(fmt::format("max_range must be > 0 and <= 10000 m, found {}", o.max_range));
  if (!std::isfinite(o.occupied_log_odds))
    fail(fmt::format("occupied_log_odds must be finite, found {}", o.occupied_log_odds));
  if (!(o.linear_step > 0.0 && o.linear_step <= 100.0))
    fail(fmt::format("linear_step must be > 0 and <= 100 m, found {}", o.linear_step));
  if (!(o.angular_step > 0.0 && o.angular_step <= kPi))
    fail(fmt::format("angular_step must be > 0 and <= pi, found {}", o.angular_step));
  if (o.refinements < 0 || o.refinements > 40)
    fail(fmt::format("refinements must be from 0 to 40, found {}", o.refinements));
}

ScanMatcher::ScanMatcher(const ScanMatcherOptions& options) : options_((validate(options), options)) {}

ScanMatch ScanMatcher::evaluate(const OccupancyGrid& map, const Pose2& vehicle_pose, const RangeScanEvent& scan) const {
  prepare_beams(scan, options_);
  return score(map, vehicle_pose, options_);
}

template <typename Objective>
ScanMatch ScanMatcher::climb(const OccupancyGrid& map, const Pose2& guess, const RangeScanEvent& scan,
                             const Objective& objective) const {
  prepare_beams(scan, options_);
  // A bound on the climb, far above the few dozen moves a matchable guess needs, so a slope that
  // runs on (a corridor's length) ends the search.
  constexpr int kMaxIterations = 300;
  ScanMatch best = score(map, Pose2(guess.x(), guess.y(), wrap_angle(guess.z())), options_);
  double best_value = objective(best);
  double linear = options_.linear_step, angular = options_.angular_step;
  int halvings = 0;
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    const std::array<Pose2, 6> moves{Pose2(linear, 0.0, 0.0),  Pose2(-linear, 0.0, 0.0), Pose2(0.0, linear, 0.0),
                                     Pose2(0.0, -linear, 0.0), Pose2(0.0, 0.0, angular), Pose2(0.0, 0.0, -angular)};
    ScanMatch step_best = best;
    double step_value = best_value;
    for (const Pose2& move : moves) {
      const Pose2 moved = best.pose + move;
      const ScanMatch candidate = score(map, Pose2(moved.x(), moved.y(), wrap_angle(moved.z())), options_);
      const double value = objective(candidate);
      if (value > step_value) {
        step_best = candidate;
        step_value = value;
      }
    }
    if (step_value > best_value) {
      best = step_best;
      best_value = step_value;
      continue;
    }
    if (halvings == options_.refinements) break;
    linear /= 2.0;
    angular /= 2.0;
    ++halvings;
  }
  return best;
}

ScanMatch ScanMatcher::match(const OccupancyGrid& map, const Pose2& guess, const RangeScanEvent& scan) const {
  return climb(map, guess, scan, [](const ScanMatch& m) { return m.log_likelihood; });
}

double PosePrior::log_posterior(const Pose2& pose, double log_likelihood) const {
  Eigen::Vector3d from_mean = pose - mean;
  from_mean[2] = wrap_angle(from_mean[2]);
  return likelihood_scale * log_likelihood - 0.5 * from_mean.dot(information * from_mean);
}

ScanMatch ScanMatcher::match(const OccupancyGrid& map, const PosePrior& prior, const RangeScanEvent& scan) const {
  return climb(map, prior.mean, scan,
               [&](const ScanMatch& m) { return prior.log_posterior(m.pose, m.log_likelihood); });
}

}  // namespace slamkit
