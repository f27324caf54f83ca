#pragma once
// What the two sparse information filters share: SEIF (SparseExtendedInformationFilter, sparse by
// approximation) and ESEIF (ExactlySparseInformationFilter, sparse by forgetting). Both hold the
// belief in canonical form, the information matrix Omega (InformationFormEstimator's graph) and the
// information vector xi, with an estimate of the mean mu = Omega^-1 xi that linearises the models.
// They differ only in how they keep the vehicle's links few.
//
// Shared here:
//  * the time update of xi (InformationFormEstimator folds Omega): with y = A^-T xi + Psi(:, v) c,
//    xi' = y - Psi(:, v) K y_v. It touches the vehicle and its linked ("active") landmarks only;
//  * the measurement update Omega += H^T R^-1 H, xi += H^T R^-1 (nu + H mu), local to the vehicle
//    and the observed landmarks, which become active;
//  * mean recovery (amortised): `recovery_sweeps` block Gauss-Seidel sweeps of Omega mu = xi per
//    scan over the vehicle, the active landmarks and as many others in turn; 0 solves exactly;
//  * map management, exact in canonical form: a new landmark is the factor [-Gx I]; a removed one
//    is marginalised (xi' = xi_r - Omega_rm Omega_mm^-1 xi_m); a fusion conditions on
//    e = m_duplicate - m_original = 0 after the change of variables, which in canonical form drops
//    e's rows (the mean is then recovered exactly: fusions are rare).
//
// Cost per step: the fold, the update and the relaxation touch the vehicle, the active landmarks,
// the observed ones and their neighbours in Omega's graph, so a step costs the same however large
// the map; a fusion (a loop closure by map matching) and an exact covariance recovery cost what the
// whole map costs.
#include <string_view>
#include <vector>

#include "slamkit/filters/information_form.hpp"

namespace slamkit {

/// The settings of a sparse information filter (run.json's seif_* or eseif_* keys).
struct SparseInformationOptions {
  /// The landmarks linked to the vehicle at most: after each SEIF sparsification; for ESEIF, the
  /// count a scan's update may not exceed without relocating the vehicle (the scan's new landmarks,
  /// and scans that cannot determine the pose, go beyond it until the next relocation). More keeps
  /// more of the exact filter's information, fewer keeps Omega sparser.
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
/// Throws std::invalid_argument naming the setting out of range as run.json does ("seif" gives
/// seif_active_landmarks).
void validate(const SparseInformationOptions& options, std::string_view prefix);

class SparseInformationFilter : public InformationFormEstimator {
 public:
  /// Folds the controls in.
  void begin_scan() override;
  using EkfEstimator::add_landmark;
  std::size_t add_landmark(const InitialLandmark& landmark) override;
  void remove_landmark(std::size_t index) override;
  bool fuse_landmarks(std::span<const LandmarkPair> pairs) override;

  /// About the bytes of the filter once the map has `landmarks` landmarks: Omega's graph, each
  /// landmark linked to the landmarks it was active with, taken as four times the active bound (a
  /// landmark stays active while it is seen, beside the others seen then). An exact recovery's
  /// factorisation comes on top.
  static double memory_estimate(std::size_t landmarks, const SparseInformationOptions& options);

  /// The information vector over state() (the pending motion not applied).
  Eigen::VectorXd information_vector() const { return xi_.head(static_cast<Eigen::Index>(dim_)); }
  /// Map indices of the landmarks linked to the vehicle.
  const std::vector<std::size_t>& active_landmarks() const { return active_; }

 protected:
  SparseInformationFilter(std::shared_ptr<const MotionModel> motion,
                          std::shared_ptr<const ObservationModel> observation, const Pose2& initial_pose,
                          const Matrix3& initial_covariance, const SparseInformationOptions& options,
                          const InformationLinearisation& linearisation);

  void reserve(std::size_t dim) override;
  void squeeze_stored_rows(std::size_t first, std::size_t count) override;
  void motion_folded(const FoldedMotion& motion) override;

  /// First estimates: InformationFormEstimator::move_implausible_anchors with the information vector;
  /// the landmarks a move links the vehicle to count as active.
  void move_anchors(std::span<const LandmarkObservation> batch);
  /// The measurement update of `batch` (each observation linearised at `at`), its landmarks made
  /// active; the mean is not recovered.
  void absorb(std::span<const LandmarkObservation> batch, const LinearisationPoint& at);
  /// recovery_sweeps sweeps over the vehicle, the active landmarks, `moved` (landmarks the step
  /// updated that are no longer active) and the next ones in turn (or the exact solve); keeps the
  /// heading wrapped, moving xi with it.
  void recover_mean(std::span<const std::size_t> moved = {});
  /// The mean solved for exactly where the exact covariance recovery has factorised Omega as it
  /// stands, the controls folded in (the gates read covariances before the update), so that the
  /// update linearises at it:
  /// the amortised recovery lags a loop closure's shift of the map by many scans, and its stale mean
  /// made the linearisation overconfident (docs/filters.md). Otherwise nothing.
  void solve_mean_where_factorised();

  const SparseInformationOptions& options() const { return options_; }
  std::size_t scans() const { return scans_; }
  /// The scan count when landmark `index` was last observed or started.
  std::size_t last_seen(std::size_t index) const { return last_seen_[index]; }

  Eigen::VectorXd xi_;  // capacity, as x_
  std::vector<std::size_t> active_;

 private:
  /// Marks landmark `index` linked to the vehicle and seen now.
  void activate(std::size_t index);
  /// Counts every landmark linked to the vehicle as active (those not yet keep the scan they were
  /// last seen in, so that SEIF's recency order stands).
  void activate_vehicle_links();
  /// Wraps the mean's heading, moving xi with it.
  void wrap_heading();
  /// One Gauss-Seidel step for the vehicle's rows, and for a landmark's.
  void relax_vehicle();
  void relax_landmark(std::size_t index);

  SparseInformationOptions options_;
  std::vector<std::size_t> last_seen_;  // by map index
  std::size_t scans_ = 0;
  std::size_t next_relaxed_ = 0;  // the map index the rotation of the recovery continues from
};

}  // namespace slamkit
