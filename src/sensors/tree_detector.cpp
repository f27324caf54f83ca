#include "slamkit/sensors/tree_detector.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace slamkit {
namespace {

// The beams that returned, in scan order.
struct Beam {
  double angle;
  double range;
  double x() const { return range * std::cos(angle); }
  double y() const { return range * std::sin(angle); }
};

// Consecutive returned beams [first, last] (indices into the returned beams) that form one object.
struct Segment {
  std::size_t first;
  std::size_t last;
  bool dropped = false;
};

double distance(const Beam& a, const Beam& b) { return std::hypot(a.x() - b.x(), a.y() - b.y()); }

}  // namespace

std::vector<Tree> TreeDetector::detect(std::span<const double> ranges) const {
  // Angles between beams are whole multiples of the resolution; a threshold that equals such a
  // multiple must compare as equal, not as whatever the rounding of the two angles makes it.
  const double tolerance = 1e-6 * p_.angular_resolution;

  std::vector<Beam> beams;
  beams.reserve(ranges.size());
  for (std::size_t k = 0; k < ranges.size(); ++k)
    if (ranges[k] < p_.max_beam_range)
      beams.push_back({static_cast<double>(k) * p_.angular_resolution, ranges[k]});
  if (beams.empty()) return {};

  std::vector<Segment> segments;
  std::size_t first = 0;
  for (std::size_t i = 1; i <= beams.size(); ++i) {
    if (i < beams.size() && std::abs(beams[i].range - beams[i - 1].range) <= p_.segment_range_jump &&
        beams[i].angle - beams[i - 1].angle <= p_.segment_angle_gap + tolerance)
      continue;
    segments.push_back({first, i - 1});
    first = i;
  }

  // Clutter: an object whose end is near the start of one of the next few is part of something
  // larger or busier than a lone trunk (a bush, a fence, a group of trunks), and so are those.
  const std::size_t n = segments.size();
  const auto lookahead = static_cast<std::size_t>(std::max(p_.clutter_lookahead, 0));
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t k = 1; k <= lookahead && i + k < n; ++k) {
      if (distance(beams[segments[i].last], beams[segments[i + k].first]) < p_.clutter_distance) {
        segments[i].dropped = true;
        segments[i + k].dropped = true;
      }
    }
  }
  // Occlusion: of two objects next to each other in angle, the one behind has its visible edge made
  // by the one in front, so its width and centre are not its own.
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const Beam& end = beams[segments[i].last];
    const Beam& next_start = beams[segments[i + 1].first];
    if (next_start.angle - end.angle < p_.occlusion_angle - tolerance)
      segments[next_start.range > end.range ? i + 1 : i].dropped = true;
  }

  const double last_angle = static_cast<double>(ranges.size() - 1) * p_.angular_resolution;
  std::vector<Tree> trees;
  for (const Segment& s : segments) {
    if (s.dropped) continue;
    const Beam& a = beams[s.first];
    const Beam& b = beams[s.last];
    if (distance(a, b) >= p_.max_extent) continue;
    if (a.range <= p_.min_range || a.angle <= p_.edge_margin || b.angle >= last_angle - p_.edge_margin)
      continue;
    // The arc the segment subtends, counting half a beam spacing beyond each end beam.
    const double width = (b.angle - a.angle + p_.angular_resolution) * (a.range + b.range) / 2.0;
    // A round trunk is no deeper, end to end, than a fraction of its width; a wall seen at a slant
    // or an object's edge is.
    if (std::abs(a.range - b.range) >= p_.max_depth_ratio * width) continue;
    // The middle of the segment (one beam or the two around the centre) is the nearest point of a
    // round trunk; the centre is half the width behind it.
    const double near = (beams[(s.first + s.last) / 2].range + beams[(s.first + s.last + 1) / 2].range) / 2.0;
    const double angle = (a.angle + b.angle) / 2.0;
    trees.push_back({near + width / 2.0, angle, angle - kPi / 2.0, width});
  }
  return trees;
}

}  // namespace slamkit
