#pragma once
// The sparse extended information filter (SEIF) of Thrun, Liu, Koller, Ng, Ghahramani and
// Durrant-Whyte (IJRR 2004), the tutorial's ref. [43]: the information form of EKF-SLAM kept sparse
// by bounding the landmarks linked to the vehicle.
//
// State: the information matrix Omega and vector xi (the belief, in canonical form) and an estimate
// of the mean mu = Omega^-1 xi, which linearises the models. Each step, in the order of the paper:
//  * time update, measurement update, mean recovery and map management: SparseInformationFilter's.
//  * sparsification, before each scan when more landmarks than `active_landmarks` are active: the
//    least recently observed ones (m0) are made passive by replacing p(x, m) with
//    p(x | m+, m- = mu-) p(m), with m+ the landmarks that stay active and m- the passive rest. In
//    information form: Omega~ = Omega1 - Omega2 + Omega3 over the vehicle and the active landmarks,
//    Omega1 = p(x, m+ | m-) (m0 marginalised out of Omega's block over x, m+, m0), Omega2 = p(m+ |
//    m-), Omega3 = p(m) (the vehicle marginalised out), and xi~ = xi + (Omega~ - Omega) mu. The
//    map's marginal is unchanged and the vehicle's links to m0 vanish; the approximation conditions
//    the vehicle on m- at its mean, which is what makes SEIF overconfident (Eustice, Walter and
//    Leonard 2005): docs/filters.md measures it.
//
// The covariances association and the runner read are InformationFormEstimator's: by default
// recovered locally, from Omega over the variables asked about and their Markov blanket, as Thrun et
// al. do (constant time, and overconfident beyond SEIF's own approximation); or exactly for SEIF's
// Omega. Either way the NEES shows the overconfidence as it is.
//
// Cost per step: SparseInformationFilter's, the sparsification touching the vehicle and the
// active landmarks only.
#include <vector>

#include "slamkit/filters/sparse_information_filter.hpp"

namespace slamkit {

/// run.json's seif_active_landmarks, seif_recovery_sweeps and seif_covariance.
struct SeifOptions : SparseInformationOptions {};

class SparseExtendedInformationFilter final : public SparseInformationFilter {
 public:
  SparseExtendedInformationFilter(std::shared_ptr<const MotionModel> motion,
                                  std::shared_ptr<const ObservationModel> observation,
                                  const Pose2& initial_pose = Pose2::Zero(),
                                  const Matrix3& initial_covariance = Matrix3::Zero(), const SeifOptions& options = {},
                                  const InformationLinearisation& linearisation = {});

  /// Folds the controls in and sparsifies.
  void begin_scan() override;
  /// Every observation linearised at the current mean estimate; then the mean is recovered.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  /// The base's, and seif_active_landmarks (now), seif_sparsifications and seif_deactivated.
  void add_statistics(std::map<std::string, double>& statistics) const override;

  /// Makes all but the `active` most recently observed active landmarks passive now (begin_scan
  /// does it before each scan with the options' bound).
  void sparsify(std::size_t active);
  /// Omega now, and as the next sparsification to the options' bound leaves it (if any is due).
  std::vector<InformationMatrixPanel> information_panels() const override;

 private:
  /// The active landmarks, the most recently observed first.
  std::vector<std::size_t> active_by_recency() const;
  /// Sparsifies `graph` over `variables` (the vehicle, then the active landmarks by recency), keeping
  /// the first `kept` landmarks active; returns the change made to Omega over them.
  static Eigen::MatrixXd sparsify(InformationGraph& graph, const InformationGraph::Variables& variables,
                                  std::size_t kept);

  std::size_t sparsifications_ = 0;
  std::size_t deactivated_ = 0;
};

}  // namespace slamkit
