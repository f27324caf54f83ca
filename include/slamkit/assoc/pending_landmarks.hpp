#pragma once
// New landmarks where detections may be false. An observation that no landmark explains is either a
// landmark seen for the first time or a false detection, and with clutter the second is the likelier:
// at one false detection per scan and a new landmark every few dozen scans, nineteen of twenty are
// false. Started as landmarks, they enter the joint Gaussian (a state augmentation each, until map
// management removes them), and the real observation that falls near one is paired with it. So such an
// observation starts a pending landmark instead: a hypothesis kept outside the map with its existence
// probability, which enters the map when it is more probably real than not.
//
// The probability is Bayes' rule over the detections (after the random-finite-set filters' Bernoulli
// component, with the detections paired by the nearest neighbour):
//  - at the start the odds are beta / kappa: the rate of first detections of landmarks over the rate of
//    false detections, both per unit of measurement space (range x bearing). kappa is the configured
//    clutter (AssociationConfig::clutter_per_scan); beta is the map's own rate so far, the landmarks
//    started per scan plus one (the posterior mean of a Poisson rate under a flat prior) over the
//    view. Without clutter the odds are infinite and every landmark starts at once.
//  - each later detection inside the acceptance gate multiplies them by P_D N(nu; 0, S) / kappa, the
//    likelihood of the detection if the landmark is real over its likelihood as clutter;
//  - each scan in which the hypothesis is predicted well inside the view and not detected multiplies
//    them by 1 - P_D.
// A hypothesis not detected for the relocalisation window is dropped. A landmark started from a
// hypothesis starts from the observation that decided it, and counts all its detections.
#include <cstddef>
#include <vector>

#include "slamkit/assoc/association.hpp"
#include "slamkit/assoc/sensor_view.hpp"

namespace slamkit {

class PendingLandmarks {
 public:
  /// Reads clutter_per_scan, detection_probability, accept_probability and relocalise_window_s.
  PendingLandmarks(const AssociationConfig& config, const SensorLimits& sensor, const ObservationModel& model);

  /// Whether observations wait here at all: only where clutter is expected.
  bool active() const { return clutter_density_ > 0.0; }

  /// Starts the scan's offers at time t from pose x, the estimate after the scan's updates; forgets
  /// the hypotheses not detected for the window.
  void begin_scan(double t, const Pose2& x);

  /// An observation z that no landmark explains, from the pose of begin_scan. Returns the number of
  /// detections of the landmark it starts now (1 for a first sighting that is more probably real
  /// than not), or 0 when it waits as a hypothesis. `landmarks_started` and `scans` give the map's rate of
  /// new landmarks so far.
  int offer(const Measurement& z, const ObservationModel& model, std::size_t landmarks_started, std::size_t scans);

  /// Ends the scan: the hypotheses predicted inside `detection_view` and not detected lose evidence.
  void end_scan(const ObservationModel& model, const SensorView& detection_view);

  std::size_t size() const { return hypotheses_.size(); }

 private:
  struct Hypothesis {
    Vector2 position;  // in the map frame, from the pose estimate when last detected
    // Of position, the measurement's uncertainty only: the hypothesis is detected again from a pose
    // whose error is nearly the same as the one that placed it (scans are fractions of a second
    // apart, and a detection re-places it), so the pose's uncertainty cancels out of the innovation.
    Matrix2 covariance;
    double log_odds;     // of being a landmark rather than false detections
    int detections;
    double last_detected;
    bool detected_now;
  };

  double clutter_density_;
  double view_area_;  // of the sensor in measurement space [m rad]
  double log_miss_;   // log(1 - P_D)
  double log_detection_;  // log P_D
  double accept_d2_;
  double window_s_;
  double now_ = 0.0;
  Pose2 pose_ = Pose2::Zero();
  std::vector<Hypothesis> hypotheses_;
};

}  // namespace slamkit
