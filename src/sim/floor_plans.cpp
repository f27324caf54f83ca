// The built-in floor plans of simulate_building. Coordinates in metres, the building's lower left
// corner at the origin. Each route keeps at least 0.7 m from every wall (door jambs included), so
// that the robot's pure pursuit, which cuts corners by a little, never comes near one.
#include <algorithm>
#include <array>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "slamkit/core/names.hpp"
#include "slamkit/sim/building.hpp"

namespace slamkit {
namespace {

/// A doorway's extent along its wall.
struct Doorway {
  double from = 0.0;
  double to = 0.0;
};

class PlanDrawing {
 public:
  explicit PlanDrawing(std::string name) { plan_.name = std::move(name); }

  void wall(const Vector2& a, const Vector2& b) { plan_.walls.push_back(WallSegment{a, b}); }

  /// A rectangle's outline: a building's shell, a table, a cabinet.
  void box(double x0, double y0, double x1, double y1) {
    wall({x0, y0}, {x1, y0});
    wall({x1, y0}, {x1, y1});
    wall({x1, y1}, {x0, y1});
    wall({x0, y1}, {x0, y0});
  }

  /// The wall from a to b broken by doorways, each given by its distances from a (in order).
  void wall_with_doors(const Vector2& a, const Vector2& b, const std::vector<Doorway>& doors) {
    const Vector2 along = (b - a).normalized();
    double from = 0.0;
    for (const Doorway& door : doors) {
      wall(a + from * along, a + door.from * along);
      from = door.to;
    }
    wall(a + from * along, b);
  }

  /// wall_with_doors for the walls along the axes, with the doorways at absolute coordinates.
  void horizontal(double y, double x0, double x1, std::initializer_list<Doorway> doors) {
    wall_with_doors({x0, y}, {x1, y}, shifted(doors, x0));
  }
  void vertical(double x, double y0, double y1, std::initializer_list<Doorway> doors) {
    wall_with_doors({x, y0}, {x, y1}, shifted(doors, y0));
  }

  void route(std::initializer_list<Vector2> waypoints) { plan_.route = waypoints; }

  FloorPlan take() { return std::move(plan_); }

 private:
  static std::vector<Doorway> shifted(std::initializer_list<Doorway> doors, double origin) {
    std::vector<Doorway> out;
    for (const Doorway& d : doors) out.push_back({d.from - origin, d.to - origin});
    return out;
  }

