// The memory estimate a run is checked against before its filter is built: what drives it (particles
// times landmarks for FastSLAM, the square of the map for the EKF, the history kept), the map size it
// assumes, and a refusal that names the setting.
#include "slamkit/pipeline/run_memory.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <variant>

#include "slamkit/core/run_result.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/filters/landmark_tree.hpp"
#include "sim_test_support.hpp"

namespace slamkit {
namespace {

using test_sim::one_lap;

RunOptions with_history(History history) {
  RunOptions options;
  options.history = history;
  return options;
}

TEST(RunMemory, FastSlamGrowsWithParticlesTimesLandmarksAndTheEkfWithTheSquareOfTheMap) {
  FilterConfig fastslam;
  fastslam.filter = FilterKind::kFastSlam2;
  const RunOptions none = with_history(History::kNone);
  const RunMemoryEstimate base = estimate_run_memory(fastslam, one_lap(), none);
  EXPECT_EQ(base.landmarks, 100u);  // the default world's, by the ids the log carries
  EXPECT_EQ(base.history_bytes, 0.0);
  fastslam.particles *= 10;
  EXPECT_DOUBLE_EQ(estimate_run_memory(fastslam, one_lap(), none).filter_bytes, 10 * base.filter_bytes);
  EXPECT_GT(FastSlam::memory_estimate(100, 2000) - FastSlam::memory_estimate(100, 1000),
            100 * 1000 * sizeof(LandmarkGaussian) / 4);

  // Without ids the map size comes from the truth; the EKF's covariance from its square.
  Dataset without_ids = one_lap();
  for (Event& e : without_ids.events)
    if (auto* scan = std::get_if<ScanEvent>(&e))
      for (Observation& o : scan->observations) o.id = kUnknownId;
  without_ids.truth.landmarks.resize(1000);
  const RunMemoryEstimate ekf = estimate_run_memory(FilterConfig{}, without_ids, none);
  EXPECT_EQ(ekf.landmarks, 1000u);
  EXPECT_DOUBLE_EQ(ekf.filter_bytes, 2003.0 * 2003.0 * sizeof(double));
}

TEST(RunMemory, TheHistoryCountsEveryParticleOnceASecondUnlessThinned) {
  FilterConfig fastslam;
  fastslam.filter = FilterKind::kFastSlam1;
  fastslam.particles = 1000;
  const double full = estimate_run_memory(fastslam, one_lap(), with_history(History::kFull)).history_bytes;
  RunOptions decimated = with_history(History::kDecimated);
  decimated.decimated_samples = 10;
  const double thinned = estimate_run_memory(fastslam, one_lap(), decimated).history_bytes;
  // A lap of the default world lasts about 120 s: 120 samples of 1,000 particles at least.
  EXPECT_GT(full, 100.0 * 1000 * sizeof(ParticleSample));
  EXPECT_LT(thinned, full / 5);
}

// An EKF over a million landmarks would need 32 TB for its covariance: refused before it is built,
// where it used to grow until std::bad_alloc.
TEST(RunMemory, ARunNoMachineCanHoldIsRefusedNamingWhatDrivesIt) {
  Dataset huge = one_lap();
  for (Event& e : huge.events)
    if (auto* scan = std::get_if<ScanEvent>(&e))
      for (Observation& o : scan->observations) o.id = kUnknownId;
  huge.truth.landmarks.resize(1'000'000);
  try {
    require_run_memory(FilterConfig{}, huge, RunOptions{});
    FAIL() << "expected std::length_error";
  } catch (const std::length_error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("ekf with a map of about 1000000 landmarks"), std::string::npos) << message;
    EXPECT_NE(message.find("--history full"), std::string::npos) << message;
    EXPECT_NE(message.find("GiB of memory; this "), std::string::npos) << message;
  }
  EXPECT_NO_THROW(require_run_memory(FilterConfig{}, one_lap(), RunOptions{}));
}

}  // namespace
}  // namespace slamkit
