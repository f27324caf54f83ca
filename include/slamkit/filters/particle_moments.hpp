#pragma once
// The Gaussian a weighted particle cloud stands for, as the particle filters report it: the weighted
// mean pose (heading by its circular mean) and the mixture's covariance (the particles' spread
// plus the mean of the covariances they carry).
#include <cmath>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

/// `pose(i)` gives particle i's pose; `weights` are normalised.
template <class PoseOf>
Pose2 weighted_mean_pose(const std::vector<double>& weights, PoseOf pose) {
  Pose2 mean = Pose2::Zero();
  double sin_sum = 0.0, cos_sum = 0.0;
  for (std::size_t i = 0; i < weights.size(); ++i) {
    const Pose2& x = pose(i);
    mean.head<2>() += weights[i] * x.head<2>();
    sin_sum += weights[i] * std::sin(x[2]);
    cos_sum += weights[i] * std::cos(x[2]);
  }
  mean[2] = std::atan2(sin_sum, cos_sum);
  return mean;
}

/// The mixture's covariance about `mean`; `covariance(i)` gives the covariance particle i carries.
template <class PoseOf, class CovarianceOf>
Matrix3 mixture_covariance(const std::vector<double>& weights, const Pose2& mean, PoseOf pose,
                           CovarianceOf covariance) {
  Matrix3 cov = Matrix3::Zero();
  for (std::size_t i = 0; i < weights.size(); ++i) {
    Eigen::Vector3d d = pose(i) - mean;
    d[2] = wrap_angle(d[2]);
    cov += weights[i] * (d * d.transpose() + covariance(i));
  }
  return cov;
}

}  // namespace slamkit
