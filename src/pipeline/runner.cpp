#include "slamkit/pipeline/runner.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "slamkit/core/coordinates.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/names.hpp"
#include "slamkit/grid/occupancy_grid.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

namespace {

/// Time of the pose the stream starts from: just before the first control is applied.
double start_time(const Dataset& dataset) {
  for (const Event& e : dataset.events)
    if (const auto* c = std::get_if<ControlEvent>(&e)) return c->t - c->dt;
  return dataset.events.empty() ? 0.0 : event_time(dataset.events.front());
}

bool within(double v, double limit) { return std::abs(v) <= limit; }  // false for NaN

/// Keeps a series of samples to at most `capacity` distinct times, evenly spread over the run: the
/// sample times taken are every stride-th one offered, and when the kept ones exceed the capacity,
/// every other kept time is dropped and the stride doubles. Samples sharing a time go together.
class Thinning {
 public:
  explicit Thinning(std::size_t capacity) : capacity_(std::max<std::size_t>(capacity, 2)) {}

  /// Whether samples at time `t` (offered in time order) are kept.
  bool take(double t) {
    if (t != last_t_) {
      last_t_ = t;
      taking_ = offered_++ % stride_ == 0;
      kept_ += taking_;
    }
    return taking_;
  }

  /// Called after samples are kept in `series` (and their twins in `companion`, same index); halves
  /// the series when it holds more than the capacity's times.
  template <typename T, typename U = int>
  void limit(std::vector<T>& series, std::vector<U>* companion = nullptr) {
    if (kept_ <= capacity_) return;
    std::size_t ordinal = 0, out = 0;
    for (std::size_t i = 0; i < series.size(); ++i) {
      if (i > 0 && series[i].t != series[i - 1].t) ++ordinal;
      if (ordinal % 2 != 0) continue;
      series[out] = std::move(series[i]);
      if (companion != nullptr) (*companion)[out] = std::move((*companion)[i]);
      ++out;
    }
    series.resize(out);
    if (companion != nullptr) companion->resize(out);
    kept_ = (kept_ + 1) / 2;
    stride_ *= 2;
  }

 private:
  std::size_t capacity_;
  std::size_t stride_ = 1;
  std::size_t offered_ = 0;
  std::size_t kept_ = 0;
  double last_t_ = NAN;
  bool taking_ = false;
};

/// Dead reckoning under the run's history: every pose, thinned, or the start and the end.
std::vector<StampedPose> dead_reckoning(const Dataset& dataset, const RunOptions& options) {
  std::vector<StampedPose> out;
  Thinning thinning(options.decimated_samples);
  Pose2 pose = dataset.initial_pose;
  out.push_back({start_time(dataset), pose});
  StampedPose last = out.back();
  for (const Event& event : dataset.events) {
    const auto* control = std::get_if<ControlEvent>(&event);
    if (control == nullptr) continue;
    pose = dataset.motion->predict(pose, control->u, control->dt);
    switch (options.history) {
      case History::kFull: out.push_back({control->t, pose}); break;
      case History::kDecimated:
        if (thinning.take(control->t)) {
          out.push_back({control->t, pose});
          thinning.limit(out);
        }
        break;
      case History::kNone:
        if (out.size() == 2) out.pop_back();
        out.push_back({control->t, pose});
        break;
    }
    last = {control->t, pose};
  }
  if (out.back().t != last.t) out.push_back(last);  // thinning keeps the start; the end goes too
  return out;
}

}  // namespace

History parse_history(const std::string& name) {
  if (name == "full") return History::kFull;
  if (name == "decimated") return History::kDecimated;
  if (name == "none") return History::kNone;
  throw std::invalid_argument(unknown_name_message("history", name, {"full", "decimated", "none"}));
}

std::string to_string(History history) {
  switch (history) {
    case History::kFull: return "full";
    case History::kDecimated: return "decimated";
    case History::kNone: return "none";
  }
  return "full";
}

