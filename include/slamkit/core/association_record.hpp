#pragma once
// What a filter did with each observation of a scan. Filters produce these records, association
// decides them, the run folder stores them and evaluation scores them, so the type lives here, below
// all of those modules.
#include <cstddef>

#include "slamkit/core/types.hpp"

namespace slamkit {

/// What a filter did with one observation: updated a landmark, started a new one from it, discarded
/// it (ambiguous, or outside every gate), or kept it for a landmark that one observation cannot
/// place (pending: its landmark starts once enough observations agree).
enum class AssociationDecision { kUpdate, kNew, kDiscard, kPending };

/// The decision's name, as associations.txt and the Python module spell it.
inline const char* to_string(AssociationDecision decision) {
  switch (decision) {
    case AssociationDecision::kUpdate: return "update";
    case AssociationDecision::kNew: return "new";
    case AssociationDecision::kDiscard: return "discard";
    case AssociationDecision::kPending: return "pending";
  }
  return "discard";
}

struct AssociationRecord {
  AssociationDecision decision = AssociationDecision::kDiscard;
  /// The landmark updated, created or waiting to start (its map id); kUnknownId when discarded.
  int landmark_id = kUnknownId;
};

/// The observation a landmark was started from: observation `observation` of the `scan`-th scan
/// given to the filter (0-based both; the indices of GroundTruth::observation_ids).
struct LandmarkOrigin {
  std::size_t scan = 0;
  std::size_t observation = 0;
};

}  // namespace slamkit
