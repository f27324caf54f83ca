#pragma once
// The extended information filter (EIF): EKF-SLAM's joint Gaussian held in information form, the
// information matrix Omega = P^-1 over the same state and the mean, with the same motion and
// observation models and the same linearisation points, so that on the same log it gives the EKF's
// estimate (tests/extended_information_filter_test.cpp checks it to 1e-8). It is the tutorial's third
// solution form (its ref. [43]) in exact form, and the oracle the sparse information filters are
// tested against.
//
// The steps, each an exact rewrite of the EKF's (the time update and the covariances are
// InformationFormEstimator's):
//  * measurement update: Omega += H^T R^-1 H, and the mean moves by Omega^-1 H^T R^-1 nu, a sparse
//    Cholesky solve. H touches only the vehicle's and the observed landmarks' columns, so the
//    information added is local; the solve is not.
//  * new landmark: the factor m = g(x, z) + w, whose Jacobian in the state is [-Gx I] and whose
//    information is the inverse of the landmark's covariance given the pose.
//  * removal: the landmark's rows marginalised out by their Schur complement.
//  * fusion (loop closure): conditioning on m_duplicate = m_original is exact in information form by
//    a change of variables, e = m_duplicate - m_original, after which conditioning on e = 0 drops e's
//    rows; the duplicate is then held as an independent point at the original's position until
//    the filter removes it.
//
// Cost: the EIF is exact, so every landmark the vehicle saw stays linked to it and the motion update
// links them all to each other: Omega fills in, and a solve costs what the EKF's dense update costs
// and more. It is the reference form, not the fast one; the sparse information filter keeps Omega
// sparse by approximation.
#include "slamkit/filters/information_form.hpp"

namespace slamkit {

class ExtendedInformationFilter final : public InformationFormEstimator {
 public:
  ExtendedInformationFilter(std::shared_ptr<const MotionModel> motion,
                            std::shared_ptr<const ObservationModel> observation,
                            const Pose2& initial_pose = Pose2::Zero(),
                            const Matrix3& initial_covariance = Matrix3::Zero(),
                            const InformationLinearisation& linearisation = {})
      : InformationFormEstimator(std::move(motion), std::move(observation), initial_pose, initial_covariance,
                                 CovarianceRecovery::kExact, linearisation) {}

  /// Every observation linearised at the prior (or the last iterate), as the EKF's joint update.
  /// Returns false (and changes nothing) if the updated information matrix does not factorise.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  using EkfEstimator::add_landmark;
  std::size_t add_landmark(const InitialLandmark& landmark) override;
  void remove_landmark(std::size_t index) override;
  bool fuse_landmarks(std::span<const LandmarkPair> pairs) override;
};

}  // namespace slamkit
