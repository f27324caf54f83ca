#pragma once
// Data association: which landmark, if any, each observation of a scan comes from. Written against
// GaussianMapView, the part of a filter's belief association needs, so every filter can use it.
//
//  - Nearest neighbour (individual compatibility): each observation's Mahalanobis distance to every
//    candidate landmark; pairs are taken greedily in order of increasing distance, each landmark at
//    most once per scan. An unpaired observation beyond the new-landmark gate of every candidate
//    starts a landmark; one between the gates is ambiguous and discarded.
//  - JCBB (Neira and Tardos, joint compatibility branch and bound): searches the pairings of a whole
//    scan for the hypothesis with the most pairings whose JOINT innovation passes the chi-square
//    gate (k times the measurement's dof), ties broken by the smaller joint Mahalanobis distance. The joint covariance
//    includes the correlations through the vehicle and the map, which is what rejects pairings that
//    are individually plausible but jointly inconsistent. The joint distance is extended by one
//    block Cholesky step per node, O(k^2) per node for k pairings.
//  - Both consider only the pairs inside the acceptance gate whose pairing probability (see
//    AssociationConfig::min_pairing_probability) is high enough: an observation that two landmarks,
//    or a landmark and clutter, explain about as well is not paired by either.
#include <Eigen/Core>
#include <memory>
#include <span>
#include <vector>

#include "slamkit/assoc/association_config.hpp"
#include "slamkit/core/association_record.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

/// The Gaussian belief over the vehicle pose and a map, as association sees it.
class GaussianMapView {
 public:
  virtual ~GaussianMapView() = default;
  virtual Pose2 pose() const = 0;
  virtual Matrix3 pose_covariance() const = 0;
  virtual Vector2 landmark_position(std::size_t index) const = 0;
  /// cov(m_index, x_vehicle), 2x3.
  virtual Matrix23 landmark_pose_covariance(std::size_t index) const = 0;
  /// cov(m_i, m_j); the marginal covariance when i == j.
  virtual Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const = 0;
};

/// Squared Mahalanobis distance thresholds derived from the configured probabilities, with as many
/// degrees of freedom as the measurement has components, for every filter. from() validates the
/// whole config first.
struct Gates {
  double accept = 0.0;
  double new_landmark = 0.0;
  static Gates from(const AssociationConfig& config, int dof);
};

/// The decision for one observation; `landmark` is a map index, meaningful for kUpdate only.
struct Pairing {
  AssociationDecision decision = AssociationDecision::kDiscard;
  std::size_t landmark = 0;
};

struct AssociationStats {
  std::size_t candidate_pairs = 0;  // observation-landmark pairs evaluated
  std::size_t jcbb_nodes = 0;       // search nodes JCBB expanded
  bool jcbb_budget_exhausted = false;
};

/// What associate() keeps from one scan to the next: its tables, search stacks and factors, and the
/// chi-square gates. A filter holds one, so that a scan no larger than those before it allocates
/// nothing. Copies start empty: the contents are scratch.
class AssociationWorkspace {
 public:
  AssociationWorkspace();
  AssociationWorkspace(const AssociationWorkspace&);
  AssociationWorkspace& operator=(const AssociationWorkspace&);
  AssociationWorkspace(AssociationWorkspace&&) noexcept;
  AssociationWorkspace& operator=(AssociationWorkspace&&) noexcept;
  ~AssociationWorkspace();

  /// Defined where associate() is: nothing outside it looks inside.
  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// False detections per scan per unit of measurement space (1 / (m rad) for range and bearing):
/// config.clutter_per_scan spread uniformly over the part of the model's measurement space the
/// sensor's range and field of view span.
double clutter_density(const AssociationConfig& config, const SensorLimits& sensor, const ObservationModel& model);

/// Throws std::invalid_argument unless `config`'s method can run with `model`: searching for the
/// landmark an observation comes from (nn, jcbb) needs a model whose one measurement places a
/// landmark, since a landmark that a range or a bearing alone cannot place is started from several
/// observations of it, which only known identities gather.
void require_searchable(const AssociationConfig& config, const ObservationModel& model);

/// Pairs each of `observations` with one of `candidates` (map indices of landmarks that can be in
/// view) or decides it is new or ambiguous, into `out` (one entry per observation). `method` must be
/// kNearestNeighbour or kJcbb. `clutter` is the clutter density (see clutter_density()).
void associate(std::span<const Observation> observations, std::span<const std::size_t> candidates,
               const GaussianMapView& belief, const ObservationModel& model, const AssociationConfig& config,
               AssociationWorkspace& workspace, std::vector<Pairing>& out, AssociationStats* stats = nullptr,
               double clutter = 0.0);

/// The same with storage of its own, for one-off calls.
std::vector<Pairing> associate(std::span<const Observation> observations, std::span<const std::size_t> candidates,
                               const GaussianMapView& belief, const ObservationModel& model,
                               const AssociationConfig& config, AssociationStats* stats = nullptr,
                               double clutter = 0.0);

}  // namespace slamkit