void check_events(const Dataset& dataset) {
  const Pose2& start = dataset.initial_pose;
  if (!within_coordinates(start.head<2>()) || !std::isfinite(start.z()))
    throw InputError(dataset.spec, 0,
                     fmt::format("expected an initial pose with x and y within +-{:g} m and a finite heading, found "
                                 "({}, {}, {})",
                                 kMaxAbsCoordinate, start.x(), start.y(), start.z()));
  const int control_dim = dataset.motion ? dataset.motion->control_dim() : -1;
  const int measurement_dim = dataset.observation ? dataset.observation->dim() : -1;
  double previous = -INFINITY;
  for (std::size_t i = 0; i < dataset.events.size(); ++i) {
    const Event& event = dataset.events[i];
    const double t = event_time(event);
    const auto refuse = [&](const std::string& what) {
      throw InputError(dataset.spec, 0, fmt::format("event {} (t = {}): expected {}", i, t, what));
    };
    if (!within(t, kMaxAbsTime)) refuse(fmt::format("a time within +-{:g} s", kMaxAbsTime));
    if (t < previous) refuse(fmt::format("a time not before the previous event's ({})", previous));
    previous = t;
    if (const auto* control = std::get_if<ControlEvent>(&event)) {
      if (!(control->dt >= 0.0 && control->dt <= kMaxAbsTime))
        refuse(fmt::format("a control interval dt from 0 to {:g} s, found {}", kMaxAbsTime, control->dt));
      if (control->u.size() != control_dim)
        refuse(fmt::format("a control of {} values for the motion model, found {}", control_dim, control->u.size()));
      for (Eigen::Index k = 0; k < control->u.size(); ++k)
        if (!within(control->u(k), kMaxAbsValue))
          refuse(fmt::format("control values within +-{:g}, found {}", kMaxAbsValue, control->u(k)));
    } else if (const auto* range_scan = std::get_if<RangeScanEvent>(&event)) {
      if (!std::isfinite(range_scan->angle_min) || !std::isfinite(range_scan->angle_increment) ||
          !(range_scan->max_range > 0.0 && range_scan->max_range <= kMaxAbsValue))
        refuse(fmt::format("a range scan with a finite beam geometry and a max range from 0 to {:g} m", kMaxAbsValue));
      if (!within_coordinates(range_scan->sensor_offset.head<2>()) || !std::isfinite(range_scan->sensor_offset.z()))
        refuse("a range scan whose sensor offset is finite");
    } else {
      for (const Observation& o : std::get<ScanEvent>(event).observations) {
        if (o.z.size() != measurement_dim)
          refuse(fmt::format("measurements of {} values for the observation model, found {}", measurement_dim,
                             o.z.size()));
        for (Eigen::Index k = 0; k < o.z.size(); ++k)
          if (!within(o.z(k), kMaxAbsValue))
            refuse(fmt::format("measurement values within +-{:g}, found {}", kMaxAbsValue, o.z(k)));
      }
    }
  }
}

namespace {

void record_origins(const SlamFilter& filter, RunResult& result) {
  auto add = [&](int id) {
    if (id == kUnknownId || result.landmark_origins.count(id)) return;
    if (const std::optional<LandmarkOrigin> origin = filter.landmark_origin(id)) result.landmark_origins[id] = *origin;
  };
  for (const auto& records : result.associations)
    for (const AssociationRecord& r : records) add(r.landmark_id);
  for (const Landmark& lm : result.map) add(lm.id);
}

}  // namespace

