#include "slamkit/assoc/landmark_existence.hpp"

namespace slamkit {

ExistenceRule::ExistenceRule(const AssociationConfig& config, const SensorLimits& sensor)
    : confirm_after_(config.confirm_after),
      provisional_max_misses_(config.provisional_max_misses),
      confirmed_max_misses_(config.confirmed_max_misses),
      detection_view_(sensor, -config.view_margin_m, -config.view_margin_rad) {}

LandmarkExistence ExistenceRule::first_observed() const {
  LandmarkExistence e;
  e.observations_ = 1;
  return e;
}

LandmarkExistence ExistenceRule::given() const {
  LandmarkExistence e;
  e.observations_ = confirm_after_;
  return e;
}

void ExistenceRule::observed(LandmarkExistence& e) const {
  ++e.observations_;
  e.misses_ = 0;
}

bool ExistenceRule::missed(LandmarkExistence& e) const {
  ++e.misses_;
  return confirmed(e) ? confirmed_max_misses_ > 0 && e.misses_ >= confirmed_max_misses_
                      : e.misses_ >= provisional_max_misses_;
}

bool ExistenceRule::unseen_nearby(LandmarkExistence& e) const {
  if (confirmed(e)) return false;
  ++e.misses_;
  return e.misses_ >= provisional_max_misses_;
}

}  // namespace slamkit
