#pragma once
// The sparse extended information filter (SEIF) of Thrun, Liu, Koller, Ng, Ghahramani and
// Durrant-Whyte (IJRR 2004), the tutorial's ref. [43]: the information form of EKF-SLAM kept sparse
// by bounding the landmarks linked to the vehicle.
//
// State: the information matrix Omega and vector xi (the belief, in canonical form) and an estimate
// of the mean mu = Omega^-1 xi, which linearises the models. Each step, in the order of the paper:
//  * time update: InformationFormEstimator's fold of the scan's controls, plus the information
//    vector's: with y = A^-T xi + Psi(:, v) c, xi' = y - Psi(:, v) K y_v. It touches the vehicle and
//    its linked ("active") landmarks only, and links those with each other.
//  * measurement update: Omega += H^T R^-1 H, xi += H^T R^-1 (nu + H mu), local to the vehicle and
//    the observed landmarks, which become active.
//  * sparsification, before each scan when more landmarks than `active_landmarks` are active: the
//    least recently observed ones (m0) are made passive by replacing p(x, m) with
//    p(x | m+, m- = mu-) p(m), with m+ the landmarks that stay active and m- the passive rest. In
//    information form: Omega~ = Omega1 - Omega2 + Omega3 over the vehicle and the active landmarks,
//    Omega1 = p(x, m+ | m-) (m0 marginalised out of Omega's block over x, m+, m0), Omega2 = p(m+ |
//    m-), Omega3 = p(m) (the vehicle marginalised out), and xi~ = xi + (Omega~ - Omega) mu. The
//    map's marginal is unchanged and the vehicle's links to m0 vanish; the approximation conditions
//    the vehicle on m- at its mean, which is what makes SEIF overconfident (Eustice, Walter and
//    Leonard 2005): docs/filters.md measures it.
//  * mean recovery (amortised): `recovery_sweeps` block Gauss-Seidel sweeps of Omega mu = xi per
//    scan over the vehicle, the active landmarks and as many others in turn; 0 solves exactly.
//
// Map management is exact in canonical form: a new landmark is the factor [-Gx I]; a removed one is
// marginalised (xi' = xi_r - Omega_rm Omega_mm^-1 xi_m); a fusion conditions on e = m_duplicate -
// m_original = 0 after the change of variables, which in canonical form drops e's rows (the mean is
// then recovered exactly: fusions are rare).
//
// The covariances association and the runner read are InformationFormEstimator's: by default
// recovered locally, from Omega over the variables asked about and their Markov blanket, as Thrun et
// al. do (constant time, and overconfident beyond SEIF's own approximation); or exactly for SEIF's
// Omega. Either way the NEES shows the overconfidence as it is.
//
// Cost per step: the fold, the update, the sparsification and the relaxation touch the vehicle, the
// active landmarks, the observed ones and their neighbours in Omega's graph, so a step costs the
// same however large the map; a fusion (a loop closure by map matching) and an exact recovery cost
// what the whole map costs.
#include <vector>

#include "slamkit/filters/information_form.hpp"

namespace slamkit {

struct SeifOptions {
  /// The landmarks linked to the vehicle at most, after each scan's sparsification: more keeps more
  /// of the exact filter's information, fewer keeps Omega sparser.
  std::size_t active_landmarks = 20;
  /// Block Gauss-Seidel sweeps of the mean recovery per scan; 0 recovers the mean exactly (a sparse
  /// Cholesky solve of the whole map).
  int recovery_sweeps = 2;
  /// How the covariances association and the runner read are recovered: local (from the Markov
  /// blanket of what is asked about, the cost independent of the map's size; overconfident by the
  /// conditioning) or exact (a sparse factorisation of the whole map, as the EIF).
  CovarianceRecovery covariance = CovarianceRecovery::kLocal;
  static constexpr std::size_t kMaxActiveLandmarks = 1000000;
  static constexpr int kMaxRecoverySweeps = 1000;
};
/// Throws std::invalid_argument naming the setting out of range.
void validate(const SeifOptions& options);

class SparseExtendedInformationFilter final : public InformationFormEstimator {
 public:
  SparseExtendedInformationFilter(std::shared_ptr<const MotionModel> motion,
                                  std::shared_ptr<const ObservationModel> observation,
                                  const Pose2& initial_pose = Pose2::Zero(),
                                  const Matrix3& initial_covariance = Matrix3::Zero(), const SeifOptions& options = {});

  /// Folds the controls in and sparsifies.
  void begin_scan() override;
  /// Every observation linearised at the current mean estimate; then the mean is recovered.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  using EkfEstimator::add_landmark;
  std::size_t add_landmark(const InitialLandmark& landmark) override;
  void remove_landmark(std::size_t index) override;
  bool fuse_landmarks(std::span<const LandmarkPair> pairs) override;
  /// The base's, and seif_active_landmarks (now), seif_sparsifications and seif_deactivated.
  void add_statistics(std::map<std::string, double>& statistics) const override;

  /// About the bytes of the filter once the map has `landmarks` landmarks: Omega's graph, each
  /// landmark linked to the landmarks it was active with, taken as four times the active bound (a
  /// landmark stays active while it is seen, beside the others seen then). An exact recovery's
  /// factorisation comes on top.
  static double memory_estimate(std::size_t landmarks, const SeifOptions& options);

  /// The information vector over state() (the pending motion not applied).
  Eigen::VectorXd information_vector() const { return xi_.head(static_cast<Eigen::Index>(dim_)); }
  /// Map indices of the landmarks linked to the vehicle.
  const std::vector<std::size_t>& active_landmarks() const { return active_; }
  /// Makes all but the `active` most recently observed active landmarks passive now (begin_scan
  /// does it before each scan with the options' bound).
  void sparsify(std::size_t active);
  /// Omega now, and as the next sparsification to the options' bound leaves it (if any is due).
  std::vector<InformationMatrixPanel> information_panels() const override;

 protected:
  void reserve(std::size_t dim) override;
  void squeeze_stored_rows(std::size_t first, std::size_t count) override;
  void motion_folded(const FoldedMotion& motion) override;

 private:
  /// The active landmarks, the most recently observed first.
  std::vector<std::size_t> active_by_recency() const;
  /// Sparsifies `graph` over `variables` (the vehicle, then the active landmarks by recency), keeping
  /// the first `kept` landmarks active; returns the change made to Omega over them.
  static Eigen::MatrixXd sparsify(InformationGraph& graph, const InformationGraph::Variables& variables,
                                  std::size_t kept);
  /// Marks landmark `index` linked to the vehicle and seen now.
  void activate(std::size_t index);
  /// recovery_sweeps sweeps over the vehicle, the active landmarks and the next ones in turn (or
  /// the exact solve); keeps the heading wrapped, moving xi with it.
  void recover_mean();
  /// One Gauss-Seidel step for the vehicle's rows, and for a landmark's.
  void relax_vehicle();
  void relax_landmark(std::size_t index);

  SeifOptions options_;
  Eigen::VectorXd xi_;  // capacity, as x_
  std::vector<std::size_t> active_;
  std::vector<std::size_t> last_seen_;  // by map index: the scan count when last observed or started
  std::size_t scans_ = 0;
  std::size_t next_relaxed_ = 0;  // the map index the rotation of the recovery continues from
  std::size_t sparsifications_ = 0;
  std::size_t deactivated_ = 0;
};

}  // namespace slamkit
