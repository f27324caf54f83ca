#pragma once
// The ACFR utility car of the Victoria Park dataset (Guivant and Nebot, IEEE T-RA 2001): Ackermann
// kinematics about the rear axle, driven by the speed of an encoder on a rear wheel and the front
// steering angle, and carried forward to the laser, whose pose is the state.
//
// The encoder wheel is H off the centreline, so on a turn it runs faster or slower than the axle
// centre: v_c = v_e / (1 - tan(alpha) H / L). The laser sits a ahead of the rear axle and b to the
// side, so it sweeps sideways as the car turns. With w = v_c tan(alpha) / L, over dt:
//   x'   = x + dt (v_c cos(phi) - w (a sin(phi) + b cos(phi)))
//   y'   = y + dt (v_c sin(phi) + w (a cos(phi) - b sin(phi)))
//   phi' = phi + dt w
// Control vector: (v_e [m/s], alpha [rad]).
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/models/motion_model.hpp"

namespace slamkit {

class AcfrCarModel final : public MotionModel {
 public:
  /// Geometry from ACFR's info.txt (see the dataset's car drawing); noise from UFastSLAM's tuning.
  struct Params {
    double wheelbase = 2.83;            // L [m], front to rear axle
    double encoder_offset = 0.76;       // H [m], centreline to the encoder wheel (rear, laser side)
    double laser_forward = 3.78;        // a [m], laser ahead of the rear axle
    double laser_left = 0.5;            // b [m], laser beside the centreline
    double sigma_speed = 2.0;           // m/s
    double sigma_steer = deg2rad(6.0);  // rad
  };
  AcfrCarModel() = default;
  /// Throws std::invalid_argument for a non-positive wheelbase or a negative noise.
  explicit AcfrCarModel(const Params& params);

  std::string name() const override { return "acfr-car"; }
  int control_dim() const override { return 2; }
  Pose2 predict(const Pose2& x, const Control& u, double dt) const override;
  Matrix3 jacobian_state(const Pose2& x, const Control& u, double dt) const override;
  ControlJacobian jacobian_control(const Pose2& x, const Control& u, double dt) const override;
  ControlCovariance control_noise(const Control& u, double dt) const override;

  /// The speed of the rear-axle centre for encoder speed v_e at steering alpha (the H/L correction).
  double axle_speed(double encoder_speed, double steer) const;

  const Params& params() const { return p_; }

 private:
  Params p_;
};

}  // namespace slamkit
