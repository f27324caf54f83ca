#include "slamkit/assoc/association_config.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace slamkit {

AssociationMethod parse_association_method(const std::string& name) {
  if (name == "known") return AssociationMethod::kKnown;
  if (name == "nn") return AssociationMethod::kNearestNeighbour;
  if (name == "jcbb") return AssociationMethod::kJcbb;
  throw std::invalid_argument("unknown association '" + name + "'; expected one of: known, nn, jcbb");
}

std::string to_string(AssociationMethod method) {
  switch (method) {
    case AssociationMethod::kKnown: return "known";
    case AssociationMethod::kNearestNeighbour: return "nn";
    case AssociationMethod::kJcbb: return "jcbb";
  }
  return "known";
}

void validate(const AssociationConfig& c) {
  auto fail = [](const char* setting, const std::string& range, const auto& found) {
    throw std::invalid_argument(fmt::format("association setting {} must be {}, found {}", setting, range, found));
  };
  if (!(c.accept_probability > 0.0 && c.accept_probability < 1.0))
    fail("accept_probability", "in (0, 1)", c.accept_probability);
  if (!(c.new_landmark_probability >= c.accept_probability && c.new_landmark_probability < 1.0))
    fail("new_landmark_probability", fmt::format("in [accept_probability, 1) = [{}, 1)", c.accept_probability),
         c.new_landmark_probability);
  if (c.confirm_after < 1) fail("confirm_after", ">= 1", c.confirm_after);
  if (c.provisional_max_misses < 1) fail("provisional_max_misses", ">= 1", c.provisional_max_misses);
  if (c.confirmed_max_misses < 0) fail("confirmed_max_misses", ">= 0 (0: never remove)", c.confirmed_max_misses);
  if (!(std::isfinite(c.view_margin_m) && c.view_margin_m >= 0.0))
    fail("view_margin_m", "finite and >= 0", c.view_margin_m);
  if (!(std::isfinite(c.view_margin_rad) && c.view_margin_rad >= 0.0))
    fail("view_margin_rad", "finite and >= 0", c.view_margin_rad);
  if (c.jcbb_max_nodes < 1) fail("jcbb_max_nodes", ">= 1", c.jcbb_max_nodes);
}

}  // namespace slamkit
