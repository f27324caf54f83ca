// EKF-SLAM and FastSLAM 2.0 on every robot of UTIAS MRCLAM Dataset6 with known identities: each beats
// its own dead reckoning against the motion-capture truth. Skips where the datasets are absent.
#include <gtest/gtest.h>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/io/mrclam.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "test_data.hpp"

using namespace slamkit;

class MrclamSlam : public ::testing::TestWithParam<std::tuple<std::string, int>> {};

TEST_P(MrclamSlam, SlamBeatsDeadReckoningAgainstMotionCapture) {
  const auto dir = test_data::shared_dataset("mrclam/MRCLAM_Dataset6");
  SLAMKIT_REQUIRE_DATASET(dir);
  const auto& [filter_name, robot] = GetParam();
  const Dataset data = read_mrclam(dir.string(), robot);
  FilterConfig config;
  config.filter = parse_filter_kind(filter_name);
  auto filter = make_filter(config, data);
  const Metrics m = evaluate_run(run_filter(*filter, data), data.truth);
  ASSERT_TRUE(m.ate_rmse_m && m.dead_reckoning_ate_rmse_m && m.map_rmse_m);
  EXPECT_LT(*m.ate_rmse_m, *m.dead_reckoning_ate_rmse_m)
      << "SLAM " << *m.ate_rmse_m << " m, dead reckoning " << *m.dead_reckoning_ate_rmse_m << " m";
  EXPECT_EQ(m.landmarks, 15u);
  EXPECT_EQ(m.map_landmarks_paired, 15u);
  EXPECT_LT(*m.map_rmse_m, 2.0);
}

INSTANTIATE_TEST_SUITE_P(Dataset6, MrclamSlam,
                         ::testing::Combine(::testing::Values("ekf", "fastslam2"), ::testing::Range(1, 6)),
                         [](const auto& info) {
                           return std::get<0>(info.param) + "_robot" + std::to_string(std::get<1>(info.param));
                         });
