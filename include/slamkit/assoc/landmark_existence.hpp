#pragma once
// Whether a landmark of the map is real. A landmark started from one observation is provisional
// until it has been observed confirm_after times; one that is expected to be seen (predicted well
// inside the sensor's view) and is not, provisional_max_misses scans in a row (confirmed_max_misses
// once confirmed), is removed; a provisional landmark is removed as well after provisional_max_misses
// scans near the vehicle without a sighting, inside the view or not: one never confirmed goes. Both filters keep a LandmarkExistence per landmark (the EKF per map
// entry, FastSLAM per particle and landmark) and create, change and read it only through
// ExistenceRule, so the rule can be replaced here alone, e.g. by a log-odds existence probability,
// without touching the filters.
#include "slamkit/assoc/association_config.hpp"
#include "slamkit/assoc/sensor_view.hpp"
#include "slamkit/core/types.hpp"

namespace slamkit {

/// One landmark's evidence of existence; what it holds is ExistenceRule's business.
class LandmarkExistence {
 private:
  friend class ExistenceRule;
  int observations_ = 0;  // times paired with an observation, the first (its creation) included
  int misses_ = 0;        // consecutive scans in which it was expected to be seen and was not
};

class ExistenceRule {
 public:
  /// Reads confirm_after, the two miss limits and the view margins.
  ExistenceRule(const AssociationConfig& config, const SensorLimits& sensor);

  /// A landmark just started from an observation: provisional, unless one observation confirms.
  LandmarkExistence first_observed() const;
  /// A landmark whose existence is given (a known identity, a prior map): confirmed at once.
  LandmarkExistence given() const;
  /// The landmark was paired with an observation.
  void observed(LandmarkExistence& existence) const;
  /// The landmark was expected to be seen (see detection_view) and was not. Returns true when it
  /// should be removed from the map.
  bool missed(LandmarkExistence& existence) const;
  /// The landmark was a candidate of the scan (in the association view) but is predicted outside
  /// detection_view, and was not seen. A confirmed landmark is not judged by that; a provisional one
  /// counts it as a miss, so that one which leaves the view before it is confirmed (or hovers at its
  /// edge) is removed too, rather than staying provisional for ever. Returns true when it should be
  /// removed from the map.
  bool unseen_nearby(LandmarkExistence& existence) const;
  bool confirmed(const LandmarkExistence& existence) const { return existence.observations_ >= confirm_after_; }

  /// Where a landmark is expected to be seen: the sensor's view narrowed by the margins, since near
  /// its edge the sensor's noise decides whether a landmark is seen. A landmark predicted outside it
  /// (after the scan's update) and not seen has not been missed.
  const SensorView& detection_view() const { return detection_view_; }

 private:
  int confirm_after_;
  int provisional_max_misses_;
  int confirmed_max_misses_;
  SensorView detection_view_;
};

}  // namespace slamkit
