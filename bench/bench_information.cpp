// The cost of one SLAM step against the map's size, 100 to 30,000 landmarks: the sparse extended
// information filter (SEIF), whose step touches the vehicle, the landmarks linked to it and their
// neighbours in Omega's graph and so should cost the same however large the map, beside the exact
// filters whose step grows with it: the full EKF's O(n^2) downdate of the covariance and the EIF's
// factorisation of an Omega that the motion has filled in. `slamkit plot-bench` draws them as
// information_vs_landmarks.svg.
//
// A step is what a run does per scan, through EkfSlam with its defaults (SEIF 20 active landmarks,
// ESEIF 60; 2 recovery sweeps; SEIF's local covariances): the predictions of the scan's controls (eight of
// 25 ms), then the update with the scan (about ten range-bearing observations with known identities).
// The known-identity gate is on, as the command line runs it; for the SEIF that is most of a step (the
// covariances it reads come from one local recovery over the Markov blanket of the scan's landmarks),
// so seif_ungated times the SEIF without it: the filter's own step, the paper's constant-time one.
// eseif_ungated is the exactly sparse filter's own step (its default exact covariance recovery, which
// the gate would read, is a factorisation of the whole map), tjtf_ungated the thin junction tree
// filter's (its default 24 landmarks a clique).
//
// The maps have the city's landmark density whatever their size (30,000 landmarks on 66 km of street,
// 4-12 m beside it), so that a scan sees as many landmarks and a landmark has as many neighbours at
// every n: a street grid of fewer or smaller blocks (the city itself at 30,000), or, where a grid would
// need blocks too small to drive round (n = 100), a loop of generate_world's shape with the same band.
// The sensor is the city scenario's (a 180 degree view reaching 22 m).
//  * SEIF, ESEIF and TJTF: drive the world's route once, which sees every landmark, so that Omega's
//    links (the junction tree's cliques) are those a run gives it (landmarks linked where they were
//    active together, streets linked at crossings). The city's 120,000 scans take about 40 s; it is
//    done once per map size. The counters say how the route left it: pose_error_m at the stretch's
//    start, route_rejected (the share the gate refused). TJTF stops at 10,000 landmarks: its walks
//    from the root to a landmark seen again grow with the chain of cliques the route leaves, and
//    driving the city's route takes it more than ten minutes.
//  * EKF and EIF: driving to their largest maps is out of reach (3,000 landmarks are 13,000 scans, of
//    up to 25 ms each for the EKF; the EIF's step at 1,000 takes seconds), so, as ekf_fixture.hpp
//    does, they start at the stretch's first pose with every landmark seen once from there. Their step
//    does not depend on how the map was made: the EKF's covariance is dense whatever it holds, and the
//    exact EIF's vehicle stays linked to every landmark it saw, so its first motion links them all to
//    each other, as on any route (two untimed steps make that fill before the timing).
//    The EIF stops at 1,000 landmarks (a factorisation of the dense Omega per scan, O(n^3)); the EKF
//    at 3,000, beyond which its covariance (3.2 GB at 10,000) and a step of a second or more outgrow
//    the machine that runs the suite, and the O(n^2) is plain by then.
//
// The timed steps: after the route the vehicle drives laps round one block (round the loop itself in
// a loop world), where every landmark it sees is mapped, as in most of a run. The steps timed are a
// stretch of those laps from the second on (the first lets the steering settle onto its periodic
// path), ending at the scan whose true pose is nearest the stretch's first, so that cycling over it
// continues the drive: each iteration is the next step of the stretch, and at the wrap the vehicle
// jumps by the counter wrap_m (under a centimetre), which the gate accepts. The filter's clock runs on
// across wraps. Nothing is copied per step; each benchmark continues where the previous run of its map
// left off.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

