#pragma once
// Side-by-side runs of two joint-Gaussian estimators under EkfSlam, for the information filters'
// oracle tests: the EIF against the EKF, the SEIF and the ESEIF against the EIF, the TJTF against the
// EKF.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>

#include "sanitizers.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/extended_information_filter.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace slamkit::testing_support {

inline constexpr double kTolerance = 1e-8;
// The information filters' sparse algebra runs some 30 times slower under AddressSanitizer: the
// comparisons check its memory on the first scans (loop closures included in the default world's
// first lap: its second begins near scan 1,200) rather than take minutes.
inline constexpr std::size_t kMaxScansUnderSanitizer = 300;
inline std::size_t capped_under_sanitizer(std::size_t scans) {
#ifdef SLAMKIT_ADDRESS_SANITIZER
  return std::min(scans, kMaxScansUnderSanitizer);
#else
  return scans;
#endif
}

// The information form cannot start from a pose known exactly; the EKF is given the prior the EIF
// starts from instead.
inline const Matrix3 kPrior = ExtendedInformationFilter::kInitialPoseFloor * Matrix3::Identity();

struct Differences {
  double state = 0.0;
  double covariance = 0.0;
  double pose_between_scans = 0.0;  // pose and its covariance after controls, before the next scan
  std::size_t checks = 0;
  std::size_t decisions_differing = 0;
  double landmarks_fused = 0.0;
  double landmarks_removed = 0.0;
  std::size_t landmarks = 0;
};

inline std::unique_ptr<EkfSlam> make(const Dataset& data, EkfVariant variant, AssociationMethod method,
                                     bool joint_scan_update, const Matrix3& prior = kPrior,
                                     const SeifOptions& seif = {}, const EseifOptions& eseif = {},
                                     const TjtfOptions& tjtf = {}, const InformationLinearisation& linearised = {}) {
  EkfSlamOptions options;
  options.information_linearisation = linearised.linearisation;
  options.update_iterations = linearised.update_iterations;
  options.seif = seif;
  options.eseif = eseif;
  options.tjtf = tjtf;
  options.initial_pose = data.initial_pose;
  options.initial_covariance = prior;
  options.association.method = method;
  options.sensor = data.sensor;
  options.variant = variant;
  options.joint_scan_update = joint_scan_update;
  return std::make_unique<EkfSlam>(data.motion, data.observation, options);
}

/// Runs `filter` over the first `scans` scans of `data` and the controls before them.
inline void drive(EkfSlam& filter, const Dataset& data, std::size_t scans) {
  std::size_t done = 0;
  for (const Event& e : data.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      filter.predict(*c);
    } else {
      filter.update(std::get<ScanEvent>(e));
      if (++done == scans) break;
    }
  }
}

inline double max_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

/// The largest difference relative to the largest entry of `a` (or absolute below 1): roundoff
/// grows with the entries, and a range-only map's covariance holds hundreds of square metres.
inline double relative_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return max_difference(a, b) / std::max(1.0, a.cwiseAbs().maxCoeff());
}

/// Runs the `reference` estimator (by default the EKF) and the `tested` one (by default the EIF) side
/// by side over at most `max_scans` scans of `data`, comparing the whole state and covariance every
/// `check_every` scans and at the end, every scan's association decisions, and the pose's belief
/// after every control. `linearised` sets both's update iterations and the information filters'
/// Jacobians (the EKF's are its variant's).
inline Differences compare(const Dataset& data, AssociationMethod method, std::size_t check_every,
                           std::size_t max_scans, bool joint_scan_update = true, const Matrix3& prior = kPrior,
                           EkfVariant reference = EkfVariant::kFull, EkfVariant tested = EkfVariant::kInformation,
                           const SeifOptions& seif = {}, const EseifOptions& eseif = {}, const TjtfOptions& tjtf = {},
                           const InformationLinearisation& linearised = {}) {
  const auto ekf = make(data, reference, method, joint_scan_update, prior, seif, eseif, tjtf, linearised);
  const auto eif = make(data, tested, method, joint_scan_update, prior, seif, eseif, tjtf, linearised);
  const EkfEstimator& a = ekf->estimator();
  const EkfEstimator& b = eif->estimator();
  Differences diff;
  const auto compare_all = [&] {
    EXPECT_EQ(a.state_dim(), b.state_dim());
    if (a.state_dim() != b.state_dim()) return;
    diff.state = std::max(diff.state, relative_difference(a.state(), b.state()));
    diff.covariance = std::max(diff.covariance, relative_difference(a.covariance(), b.covariance()));
    ++diff.checks;
  };
  std::size_t scans = 0;
  for (const Event& e : data.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      ekf->predict(*c);
      eif->predict(*c);
      diff.pose_between_scans =
          std::max({diff.pose_between_scans, relative_difference(a.pose(), b.pose()),
                    relative_difference(a.pose_covariance(), b.pose_covariance())});
      continue;
    }
    ekf->update(std::get<ScanEvent>(e));
    eif->update(std::get<ScanEvent>(e));
    const auto& da = ekf->last_associations();
    const auto& db = eif->last_associations();
    EXPECT_EQ(da.size(), db.size());
    for (std::size_t k = 0; k < std::min(da.size(), db.size()); ++k)
      if (da[k].decision != db[k].decision || da[k].landmark_id != db[k].landmark_id) ++diff.decisions_differing;
    if (++scans % check_every == 0) compare_all();
    if (scans == max_scans) break;
  }
  compare_all();
  if (method != AssociationMethod::kKnown) {
    diff.landmarks_fused = eif->statistics().at("landmarks_fused");
    diff.landmarks_removed = eif->statistics().at("landmarks_removed");
  }
  diff.landmarks = eif->num_landmarks();
  return diff;
}

inline void expect_equivalent(const Differences& diff) {
  EXPECT_LT(diff.state, kTolerance);
  EXPECT_LT(diff.covariance, kTolerance);
  EXPECT_LT(diff.pose_between_scans, kTolerance);
  EXPECT_EQ(diff.decisions_differing, 0u);
  ::testing::Test::RecordProperty("max_state_difference", std::to_string(diff.state));
  ::testing::Test::RecordProperty("max_covariance_difference", std::to_string(diff.covariance));
}

}  // namespace slamkit::testing_support
