#include "slamkit/pipeline/runner.hpp"

#include <chrono>
#include <cmath>

#include "slamkit/models/motion_model.hpp"

namespace slamkit {

namespace {

double event_time(const Event& e) {
  return std::visit([](const auto& ev) { return ev.t; }, e);
}

/// Time of the pose the stream starts from: just before the first control is applied.
double start_time(const Dataset& dataset) {
  for (const Event& e : dataset.events)
    if (const auto* c = std::get_if<ControlEvent>(&e)) return c->t - c->dt;
  return dataset.events.empty() ? 0.0 : event_time(dataset.events.front());
}

}  // namespace

RunResult run_filter(SlamFilter& filter, const Dataset& dataset, const RunOptions& options) {
  RunResult result;
  result.filter = filter.name();
  result.dataset = dataset.spec;
  result.filtered.reserve(dataset.events.size() + 1);
  result.pose_covariances.reserve(dataset.events.size() + 1);

  auto record = [&](double t) {
    // Several events can share a time (a control then the scan taken there): keep the latest state.
    if (!result.filtered.empty() && result.filtered.back().t == t) {
      result.filtered.back().pose = filter.pose();
      result.pose_covariances.back() = filter.pose_covariance();
      return;
    }
    result.filtered.push_back({t, filter.pose()});
    result.pose_covariances.push_back(filter.pose_covariance());
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
      filter.predict(*control);
      ++result.steps;
      record(control->t);
    } else {
      const auto& scan = std::get<ScanEvent>(event);
      filter.update(scan);
      ++result.scans;
      result.scan_times.push_back(scan.t);
      result.associations.push_back(filter.last_associations());
      result.observations += scan.observations.size();
      record(scan.t);
      if (scan.t - last_std_time >= options.std_interval_s) {
        last_std_time = scan.t;
        for (const Landmark& lm : filter.landmarks())
          result.landmark_std.push_back({scan.t, lm.id, std::sqrt(std::max(0.0, lm.covariance(0, 0))),
                                         std::sqrt(std::max(0.0, lm.covariance(1, 1)))});
        for (const WeightedPose& p : filter.pose_samples()) result.particles.push_back({scan.t, p});
      }
      for (RunObserver* observer : options.observers)
        observer->on_scan(filter, scan, events_done, dataset.events.size());
    }
  }
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
  result.map = filter.landmarks();
  result.trajectory = filter.smoothed_trajectory();
  result.smoothed = !result.trajectory.empty();
  if (!result.smoothed) result.trajectory = result.filtered;
  result.statistics = filter.statistics();
  result.dead_reckoning = dead_reckoning(dataset);
  if (result.partial)
    std::erase_if(result.dead_reckoning, [&](const StampedPose& p) { return p.t > result.filtered.back().t; });
  return result;
}

std::vector<StampedPose> dead_reckoning(const Dataset& dataset) {
  std::vector<StampedPose> out;
  Pose2 pose = dataset.initial_pose;
  out.push_back({start_time(dataset), pose});
  for (const Event& event : dataset.events) {
    if (const auto* control = std::get_if<ControlEvent>(&event)) {
      pose = dataset.motion->predict(pose, control->u, control->dt);
      out.push_back({control->t, pose});
    }
  }
  return out;
}

}  // namespace slamkit
