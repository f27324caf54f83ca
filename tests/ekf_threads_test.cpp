// The EKF's covariance passes shared out over threads give the same estimate, bit for bit, as one
// thread: every covariance entry is computed the same way whichever thread computes it.
#include <gtest/gtest.h>

#include <memory>

#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

using namespace slamkit;

namespace {

/// A world whose map passes 300 landmarks (state dimension 600) after about 880 of its scans (349 at
/// 1000): from there a scan's downdate is large enough to be shared out.
const Dataset& busy_world() {
  static const Dataset data = [] {
    WorldGenOptions world;
    world.landmarks = 600;
    world.width = 400.0;
    world.height = 200.0;
    SimulatorConfig sim;
    sim.loops = 1;
    return simulate(generate_world(world), sim);
  }();
  return data;
}

/// The estimator after the first `scans` scans of busy_world() on `threads` threads.
std::unique_ptr<SlamFilter> run(EkfVariant variant, unsigned threads, std::size_t scans) {
  FilterConfig config;
  config.ekf_variant = variant;
  config.threads = threads;
  std::unique_ptr<SlamFilter> filter = make_filter(config, busy_world());
  std::size_t seen = 0;
  for (const Event& e : busy_world().events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      filter->predict(*c);
    } else {
      filter->update(std::get<ScanEvent>(e));
      if (++seen == scans) break;
    }
  }
  return filter;
}

}  // namespace

TEST(EkfThreads, SameEstimateBitForBitOnOneAndTwoThreads) {
  for (const EkfVariant variant : {EkfVariant::kFull, EkfVariant::kCompressed}) {
    const auto one = run(variant, 1, 1000);
    const auto two = run(variant, 2, 1000);
    const EkfEstimator& a = dynamic_cast<const EkfSlam&>(*one).estimator();
    const EkfEstimator& b = dynamic_cast<const EkfSlam&>(*two).estimator();
    ASSERT_EQ(a.threads(), 1U);
    ASSERT_EQ(b.threads(), 2U);
    ASSERT_GT(a.num_landmarks(), 300U) << "the map must be large enough for the work to be shared out";
    ASSERT_EQ(a.state_dim(), b.state_dim());
    EXPECT_TRUE(a.state() == b.state()) << to_string(variant);
    EXPECT_TRUE(a.covariance() == b.covariance()) << to_string(variant);
  }
}