  FloorPlan plan_;
};

}  // namespace

// ---- Office -----------------------------------------------------------------------------------------

// A 2 m wide corridor rings a central pair of rooms (x 6-14, y 5-10) and is ringed by eight rooms
// against the outer walls. Every corridor wall has a doorway within a few metres, and the rooms
// behind hold furniture, so that each scan along the corridor sees corners and edges ahead and to
// both sides. The route drives the corridor ring counter-clockwise and, on the way, a clockwise
// lap round the table of the south-east room: two loops that the second lap closes.
FloorPlan office_floor_plan() {
  PlanDrawing d("office");
  d.box(0.0, 0.0, 20.0, 15.0);
  // The corridor's outer walls.
  d.horizontal(3.0, 4.0, 16.0, {{6.2, 7.2}, {12.8, 13.8}});
  d.horizontal(12.0, 4.0, 16.0, {{8.0, 9.0}, {11.5, 12.5}});
  d.vertical(4.0, 3.0, 12.0, {{5.0, 6.0}, {9.5, 10.5}});
  d.vertical(16.0, 3.0, 12.0, {{5.0, 6.4}, {9.0, 10.0}});  // the first, wider, on the route
  // The central rooms, with a door between them.
  d.horizontal(5.0, 6.0, 14.0, {{7.5, 8.5}});
  d.horizontal(10.0, 6.0, 14.0, {{11.0, 12.0}});
  d.vertical(6.0, 5.0, 10.0, {{7.0, 8.0}});
  d.vertical(14.0, 5.0, 10.0, {{7.5, 8.5}});
  d.vertical(10.0, 5.0, 10.0, {{6.5, 7.5}});
  // Partitions between the outer rooms.
  d.wall({0.0, 7.5}, {4.0, 7.5});
  d.wall({16.0, 7.5}, {20.0, 7.5});
  for (const double x : {4.0, 10.0, 16.0}) {
    d.wall({x, 0.0}, {x, 3.0});
    d.wall({x, 12.0}, {x, 15.0});
  }
  // Furniture: desks, tables and cabinets as boxes, shelves and screens as short walls.
  d.box(0.8, 1.0, 2.4, 1.8);
  d.box(0.3, 4.2, 0.9, 6.2);
  d.box(1.2, 10.8, 2.6, 12.4);
  d.box(4.6, 0.5, 6.0, 1.3);
  d.wall({8.5, 0.0}, {8.5, 1.2});
  d.box(14.0, 0.6, 15.4, 1.5);
  d.wall({11.2, 3.0}, {11.2, 2.2});
  d.box(5.0, 13.2, 7.0, 14.2);
  d.box(13.6, 13.6, 15.2, 14.5);
  d.wall({10.8, 15.0}, {10.8, 13.8});
  d.box(17.4, 11.6, 19.2, 12.6);
  d.wall({20.0, 9.5}, {19.0, 9.5});
  d.box(17.7, 2.6, 18.3, 4.4);  // the table the route circles
  d.box(7.2, 8.4, 8.6, 9.2);
  d.box(12.0, 5.8, 13.2, 6.6);
  d.wall({14.0, 9.2}, {13.2, 9.2});
  d.route({{5.0, 4.0},
           {15.0, 4.0},
           {15.0, 5.7},
           {19.0, 5.7},
           {19.0, 1.2},
           {17.0, 1.2},
           {17.0, 5.7},
           {15.0, 5.7},
           {15.0, 11.0},
           {5.0, 11.0}});
  return d.take();
}

// ---- Corridors --------------------------------------------------------------------------------------

namespace {

constexpr double kOfficeDepth = 4.0;
// Unequal, so that no two stretches of a row look alike to the laser.
constexpr std::array<double, 6> kOfficeWidths = {5.0, 4.0, 6.0, 4.5, 5.5, 3.5};

// A row of offices along one side of a block of rooms, the side running from corner a to corner b
// with `inward` pointing into the block: the side wall with a doorway into each office, the
// partitions, the row's back wall and a desk in each office, where the laser sees it through the
// doorway. The offices fill [from, to] (distances from a); the last takes what the widths leave.
void office_row(PlanDrawing& d, const Vector2& a, const Vector2& b, const Vector2& inward, double from, double to) {
  const Vector2 along = (b - a).normalized();
  const auto at = [&](double s, double depth) -> Vector2 { return a + s * along + depth * inward; };
  std::vector<Doorway> doors;
  double start = from;
  for (std::size_t k = 0; start < to; ++k) {
    const double width = kOfficeWidths[k % kOfficeWidths.size()];
    const double end = to - (start + width) < kOfficeWidths.back() ? to : start + width;
    // Doors alternate between the offices' two ends; the desk stands at the other.
    const bool door_first = k % 2 == 0;
    doors.push_back(door_first ? Doorway{start + 0.6, start + 1.6} : Doorway{end - 1.6, end - 0.6});
    const double desk = door_first ? end - 1.4 : start + 1.4;
    d.wall(at(desk - 0.6, 3.0), at(desk + 0.6, 3.0));
    d.wall(at(start, 0.0), at(start, kOfficeDepth));
    start = end;
  }
  d.wall(at(to, 0.0), at(to, kOfficeDepth));
  d.wall(at(from, kOfficeDepth), at(to, kOfficeDepth));
  d.wall_with_doors(a, b, doors);
}

}  // namespace

// Corridors 2.5 m wide along the outer walls and across the middle (centre lines x = 1.25, 40, 78.75
// and y = 1.25, 30, 58.75) between four blocks of rooms, some sides lined with offices and some
// blank. The route, 270 m a lap, goes east along the south corridor, north up the middle to the
// cross corridor, east along its blank eastern half, north, west along the north corridor and south
// back to the start. The blank stretch of the cross corridor is the hard case for scan matching:
// for its first 19 m the laser (20 m, looking ahead) sees two parallel walls and nothing else.
FloorPlan corridor_building_floor_plan() {
  PlanDrawing d("corridors");
  d.box(0.0, 0.0, 80.0, 60.0);
  constexpr double w0 = 2.5, w1 = 38.75, e0 = 41.25, e1 = 77.5;  // the blocks' x extents
  constexpr double s0 = 2.5, s1 = 28.75, n0 = 31.25, n1 = 57.5;  // and their y extents
  const Vector2 up(0.0, 1.0), down(0.0, -1.0), right(1.0, 0.0), left(-1.0, 0.0);
  // South-west block: offices on the south, east and west sides.
  office_row(d, {w0, s0}, {w1, s0}, up, 0.5, 32.0);
  office_row(d, {w1, s0}, {w1, s1}, left, 4.5, 26.0);
  office_row(d, {w0, s0}, {w0, s1}, right, 4.5, 26.0);
  d.wall({w0, s1}, {w1, s1});
  // South-east block: blank.
  d.box(e0, s0, e1, s1);
  // North-east block: offices on the east and north sides.
  office_row(d, {e1, n0}, {e1, n1}, left, 3.5, 21.5);
  office_row(d, {e0, n1}, {e1, n1}, down, 0.5, 31.5);
  d.wall({e0, n0}, {e1, n0});
  d.wall({e0, n0}, {e0, n1});
  // North-west block: offices on the west side and the eastern half of the north side.
  office_row(d, {w0, n0}, {w0, n1}, right, 0.5, 21.5);
  office_row(d, {w0, n1}, {w1, n1}, down, 17.5, 35.75);
  d.wall({w0, n0}, {w1, n0});
  d.wall({w1, n0}, {w1, n1});
  d.route({{1.25, 1.25}, {40.0, 1.25}, {40.0, 30.0}, {78.75, 30.0}, {78.75, 58.75}, {1.25, 58.75}});
  return d.take();
}

// A 2.5 m corridor round a block of offices lined on all four sides (35 m x 25 m outside, the block
// 30 m x 20 m): the office's loop at a scale where each scan sees one side of it, 110 m a lap. The
// route drives the corridor counter-clockwise, so the offices are always on the robot's left and the
// blank outer wall on its right.
FloorPlan ring_floor_plan() {
  PlanDrawing d("ring");
  d.box(0.0, 0.0, 35.0, 25.0);
  constexpr double x0 = 2.5, x1 = 32.5, y0 = 2.5, y1 = 22.5;  // the block
  const Vector2 up(0.0, 1.0), down(0.0, -1.0), right(1.0, 0.0), left(-1.0, 0.0);
  office_row(d, {x0, y0}, {x1, y0}, up, 0.5, 29.5);
  office_row(d, {x1, y0}, {x1, y1}, left, 4.5, 15.5);
  office_row(d, {x0, y1}, {x1, y1}, down, 0.5, 29.5);
  office_row(d, {x0, y0}, {x0, y1}, right, 4.5, 15.5);
  d.route({{1.25, 1.25}, {33.75, 1.25}, {33.75, 23.75}, {1.25, 23.75}});
  return d.take();
}

namespace {

struct PlanEntry {
  const char* name;
  FloorPlan (*make)();
};

const PlanEntry kFloorPlans[] = {
    {"office", &office_floor_plan}, {"corridors", &corridor_building_floor_plan}, {"ring", &ring_floor_plan}};

}  // namespace

FloorPlan floor_plan(const std::string& name) {
  const auto entry = std::find_if(std::begin(kFloorPlans), std::end(kFloorPlans),
                                  [&](const PlanEntry& e) { return name == e.name; });
  if (entry == std::end(kFloorPlans))
    throw std::invalid_argument(unknown_name_message("floor plan", name, floor_plan_names()));
  return entry->make();
}

std::vector<std::string> floor_plan_names() {
  std::vector<std::string> names;
  for (const PlanEntry& e : kFloorPlans) names.emplace_back(e.name);
  return names;
}

}  // namespace slamkit
