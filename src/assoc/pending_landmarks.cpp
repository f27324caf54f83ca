#include "slamkit/assoc/pending_landmarks.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "slamkit/core/chi_square.hpp"

namespace slamkit {

PendingLandmarks::PendingLandmarks(const AssociationConfig& config, const SensorLimits& sensor,
                                   const ObservationModel& model)
    : clutter_density_(clutter_density(config, sensor, model)),
      view_area_(sensor.max_range * std::min(sensor.fov, 2.0 * std::numbers::pi)),
      log_miss_(std::log1p(-config.detection_probability)),
      log_detection_(std::log(config.detection_probability)),
      accept_d2_(eval::chi_square_quantile(config.accept_probability, 2.0)),
      window_s_(config.relocalise_window_s) {}

void PendingLandmarks::begin_scan(double t, const Pose2& x) {
  now_ = t;
  pose_ = x;
  std::erase_if(hypotheses_, [&](const Hypothesis& h) { return h.last_detected < t - window_s_; });
  for (Hypothesis& h : hypotheses_) h.detected_now = false;
}

int PendingLandmarks::offer(const Measurement& z, const ObservationModel& model, std::size_t landmarks_started,
                            std::size_t scans) {
  if (!active()) return 1;
  if (!model.invertible() || model.dim() != 2)
    throw std::logic_error("pending landmarks place hypotheses by inverting a range-bearing measurement");
  const Matrix2 r = model.noise();
  PoseJacobian pose_rows;
  LandmarkJacobian landmark_rows;
  // The nearest hypothesis inside the acceptance gate, by Mahalanobis distance.
  Hypothesis* nearest = nullptr;
  double nearest_d2 = accept_d2_, nearest_log_likelihood = 0.0;
  for (Hypothesis& h : hypotheses_) {
    if (h.detected_now) continue;
    model.jacobians(pose_, h.position, pose_rows, landmark_rows);
    const Matrix2 hm = landmark_rows;
    const Matrix2 s = hm * h.covariance * hm.transpose() + r;
    const Eigen::LLT<Matrix2> llt(0.5 * (s + s.transpose()));
    if (llt.info() != Eigen::Success) continue;
    const Vector2 nu = model.residual(z, model.predict(pose_, h.position));
    const double d2 = nu.dot(llt.solve(nu));
    if (!(d2 < nearest_d2)) continue;
    nearest = &h;
    nearest_d2 = d2;
    const double log_det = 2.0 * std::log(llt.matrixL().determinant());
    nearest_log_likelihood = -0.5 * d2 - std::log(2.0 * std::numbers::pi) - 0.5 * log_det;
  }
  const InitialLandmark placed = *inverted_landmark(model, pose_, z);
  const Vector2& position = placed.mean;
  const Matrix2& covariance = placed.covariance;
  if (nearest == nullptr) {
    const double birth_rate = (static_cast<double>(landmarks_started) + 1.0) / (static_cast<double>(scans) + 1.0);
    const double log_odds = std::log(birth_rate / view_area_) - std::log(clutter_density_);
    if (log_odds > 0.0) return 1;
    hypotheses_.push_back({position, 0.5 * (covariance + covariance.transpose()), log_odds, 1, now_, true});
    return 0;
  }
  nearest->log_odds += log_detection_ + nearest_log_likelihood - std::log(clutter_density_);
  ++nearest->detections;
  if (nearest->log_odds > 0.0) {
    const int detections = nearest->detections;
    hypotheses_.erase(hypotheses_.begin() + (nearest - hypotheses_.data()));
    return detections;
  }
  nearest->position = position;
  nearest->covariance = 0.5 * (covariance + covariance.transpose());
  nearest->last_detected = now_;
  nearest->detected_now = true;
  return 0;
}

void PendingLandmarks::end_scan(const ObservationModel& model, const SensorView& detection_view) {
  for (Hypothesis& h : hypotheses_)
    if (!h.detected_now && detection_view.contains(model, pose_, h.position)) h.log_odds += log_miss_;
}

}  // namespace slamkit
