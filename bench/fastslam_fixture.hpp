#pragma once
// The FastSLAM benchmarks' scene: landmarks scattered uniformly at a density that puts ~15 of them
// within the sensor's 30 m of the vehicle, which stands at the centre (speed 0, so the scene does
// not drift away while a benchmark repeats). Maps are given to every particle with
// set_initial_map, so a map of 20000 landmarks costs what it would after a long run, without the run.
#include <cmath>
#include <random>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/fastslam.hpp"

namespace slamkit::bench {

constexpr double kRange = 30.0;
constexpr double kAreaPerLandmark = kPi * kRange * kRange / 15.0;  // ~15 landmarks in view

struct Scene {
  std::vector<Landmark> map;
  std::vector<ScanEvent> scans;  // noisy scans from the origin, cycled through
};

inline Scene make_scene(int landmarks, bool ids) {
  Scene scene;
  std::mt19937_64 rng(11);
  const double half = 0.5 * std::sqrt(kAreaPerLandmark * landmarks);
  std::uniform_real_distribution<double> coord(-half, half);
  for (int i = 0; i < landmarks; ++i)
    scene.map.push_back({i, Vector2(coord(rng), coord(rng)), Matrix2::Identity() * 0.01});
  const RangeBearingModel sensor;
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int s = 0; s < 16; ++s) {
    ScanEvent scan{0.2 * (s + 1), {}};
    for (const Landmark& lm : scene.map) {
      if (lm.position.norm() > kRange) continue;
      const Vector2 z = sensor.predict(Pose2::Zero(), lm.position) +
                        Vector2(0.1 * normal(rng), deg2rad(1.0) * normal(rng));
      scan.observations.push_back({z, ids ? lm.id : kUnknownId});
    }
    scene.scans.push_back(std::move(scan));
  }
  return scene;
}

inline FastSlamConfig make_config(int version, int particles, AssociationMethod method, unsigned threads) {
  FastSlamConfig c;
  c.version = version;
  c.particles = particles;
  c.association.method = method;
  c.threads = threads;
  c.sensor = SensorLimits{kRange, 2.0 * kPi};
  return c;
}

/// One step: 8 predictions (40 Hz controls, 5 Hz scans) and the scan's update.
inline void step(FastSlam& filter, const Scene& scene, std::size_t& k) {
  Control u(2);
  u << 0.0, 0.0;
  const ScanEvent& scan = scene.scans[k++ % scene.scans.size()];
  for (int i = 0; i < 8; ++i) filter.predict(ControlEvent{scan.t, 0.025, u});
  filter.update(scan);
}

}  // namespace slamkit::bench
