#include <stdexcept>

#include "slamkit/assoc/association_config.hpp"

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

}  // namespace slamkit
