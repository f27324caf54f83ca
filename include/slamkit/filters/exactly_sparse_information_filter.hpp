#pragma once
// The exactly sparse extended information filter (ESEIF) of Walter, Eustice and Leonard (IJRR 2007):
// the information form of EKF-SLAM kept sparse without SEIF's approximation. The vehicle's links
// are bounded by forgetting what it knows, never by asserting what it does not:
//  * while no more than `active_landmarks` landmarks are linked to the vehicle, a scan is the
//    exact information filter's update (SparseInformationFilter's);
//  * when a scan would link more, its observations are split. Those of up to half the bound's
//    landmarks (z_beta) are kept aside; the rest (z_alpha) update the filter as usual. Then the
//    vehicle is marginalised out (exact: the landmarks linked to it, the active set and alpha's,
//    become linked to each other), and put back with no information at all, at its current
//    estimate. z_beta's update then relocates it: the vehicle is linked to beta's landmarks only.
// Marginalising is exact and starting the vehicle again from nothing only drops information (the
// vehicle's links to the map through its past motion), so the belief stays consistent: the filter's
// Omega is the exact information matrix of a little less data. What is lost is what the filter knew
// of the pose given the map, its odometry's share above all, at each relocation (docs/filters.md
// measures it); z_beta alone must determine the pose (two range-bearing landmarks; three bearings or
// ranges in general position). A scan that cannot does not relocate, and the active set grows until
// one can (eseif_relocations_deferred counts them). The update must see the scan's observations
// together: the sequential update, one observation at a time, could never relocate, and is refused.
//
// beta is chosen in order of how firmly each landmark is tied into the map (its own information
// block's trace: the landmarks observed most): first each that adds a direction the pose was not
// yet determined in, until all three are, then the others in that order, up to half the bound. Two
// landmarks that just determine the pose leave its heading so loose that later linearisations make
// the filter overconfident; more pin it down.
//
// The covariances are recovered exactly by default (a sparse factorisation, as the EIF): the local
// recovery conditions on the Markov blanket, which for a relocated vehicle is beta's landmarks and
// their neighbours, and is overconfident by far.
#include <vector>

#include "slamkit/filters/sparse_information_filter.hpp"

namespace slamkit {

/// run.json's eseif_active_landmarks, eseif_recovery_sweeps and eseif_covariance. The bound is
/// larger than SEIF's: each relocation forgets most of what the filter knew of the pose given the map
/// (on Victoria Park about 90%), so relocating rarely is what keeps the estimate close to the exact
/// filter's, and a relocation's cost (one marginalisation over the active set) is small.
struct EseifOptions : SparseInformationOptions {
  EseifOptions() {
    active_landmarks = 60;
    covariance = CovarianceRecovery::kExact;
  }
};

class ExactlySparseInformationFilter final : public SparseInformationFilter {
 public:
  ExactlySparseInformationFilter(std::shared_ptr<const MotionModel> motion,
                                 std::shared_ptr<const ObservationModel> observation,
                                 const Pose2& initial_pose = Pose2::Zero(),
                                 const Matrix3& initial_covariance = Matrix3::Zero(),
                                 const EseifOptions& options = {},
                                 const InformationLinearisation& linearisation = {});

  /// The exact update, or, when it would link more than the bound to the vehicle and the batch
  /// determines the pose, the split update with the relocation; then the mean is recovered.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  /// The base's, and eseif_active_landmarks (now), eseif_relocations and eseif_relocations_deferred.
  void add_statistics(std::map<std::string, double>& statistics) const override;
  /// Omega now, titled with the active set and its bound.
  std::vector<InformationMatrixPanel> information_panels() const override;

  /// The positions in `batch` of the observations that relocate the vehicle (z_beta), in the order
  /// chosen; empty if the batch does not determine the pose.
  std::vector<std::size_t> relocation_set(std::span<const LandmarkObservation> batch) const;

 private:
  /// Whether `batch` would link more than the bound to the vehicle.
  bool over_bound(std::span<const LandmarkObservation> batch) const;

  std::size_t relocations_ = 0;
  std::size_t deferred_ = 0;
};

}  // namespace slamkit