// A namespace of its own: the benchmarks are compiled as one unity batch, where the other files' names
// (Scene, step, map_sizes) are in scope.
namespace slamkit::information_step {
namespace {

constexpr int kMaxSeif = 30'000, kMaxEif = 1'000, kMaxEkf = 3'000, kMaxTjtf = 10'000;
// Below this a street's bands (12 m each side) and the intersections leave little of a block, and a
// lap round one is a few scans: such maps are a loop instead.
constexpr double kMinBlockM = 50.0;
// Laps simulated after the route: one to settle, one to start the stretch in, two to end it in.
constexpr int kLaps = 4;
// The stretch starts where this many scans see as many landmarks as the lap's average, so that a filter
// slow enough to be timed over a few steps (the EIF at 1,000 landmarks runs one or two) times typical
// ones rather than a corner's.
constexpr std::size_t kTypicalScans = 25;
// The laps' noise, other than the route's, so that they do not replay its first scans' errors.
constexpr std::uint64_t kLapSeed = 2;
// Untimed steps of the exact filters after their set-up: the EIF's first motion fills Omega in.
constexpr int kExactWarmSteps = 2;

double street_length(int blocks, double block_m) { return 2.0 * (blocks + 1) * blocks * block_m; }

/// The city's landmarks per metre of street, both sides together.
double city_density() {
  const StreetGridOptions city;
  return city.landmarks / street_length(city.blocks, city.block_m);
}

double closed_route_length(const std::vector<Vector2>& route) {
  double length = 0.0;
  for (std::size_t i = 0; i < route.size(); ++i) length += (route[(i + 1) % route.size()] - route[i]).norm();
  return length;
}

/// A world of `n` landmarks at the city's density, and the closed lap driven after its route.
void make_world(int n, World& world, std::vector<Vector2>& lap) {
  const StreetGridOptions city;
  const double length = n / city_density();
  // The fewest blocks, each no longer than the city's: the city itself at its own count.
  int blocks = 2;
  while (length / street_length(blocks, 1.0) > city.block_m * (1.0 + 1e-9)) blocks += 2;
  const double block_m = length / street_length(blocks, 1.0);
  if (block_m >= kMinBlockM) {
    StreetGridOptions grid;
    grid.blocks = blocks;
    grid.block_m = block_m;
    grid.landmarks = n;
    world = street_grid_world(grid);
    // The south-west block, counter-clockwise: the route ends at (0, 0).
    lap = {{block_m, 0.0}, {block_m, block_m}, {0.0, block_m}, {0.0, 0.0}};
    return;
  }
  // A rounded rectangle twice as wide as high, whose perimeter 2 (w + h) - (8 - 2 pi) h / 4 holds the
  // landmarks at the city's density, in the city's band.
  WorldGenOptions loop;
  loop.height = length / (4.0 + kPi / 2.0);
  loop.width = 2.0 * loop.height;
  loop.landmarks = n;
  loop.band_inner = city.band_inner;
  loop.band_outer = city.band_outer;
  loop.min_spacing = city.min_spacing;
  world = generate_world(loop);
  lap = world.waypoints;
}

/// A world, its route and the laps after it, shared by the filters of one map size.
struct Scene {
  World world;
  SimulatorConfig config;
  std::optional<Dataset> route;  // the route that sees every landmark, until the SEIF has driven it
  std::shared_ptr<const MotionModel> motion;
  std::shared_ptr<const ObservationModel> observation;
  SensorLimits sensor;
  std::vector<Event> events;  // the laps' events, up to the stretch's end
  std::vector<double> times;  // their times as simulated
  std::size_t settled = 0;    // events[0, settled) lead up to the stretch
  std::vector<std::size_t> step_ends;  // step i is events [i ? step_ends[i - 1] : settled, step_ends[i])
  Pose2 start_pose = Pose2::Zero();    // the true pose at events[settled - 1], the scan before the stretch
  double duration = 0.0;               // of the stretch [s]
  double wrap_m = 0.0;                 // the mismatch at the wrap (heading taken at the sensor's reach)
};

/// How far apart two poses are for what the sensor sees: the distance plus the displacement their
/// heading difference gives a landmark at the sensor's reach.
double mismatch(const Pose2& a, const Pose2& b, double reach) {
  return (a.head<2>() - b.head<2>()).norm() + reach * std::abs(wrap_angle(a[2] - b[2]));
}

std::unique_ptr<Scene> make_scene(int n) {
  auto s = std::make_unique<Scene>();
  std::vector<Vector2> lap;
  make_world(n, s->world, lap);
  static const SimulatorConfig city = scenario("city").config;  // one pass of the route, the city's sensor
  s->config = city;
  s->route = simulate(s->world, s->config);

  World laps;
  laps.landmarks = s->world.landmarks;
  laps.waypoints = lap;
  laps.start = s->route->truth.poses.back().pose;
  SimulatorConfig config = s->config;
  config.loops = kLaps;
  config.seed = kLapSeed;
  Dataset driven = simulate(laps, config);
  s->motion = driven.motion;
  s->observation = driven.observation;
  s->sensor = driven.sensor;

  // Each scan's event, true pose (the scan follows its step's control, whose pose the truth holds) and
  // observations.
  struct Scan {
    std::size_t event;
    double t;
    Pose2 pose;
    double seen;
  };
  std::vector<Scan> scans;
  std::size_t controls = 0;
  for (std::size_t i = 0; i < driven.events.size(); ++i) {
    if (const auto* scan = std::get_if<ScanEvent>(&driven.events[i]))
      scans.push_back({i, scan->t, driven.truth.poses[controls].pose, static_cast<double>(scan->observations.size())});
    else
      ++controls;
  }
  // The second lap: its average, and the start of its most typical run of scans.
  const double lap_s = closed_route_length(lap) / config.speed;
  std::size_t lap_begin = 1, lap_end = 1;
  while (lap_begin < scans.size() && scans[lap_begin].t < lap_s) ++lap_begin;
  while (lap_end < scans.size() && scans[lap_end].t < 2.0 * lap_s) ++lap_end;
  if (lap_end + kTypicalScans > scans.size())
    throw std::logic_error("bench_information: the laps are shorter than their route");
  double average = 0.0;
  for (std::size_t j = lap_begin; j < lap_end; ++j) average += scans[j].seen;
  average /= static_cast<double>(lap_end - lap_begin);
  std::size_t first = lap_begin;
  double least = std::numeric_limits<double>::infinity();
  for (std::size_t j = lap_begin; j < lap_end; ++j) {
    double off = 0.0;
    for (std::size_t k = j; k < j + kTypicalScans; ++k) off += std::abs(scans[k].seen - average);
    if (off < least) {
      least = off;
      first = j;
    }
  }
  std::size_t end = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t j = first + 1; j < scans.size(); ++j) {
    if (scans[j].t < scans[first].t + 0.9 * lap_s) continue;
    const double m = mismatch(scans[j].pose, scans[first].pose, config.max_range);
    if (m < best) {
      best = m;
      end = j;
    }
  }
  if (end == 0) throw std::logic_error("bench_information: the laps hold no scan a lap after the stretch's start");
  s->settled = scans[first - 1].event + 1;
  for (std::size_t j = first; j < end; ++j) s->step_ends.push_back(scans[j].event + 1);
  s->start_pose = scans[first - 1].pose;
  s->duration = scans[end - 1].t - scans[first - 1].t;
  s->wrap_m = best;
  driven.events.resize(s->step_ends.back());
  s->events = std::move(driven.events);
  for (const Event& e : s->events) s->times.push_back(event_time(e));
  return s;
}

/// The scene of each map size, kept for the whole run: built once for every filter.
Scene& scene(int n) {
  static std::map<int, std::unique_ptr<Scene>> scenes;
  std::unique_ptr<Scene>& s = scenes[n];
  if (!s) s = make_scene(n);
  return *s;
}

/// A filter with its map, and where it is in the stretch.
struct Running {
  EkfVariant variant = EkfVariant::kFull;
  bool gate = true;
  int n = -1;
  std::unique_ptr<EkfSlam> filter;
  std::size_t next = 0;  // the step of the stretch it runs next
  double offset = 0.0;   // added to the scene's times, so that the filter's clock runs on across wraps
  std::size_t setup_scans = 0;
  // The SEIF's position error at the stretch's start: how far the route left it from the truth (the
  // exact filters start at the truth).
  double pose_error_m = 0.0;
  double route_rejected = 0.0;  // the share of the route's observations the SEIF's gate refused
};

void feed(EkfSlam& filter, Event& event, double t) {
  std::visit(
      [&](auto& e) {
        e.t = t;
        if constexpr (std::is_same_v<std::decay_t<decltype(e)>, ControlEvent>)
          filter.predict(e);
        else if constexpr (std::is_same_v<std::decay_t<decltype(e)>, ScanEvent>)
          filter.update(e);
      },
      event);
}

/// One step of the stretch: its controls, then its scan.
void step(Running& r, Scene& s) {
  const std::size_t end = s.step_ends[r.next];
  for (std::size_t i = r.next == 0 ? s.settled : s.step_ends[r.next - 1]; i < end; ++i)
    feed(*r.filter, s.events[i], s.times[i] + r.offset);
  if (++r.next == s.step_ends.size()) {
    r.next = 0;
    r.offset += s.duration;
  }
}

EkfSlamOptions options(EkfVariant variant, bool gate, const Scene& s, const Pose2& start) {
  EkfSlamOptions o;
  o.variant = variant;
  o.sensor = s.sensor;
  o.initial_pose = start;
  // One thread, as the information filters have: Google Benchmark's CPU time is the benchmark
  // thread's, and the comparison is of the work a step does.
  o.threads = 1;
  o.association.gate_known = gate;
  return o;
}

bool sparse(EkfVariant variant) {
  return variant == EkfVariant::kSparseInformation || variant == EkfVariant::kExactlySparseInformation;
}

/// Filters whose map is made by driving the route: the sparse ones and the thin junction tree.
bool driven(EkfVariant variant) { return sparse(variant) || variant == EkfVariant::kThinJunctionTree; }

double statistic(const EkfSlam& filter, const std::string& name) {
  const auto s = filter.statistics();
  const auto it = s.find(name);
  return it == s.end() ? 0.0 : it->second;
}

/// A filter whose map the route makes (SEIF, ESEIF, TJTF) after the route and the lap that settles the laps.
void drive_route(Running& r, Scene& s) {
  if (!s.route) s.route = simulate(s.world, s.config);  // driven before, by another filter
  r.filter = std::make_unique<EkfSlam>(s.motion, s.observation, options(r.variant, r.gate, s, s.route->initial_pose));
  for (const Event& event : s.route->events)
    std::visit(
        [&](const auto& e) {
          if constexpr (std::is_same_v<std::decay_t<decltype(e)>, ControlEvent>) {
            r.filter->predict(e);
          } else if constexpr (std::is_same_v<std::decay_t<decltype(e)>, ScanEvent>) {
            r.filter->update(e);
            ++r.setup_scans;
          }
        },
        event);
  r.route_rejected = statistic(*r.filter, "known_id_rejected_fraction");
  r.offset = event_time(s.route->events.back());  // the laps' clock starts at the route's end
  s.route.reset();                                 // the city's is a hundred megabytes
  for (std::size_t i = 0; i < s.settled; ++i) feed(*r.filter, s.events[i], s.times[i] + r.offset);
  r.pose_error_m = (r.filter->pose().head<2>() - s.start_pose.head<2>()).norm();
}

/// The EKF or EIF at the stretch's start with every landmark seen once from there.
void map_exact(Running& r, Scene& s) {
  r.filter = std::make_unique<EkfSlam>(s.motion, s.observation, options(r.variant, r.gate, s, s.start_pose));
  ScanEvent all{s.times[s.settled - 1], {}};
  all.observations.reserve(s.world.landmarks.size());
  for (const Landmark& l : s.world.landmarks)
    all.observations.push_back({s.observation->predict(s.start_pose, l.position), l.id});
  r.filter->update(all);
  r.setup_scans = 1;
  for (int k = 0; k < kExactWarmSteps; ++k) step(r, s);
}

/// One filter alive at a time: the EKF's at 3,000 landmarks holds 0.3 GB.
Running& running(EkfVariant variant, bool gate, int n) {
  static Running r;
  if (r.filter && r.variant == variant && r.gate == gate && r.n == n) return r;
  r = Running{};
  r.variant = variant;
  r.gate = gate;
  r.n = n;
  Scene& s = scene(n);
  if (driven(variant))
    drive_route(r, s);
  else
    map_exact(r, s);
  return r;
}

void BM_InformationStep(benchmark::State& state, EkfVariant variant, bool gate) {
  const int n = static_cast<int>(state.range(0));
  Running& r = running(variant, gate, n);
  Scene& s = scene(n);
  const double rejected_before = statistic(*r.filter, "outliers_rejected");
  std::size_t observations = 0;
  for (auto _ : state) {
    observations += std::get<ScanEvent>(s.events[s.step_ends[r.next] - 1]).observations.size();
    step(r, s);
  }
  const EkfSlam& filter = *r.filter;
  state.counters["landmarks"] = static_cast<double>(filter.num_landmarks());
  state.counters["observations"] =
      benchmark::Counter(static_cast<double>(observations), benchmark::Counter::kAvgIterations);
  // What the gate refused in the timed steps. A filter that refuses most has lost itself: its steps
  // update little, and EkfSlam's known-identity recovery works instead (once the gate has refused
  // most of the last 30 s, every scan reads the covariance of each landmark refused in them, for the
  // SEIF one local recovery each).
  state.counters["rejected"] = statistic(filter, "outliers_rejected") - rejected_before;
  state.counters["stretch_steps"] = static_cast<double>(s.step_ends.size());
  state.counters["wrap_m"] = s.wrap_m;
  state.counters["setup_scans"] = static_cast<double>(r.setup_scans);
  if (variant == EkfVariant::kInformation || sparse(variant))
    state.counters["information_nonzeros"] = statistic(filter, "information_nonzeros");
  if (driven(variant)) {
    state.counters["pose_error_m"] = r.pose_error_m;
    state.counters["route_rejected"] = r.route_rejected;
  }
  if (variant == EkfVariant::kThinJunctionTree) {
    state.counters["cliques"] = statistic(filter, "tjtf_cliques");
    state.counters["widest_clique"] = statistic(filter, "tjtf_widest_clique");
  }
  if (sparse(variant)) {
    state.counters["active"] = statistic(
        filter, variant == EkfVariant::kSparseInformation ? "seif_active_landmarks" : "eseif_active_landmarks");
  }
}

void map_sizes(benchmark::internal::Benchmark* b, int largest) {
  for (const int n : {100, 300, 1'000, 3'000, 10'000, 30'000})
    if (n <= largest) b->Arg(n);
  b->Unit(benchmark::kMicrosecond);
}
void seif_sizes(benchmark::internal::Benchmark* b) { map_sizes(b, kMaxSeif); }
void eif_sizes(benchmark::internal::Benchmark* b) { map_sizes(b, kMaxEif); }
void ekf_sizes(benchmark::internal::Benchmark* b) { map_sizes(b, kMaxEkf); }
void tjtf_sizes(benchmark::internal::Benchmark* b) { map_sizes(b, kMaxTjtf); }

// Named BM_InformationStep/<filter>/<landmarks>: the series of information_vs_landmarks.svg.
BENCHMARK_CAPTURE(BM_InformationStep, seif, EkfVariant::kSparseInformation, true)->Apply(seif_sizes);
BENCHMARK_CAPTURE(BM_InformationStep, seif_ungated, EkfVariant::kSparseInformation, false)->Apply(seif_sizes);
BENCHMARK_CAPTURE(BM_InformationStep, eseif_ungated, EkfVariant::kExactlySparseInformation, false)
    ->Apply(seif_sizes);
BENCHMARK_CAPTURE(BM_InformationStep, eif, EkfVariant::kInformation, true)->Apply(eif_sizes);
BENCHMARK_CAPTURE(BM_InformationStep, ekf, EkfVariant::kFull, true)->Apply(ekf_sizes);
BENCHMARK_CAPTURE(BM_InformationStep, tjtf_ungated, EkfVariant::kThinJunctionTree, false)->Apply(tjtf_sizes);

}  // namespace
}  // namespace slamkit::information_step
