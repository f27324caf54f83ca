// Runs that end because the filter can no longer be trusted, though its numbers are finite: its
// numbers broke down (FilterBreakdown: an information matrix too ill-conditioned to factorise, as the
// fuzzer found for the information filters), or its pose covariance has a negative variance. The run
// ends as diverged at that event, keeping what ran and saying why, as a run whose estimate stops
// being finite does; no exception leaves the runner, and the run folder can be written.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "slamkit/io/run_io.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"
#include "wrapped_motion_model.hpp"

namespace slamkit {
namespace {

Dataset one_lap() {
  SimulatorConfig sim;
  sim.loops = 1;
  return simulate(default_world(), sim);
}

void expect_diverged_at_control(const RunResult& run, const Dataset& data, std::size_t control,
                                const std::string& because) {
  ASSERT_TRUE(run.diverged_at_s.has_value());
  EXPECT_TRUE(run.partial);
  EXPECT_EQ(run.divergence, because);
  std::size_t controls = 0;
  double t = 0.0;
  for (const Event& e : data.events)
    if (const auto* c = std::get_if<ControlEvent>(&e); c != nullptr && ++controls == control) t = c->t;
  EXPECT_EQ(*run.diverged_at_s, t);
  ASSERT_FALSE(run.filtered.empty());
  EXPECT_LT(run.filtered.back().t, *run.diverged_at_s);
  for (std::size_t i = 0; i < run.filtered.size(); ++i)
    ASSERT_GE(run.pose_covariances[i].diagonal().minCoeff(), 0.0) << "t " << run.filtered[i].t;

  const test_data::ScratchDir dir;
  write_run(dir.file("run"), run);
  const RunResult back = read_run(dir.file("run"));
  EXPECT_EQ(back.diverged_at_s, run.diverged_at_s);
  EXPECT_EQ(back.divergence, run.divergence);
}

// The dataset's motion model until its `healthy`-th noise query, -1 of control noise from then on.
class NegativeNoiseAfter final : public test_data::WrappedMotionModel {
 public:
  NegativeNoiseAfter(std::shared_ptr<const MotionModel> model, std::size_t healthy)
      : WrappedMotionModel(std::move(model)), left_(healthy) {}
  ControlCovariance control_noise(const Control& u, double dt) const override {
    if (left_ == 0) return -ControlCovariance::Identity(u.size(), u.size());
    --left_;
    return model_->control_noise(u, dt);
  }

 private:
  mutable std::size_t left_;
};

class NegativeVariance : public ::testing::TestWithParam<FilterKind> {};

TEST_P(NegativeVariance, EndsTheRunAsDivergedAtTheFirstNegativeVariance) {
  const Dataset data = one_lap();
  Dataset broken = data;
  broken.motion = std::make_shared<NegativeNoiseAfter>(data.motion, 1000);
  FilterConfig config;
  config.filter = GetParam();
  auto filter = make_filter(config, broken);
  RunResult run;
  try {
    run = run_filter(*filter, data);
  } catch (const std::exception& e) {
    FAIL() << "the runner threw: " << e.what();
  }
  expect_diverged_at_control(run, data, 1001, "its pose covariance had a negative variance");
}

INSTANTIATE_TEST_SUITE_P(Filters, NegativeVariance,
                         ::testing::Values(FilterKind::kEkf, FilterKind::kEif, FilterKind::kSeif, FilterKind::kEseif,
                                           FilterKind::kTjtf),
                         [](const auto& info) { return to_string(info.param); });

// A filter that breaks down at its `healthy`-th prediction, and from then on cannot say what its map
// is; otherwise the EIF it wraps.
class BreaksDownAfter final : public SlamFilter {
 public:
  BreaksDownAfter(std::unique_ptr<SlamFilter> filter, std::size_t healthy)
      : filter_(std::move(filter)), left_(healthy) {}
  std::string name() const override { return filter_->name(); }
  void predict(const ControlEvent& control) override {
    if (left_ == 0) {
      broken_ = true;
      throw FilterBreakdown("the information matrix is not positive definite");
    }
    --left_;
    filter_->predict(control);
  }
  void update(const ScanEvent& scan) override { filter_->update(scan); }
  Pose2 pose() const override { return filter_->pose(); }
  Matrix3 pose_covariance() const override { return filter_->pose_covariance(); }
  std::size_t num_landmarks() const override { return filter_->num_landmarks(); }
  std::vector<Landmark> landmarks() const override {
    if (broken_) throw FilterBreakdown("the information matrix is not positive definite");
    return filter_->landmarks();
  }
  const std::vector<AssociationRecord>& last_associations() const override { return filter_->last_associations(); }

 private:
  std::unique_ptr<SlamFilter> filter_;
  std::size_t left_;
  bool broken_ = false;
};

TEST(FilterBreakdown, EndsTheRunAsDivergedWithWhatBrokeAndWithoutTheMapItCannotRecover) {
  const Dataset data = one_lap();
  FilterConfig config;
  config.filter = FilterKind::kEif;
  BreaksDownAfter filter(make_filter(config, data), 1000);
  RunResult run;
  try {
    run = run_filter(filter, data);
  } catch (const std::exception& e) {
    FAIL() << "the runner threw: " << e.what();
  }
  expect_diverged_at_control(run, data, 1001, "the information matrix is not positive definite");
  EXPECT_EQ(run.steps, 1000u);
  EXPECT_TRUE(run.map.empty());
}

}  // namespace
}  // namespace slamkit
