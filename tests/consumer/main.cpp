// Simulates the built-in world, runs EKF-SLAM on it and checks that SLAM beats dead reckoning: the
// installed headers, library and dependencies work together outside slamkit's build.
#include <cstdio>

#include "slamkit/core/version.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

int main() {
  const slamkit::Scenario scenario = slamkit::scenario("default");
  const slamkit::Dataset data = slamkit::simulate(scenario.world, scenario.config);
  auto filter = slamkit::make_filter(slamkit::FilterConfig{}, data);
  const slamkit::RunResult run = slamkit::run_filter(*filter, data);
  const slamkit::Metrics metrics = slamkit::evaluate_run(run, data.truth);
  std::printf("slamkit %s: ATE RMSE %.3f m, dead reckoning %.3f m\n", slamkit::version().c_str(),
              *metrics.ate_rmse_m, *metrics.dead_reckoning_ate_rmse_m);
  return *metrics.ate_rmse_m < *metrics.dead_reckoning_ate_rmse_m ? 0 : 1;
}
