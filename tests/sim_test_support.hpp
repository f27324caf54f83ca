#pragma once
// What the simulator tests share: a dataset's scans and controls, the sensor's sweeps, EkfSlam's
// settings for a dataset, and a fingerprint of everything a run produces, for "bit for bit"
// comparisons.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <variant>
#include <vector>

#include "slamkit/core/dataset.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/sim/simulator.hpp"

namespace slamkit::test_sim {

/// EkfSlam's settings for a run on `d`: its start and sensor, the EKF variant, one thread.
inline EkfSlamOptions ekf_options_for(const Dataset& d, EkfVariant variant) {
  EkfSlamOptions options;
  options.initial_pose = d.initial_pose;
  options.sensor = d.sensor;
  options.variant = variant;
  options.threads = 1;
  return options;
}

/// FastSLAM's settings for a run on `d`: its start and sensor, the version and particles, one thread.
inline FastSlamConfig fastslam_config_for(const Dataset& d, int version, int particles) {
  FastSlamConfig c;
  c.version = version;
  c.particles = particles;
  c.initial_pose = d.initial_pose;
  c.sensor = d.sensor;
  c.threads = 1;
  return c;
}

inline std::vector<ScanEvent> scans_of(const Dataset& d) {
  std::vector<ScanEvent> out;
  for (const Event& e : d.events)
    if (const auto* s = std::get_if<ScanEvent>(&e)) out.push_back(*s);
  return out;
}

/// The dataset cut at time `t_end`: its events, truth poses and the identities of the scans kept.
inline Dataset truncated(Dataset d, double t_end) {
  std::size_t scans = 0;
  for (const Event& e : d.events)
    if (event_time(e) <= t_end && std::holds_alternative<ScanEvent>(e)) ++scans;
  std::erase_if(d.events, [&](const Event& e) { return event_time(e) > t_end; });
  std::erase_if(d.truth.poses, [&](const StampedPose& p) { return p.t > t_end; });
  if (d.truth.observation_ids.size() > scans) d.truth.observation_ids.resize(scans);
  return d;
}

inline std::vector<ControlEvent> controls_of(const Dataset& d) {
  std::vector<ControlEvent> out;
  for (const Event& e : d.events)
    if (const auto* c = std::get_if<ControlEvent>(&e)) out.push_back(*c);
  return out;
}

// One lap of the default scenario, simulated once per test binary.
inline const Dataset& one_lap() {
  static const Dataset data = [] {
    Scenario s = scenario("default");
    s.config.loops = 1;
    return simulate(s.world, s.config);
  }();
  return data;
}

// Sweeps the sensor made, with or without a ScanEvent: one every observation period.
inline std::size_t sweeps_of(const Dataset& d, const SimulatorConfig& c) {
  return controls_of(d).size() /
         static_cast<std::size_t>(std::lround(c.observation_period / c.control_period));
}

// FNV-1a over the bit patterns of everything a run produces.
class Fingerprint {
 public:
  void add(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) {
      hash_ ^= (v >> (8 * i)) & 0xffU;
      hash_ *= 0x100000001b3ULL;
    }
  }
  void add(double d) {
    std::uint64_t v = 0;
    std::memcpy(&v, &d, sizeof v);
    add(v);
  }
  void add(int i) { add(static_cast<std::uint64_t>(static_cast<std::int64_t>(i))); }
  std::uint64_t value() const { return hash_; }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

inline std::uint64_t fingerprint(const Dataset& d) {
  Fingerprint f;
  for (const Event& e : d.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      f.add(c->t);
      f.add(c->dt);
      f.add(c->u[0]);
      f.add(c->u[1]);
    } else {
      const auto& s = std::get<ScanEvent>(e);
      f.add(s.t);
      for (const Observation& o : s.observations) {
        f.add(o.id);
        f.add(o.z[0]);
        f.add(o.z[1]);
      }
    }
  }
  for (const StampedPose& p : d.truth.poses) {
    f.add(p.t);
    f.add(p.pose.x());
    f.add(p.pose.y());
    f.add(p.pose.z());
  }
  for (const std::vector<int>& ids : d.truth.observation_ids)
    for (const int id : ids) f.add(id);
  return f.value();
}

}  // namespace slamkit::test_sim
