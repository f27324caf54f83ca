#pragma once
// What a filter did with each observation of a scan. Filters produce these records, association
// decides them, the run folder stores them and evaluation scores them, so the type lives here, below
// all of those modules.
#include "slamkit/core/types.hpp"

namespace slamkit {

/// What a filter did with one observation: updated a landmark, started a new one from it, or
/// discarded it (ambiguous, or outside every gate).
enum class AssociationDecision { kUpdate, kNew, kDiscard };

/// The decision's name, as associations.txt and the Python module spell it.
inline const char* to_string(AssociationDecision decision) {
  switch (decision) {
    case AssociationDecision::kUpdate: return "update";
    case AssociationDecision::kNew: return "new";
    case AssociationDecision::kDiscard: return "discard";
  }
  return "discard";
}

struct AssociationRecord {
  AssociationDecision decision = AssociationDecision::kDiscard;
  /// The landmark updated or created (its map id); kUnknownId when discarded.
  int landmark_id = kUnknownId;
};

}  // namespace slamkit