void check_filter_fits(const SlamFilter& filter, const Dataset& dataset) {
  const auto holds = [&](auto kind) {
    using Kind = decltype(kind);
    return std::any_of(dataset.events.begin(), dataset.events.end(),
                       [](const Event& e) { return std::holds_alternative<Kind>(e); });
  };
  if (filter.maps_range_scans() && !holds(RangeScanEvent{}))
    throw InputError(dataset.spec, 0,
                     fmt::format("the {} filter maps with laser scans, and this dataset holds none: expected a laser "
                                 "log (carmen:FILE, or a simulated building)",
                                 filter.name()));
  if (!filter.maps_range_scans() && !holds(ScanEvent{}) && holds(RangeScanEvent{}))
    throw InputError(dataset.spec, 0,
                     fmt::format("this dataset holds laser scans and no landmark observations, which the {} filter "
                                 "maps with: expected --filter scan-matching or grid-fastslam",
                                 filter.name()));
}

RunResult run_filter(SlamFilter& filter, const Dataset& dataset, const RunOptions& options) {
  check_events(dataset);
  check_filter_fits(filter, dataset);
  RunResult result;
  result.filter = filter.name();
  result.dataset = dataset.spec;
  result.history = to_string(options.history);
  if (options.history != History::kFull) filter.forget_smoothed_trajectory();
  if (options.history == History::kFull) {
    result.filtered.reserve(dataset.events.size() + 1);
    result.pose_covariances.reserve(dataset.events.size() + 1);
  }

  Thinning filtered_thinning(options.decimated_samples), std_thinning(options.decimated_samples),
      particle_thinning(options.decimated_samples);
  double last_time = start_time(dataset);
  // Ends the run as diverged at `t` for `why`; false, which the callers return.
  const auto diverged = [&](double t, std::string why) {
    result.partial = true;
    result.diverged_at_s = t;
    result.divergence = std::move(why);
    return false;
  };
  // Returns false, recording nothing, when the estimate is no longer finite (or its covariance says
  // nothing sound): such a filter would go on producing nothing but NaNs, and without known
  // association would start a landmark at every observation (no gate holds a NaN), so the run stops
  // at the last sound estimate instead.
  auto record = [&](double t) {
    Pose2 pose;
    Matrix3 covariance;
    try {
      pose = filter.pose();
      covariance = filter.pose_covariance();
    } catch (const FilterBreakdown& e) {  // an information filter recovers its covariance by factorising
      return diverged(t, e.what());
    }
    if (!pose.allFinite() || !covariance.allFinite()) return diverged(t, "its pose estimate was no longer finite");
    if ((covariance.diagonal().array() < 0.0).any()) return diverged(t, "its pose covariance had a negative variance");
    last_time = t;
    // Several events can share a time (a control then the scan taken there): keep the latest state.
    if (!result.filtered.empty() && result.filtered.back().t == t) {
      result.filtered.back().pose = pose;
      result.pose_covariances.back() = covariance;
      return true;
    }
    if (options.history == History::kNone && result.filtered.size() == 2) {
      result.filtered.pop_back();
      result.pose_covariances.pop_back();
    }
    if (options.history == History::kDecimated && !filtered_thinning.take(t)) return true;
    result.filtered.push_back({t, pose});
    result.pose_covariances.push_back(covariance);
    if (options.history == History::kDecimated) filtered_thinning.limit(result.filtered, &result.pose_covariances);
    return true;
  };

  // Applies one event to the filter; false, the run ending as diverged there, when the filter's
  // numbers break down (its estimate is then as untrustworthy as one that is not finite).
  const auto applied = [&](double t, auto&& apply) {
    try {
      apply();
      return true;
    } catch (const FilterBreakdown& e) {
      return diverged(t, e.what());
    }
  };
  double last_std_time = -INFINITY;
  const auto begin = std::chrono::steady_clock::now();
  record(start_time(dataset));
  std::size_t events_done = 0;
  for (const Event& event : dataset.events) {
    if (options.stop != nullptr && options.stop->load()) {
      result.partial = true;
      break;
    }
    ++events_done;
    if (const auto* control = std::get_if<ControlEvent>(&event)) {
      if (!applied(control->t, [&] { filter.predict(*control); }) || !record(control->t)) break;
      ++result.steps;
    } else if (const auto* range_scan = std::get_if<RangeScanEvent>(&event)) {
      if (!filter.maps_range_scans()) continue;
      try {
        filter.update_range_scan(*range_scan);
      } catch (const GridExtentError& e) {
        throw InputError(dataset.spec, 0,
                         fmt::format("event {} (t = {}): a scan the map cannot take: {}", events_done - 1,
                                     range_scan->t, e.what()));
      }
      if (!record(range_scan->t)) break;
      ++result.scans;
      // A range scan pairs nothing; its empty record keeps one record per scan for the readers.
      if (options.history == History::kFull) {
        result.scan_times.push_back(range_scan->t);
        result.associations.emplace_back();
      }
      for (RunObserver* observer : options.observers)
        observer->on_range_scan(filter, *range_scan, events_done, dataset.events.size());
    } else {
      const auto& scan = std::get<ScanEvent>(event);
      if (filter.maps_range_scans()) continue;
      if (!applied(scan.t, [&] { filter.update(scan); }) || !record(scan.t)) break;
      ++result.scans;
      if (options.history == History::kFull) {
        result.scan_times.push_back(scan.t);
        result.associations.push_back(filter.last_associations());
      }
      result.observations += scan.observations.size();
      if (options.history != History::kNone && scan.t - last_std_time >= options.std_interval_s) {
        last_std_time = scan.t;
        const bool full = options.history == History::kFull;
        if (full || std_thinning.take(scan.t)) {
          for (const Landmark& lm : filter.landmarks())
            result.landmark_std.push_back({scan.t, lm.id, std::sqrt(std::max(0.0, lm.covariance(0, 0))),
                                           std::sqrt(std::max(0.0, lm.covariance(1, 1)))});
          if (!full) std_thinning.limit(result.landmark_std);
        }
        if (full || particle_thinning.take(scan.t)) {
          for (const WeightedPose& p : filter.pose_samples()) result.particles.push_back({scan.t, p});
          if (!full) particle_thinning.limit(result.particles);
        }
      }
      for (RunObserver* observer : options.observers)
        observer->on_scan(filter, scan, events_done, dataset.events.size());
    }
  }
  // Thinned away: the final estimate always goes, unless it is the one that diverged.
  if (result.filtered.back().t != last_time && !result.diverged_at_s) {
    result.filtered.push_back({last_time, filter.pose()});
    result.pose_covariances.push_back(filter.pose_covariance());
  }
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
  // A filter whose numbers broke down may not be able to say more (an information filter cannot
  // recover its map from a matrix it cannot factorise): what it cannot say is left empty.
  const auto unless_broken = [](auto&& query) {
    try {
      return query();
    } catch (const FilterBreakdown&) {
      return decltype(query()){};
    }
  };
  result.map = unless_broken([&] { return filter.landmarks(); });
  result.grid = filter.grid_map();
  if (result.diverged_at_s)
    std::erase_if(result.map, [](const Landmark& lm) { return !lm.position.allFinite() || !lm.covariance.allFinite(); });
  // A particle filter's smoothed trajectory is a whole path: only a run that keeps everything takes it.
  if (options.history == History::kFull) result.trajectory = unless_broken([&] { return filter.smoothed_trajectory(); });
  if (result.diverged_at_s)
    std::erase_if(result.trajectory, [](const StampedPose& p) { return !p.pose.allFinite(); });
  result.smoothed = !result.trajectory.empty();
  if (!result.smoothed) result.trajectory = result.filtered;
  if (options.history == History::kFull) record_origins(filter, result);
  result.statistics = unless_broken([&] { return filter.statistics(); });
  result.information = unless_broken([&] { return filter.information_panels(); });
  result.dead_reckoning = dead_reckoning(dataset, options);
  if (result.partial)
    std::erase_if(result.dead_reckoning, [&](const StampedPose& p) { return p.t > result.filtered.back().t; });
  return result;
}

std::vector<StampedPose> dead_reckoning(const Dataset& dataset) { return dead_reckoning(dataset, RunOptions{}); }

}  // namespace slamkit
