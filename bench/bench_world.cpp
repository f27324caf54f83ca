// Generating a world (make-world) as the landmark count outgrows the band: the default 120 x 80 m
// route's band holds about 900 landmarks at the default 3 m spacing, so past that the generator
// shrinks the spacing step by step. Time per landmark should stay about flat (it grew linearly in
// the count, the whole generation quadratically, while the spacing test's grid kept its first cells).
#include <benchmark/benchmark.h>

#include "slamkit/sim/world.hpp"

namespace {

void BM_GenerateWorld(benchmark::State& state) {
  slamkit::WorldGenOptions options;
  options.landmarks = static_cast<int>(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(slamkit::generate_world(options));
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

BENCHMARK(BM_GenerateWorld)->RangeMultiplier(10)->Range(1'000, 1'000'000)->Unit(benchmark::kMillisecond);

}  // namespace
