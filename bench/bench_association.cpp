// Cost of one scan's data association against the size of the map. The vehicle sees the same
// neighbourhood whatever the map's size, so the cost must follow the landmarks near the vehicle, not
// the whole map: the candidate search goes through a grid, never over every landmark.
#include <benchmark/benchmark.h>

#include <random>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"

namespace {

using namespace slamkit;

/// Landmarks on a jittered lattice of 12 m pitch around the origin (about 20 within 30 m of any
/// point), `n` of them, and a scan of what the vehicle at the origin sees.
struct AssociationScene {
  std::unique_ptr<EkfSlam> ekf;
  ScanEvent scan;
};

AssociationScene make_association_scene(int n, AssociationMethod method) {
  EkfSlamOptions options;
  options.association.method = method;
  options.sensor = SensorLimits{30.0, 2.0 * kPi};
  options.initial_covariance = Eigen::Vector3d(0.05, 0.05, 0.001).asDiagonal();
  const RangeBearingModel model;
  auto map = std::make_unique<JointGaussian>(std::make_shared<AckermannModel>(), std::make_shared<RangeBearingModel>(),
                                             Pose2::Zero(), options.initial_covariance);
  std::vector<int> ids;
  AssociationScene scene;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> jitter(-3.0, 3.0);
  int added = 0;
  // Fill rings of lattice cells outwards from the origin so the neighbourhood is the same for all n.
  for (int ring = 0; added < n; ++ring) {
    for (int i = -ring; i <= ring && added < n; ++i)
      for (int j = -ring; j <= ring && added < n; ++j) {
        if (std::max(std::abs(i), std::abs(j)) != ring) continue;
        const Vector2 p(12.0 * i + jitter(rng), 12.0 * j + jitter(rng));
        if (p.norm() < 2.0) continue;
        map->add_landmark(model.predict(Pose2::Zero(), p));
        ids.push_back(added++);
        if (p.norm() < 28.0) scene.scan.observations.push_back({model.predict(Pose2::Zero(), p), kUnknownId});
      }
  }
  scene.ekf = std::make_unique<EkfSlam>(std::move(map), ids, options);
  return scene;
}

void run(benchmark::State& state, AssociationMethod method) {
  AssociationScene scene = make_association_scene(static_cast<int>(state.range(0)), method);
  std::size_t paired = 0;
  for (auto _ : state) {
    const auto& pairings = scene.ekf->associate_scan(scene.scan);
    paired = 0;
    for (const auto& p : pairings) paired += p.decision == AssociationDecision::kUpdate;
    benchmark::DoNotOptimize(paired);
  }
  state.counters["observations"] = static_cast<double>(scene.scan.observations.size());
  state.counters["paired"] = static_cast<double>(paired);
  state.SetComplexityN(state.range(0));
}

void BM_AssociationNearestNeighbour(benchmark::State& state) { run(state, AssociationMethod::kNearestNeighbour); }
void BM_AssociationJcbb(benchmark::State& state) { run(state, AssociationMethod::kJcbb); }

BENCHMARK(BM_AssociationNearestNeighbour)->Arg(100)->Arg(300)->Arg(1000)->Arg(3000)->Arg(5000)->Complexity();
BENCHMARK(BM_AssociationJcbb)->Arg(100)->Arg(300)->Arg(1000)->Arg(3000)->Arg(5000)->Complexity();

}  // namespace
