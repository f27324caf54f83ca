#pragma once
// A motion model that passes every call to another, for tests that change one of its answers part-way
// through a run (a model that turns NaN, or whose noise turns negative) and keep the rest.
#include <memory>
#include <string>
#include <utility>

#include "slamkit/models/motion_model.hpp"

namespace slamkit::test_data {

class WrappedMotionModel : public MotionModel {
 public:
  explicit WrappedMotionModel(std::shared_ptr<const MotionModel> model) : model_(std::move(model)) {}
  std::string name() const override { return model_->name(); }
  int control_dim() const override { return model_->control_dim(); }
  Pose2 predict(const Pose2& x, const Control& u, double dt) const override { return model_->predict(x, u, dt); }
  Matrix3 jacobian_state(const Pose2& x, const Control& u, double dt) const override {
    return model_->jacobian_state(x, u, dt);
  }
  ControlJacobian jacobian_control(const Pose2& x, const Control& u, double dt) const override {
    return model_->jacobian_control(x, u, dt);
  }
  ControlCovariance control_noise(const Control& u, double dt) const override { return model_->control_noise(u, dt); }

 protected:
  std::shared_ptr<const MotionModel> model_;
};

}  // namespace slamkit::test_data
