// MRPT's 2-D range-bearing EKF-SLAM (mrpt::slam::CRangeBearingKFSLAM2D) on a slamkit simulator log,
// for a side-by-side comparison with slamkit's EKF (`make bench-compare`, docs/performance.md).
// Not part of slamkit: a separate CMake project that links slamkit's library only to read the log
// (load_dataset) and to score the result with slamkit's own metrics.
//
//   mrpt_ekf_slam --data DIR [--method naive|davison|none] [--slamkit-run RUN_DIR]
//
// Prints one JSON object: MRPT's filter time and accuracy (ATE, map RMSE, pose NEES), and, with
// --slamkit-run (a folder written by `slamkit run --filter ekf`), slamkit's accuracy scored the same
// way (at the same instants).
//
// --method: MRPT's update. naive (its default, kfEKFNaive) updates with all of a scan's observations
// at once through the dense Jacobian of the whole state, O(n^3) per scan; davison (kfEKFAlaDavison)
// applies them one scalar measurement at a time, O(m n^2), its fastest mode for a large map; none
// runs no MRPT filter and only scores the --slamkit-run.
//
// How the log becomes MRPT input:
//   * Motion. MRPT's filter takes one odometry increment per scan. The (speed, steer) controls
//     between two scans are chained with slamkit's AckermannModel from the identity pose, giving the
//     pose change in the frame of the previous scan's pose, and its covariance is propagated control
//     by control exactly as slamkit's EKF does (S <- Fx S Fx^T + Fu M Fu^T, with M the log's control
//     noise). MRPT rotates that covariance into the world frame and composes the increment
//     (x <- x (+) u), which is the same linearised prediction, linearised once per scan instead of
//     once per control.
//   * MRPT skips the prediction while its map is empty (the first scan). So the state is set
//     directly before the first scan: the initial pose (+) the first increment, with the
//     increment's covariance (slamkit's EKF starts from the initial pose with zero covariance).
//   * Observations: CObservationBearingRange with {range, yaw = bearing, pitch = 0, landmarkID =
//     the log's id}. MRPT's yaw is atan2(dy, dx) - heading, counter-clockwise, as slamkit's bearing.
//     With landmarkID >= 0 the filter associates by id (known association) and runs no data
//     association. Sensor noise: options.std_sensor_range / std_sensor_yaw from the log's model;
//     maximum range and field of view from the log (MRPT only predicts landmarks that may be in view).
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservationBearingRange.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPosePDFGaussian.h>
#include <mrpt/slam/CRangeBearingKFSLAM2D.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/eval/metrics.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/trajectory_io.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

namespace {

using slamkit::Landmark;
using slamkit::Matrix3;
using slamkit::Pose2;
using slamkit::StampedPose;

struct Score {
  double ate_rmse = 0.0;
  std::size_t matched = 0;
  std::optional<double> map_rmse;
  std::size_t map_paired = 0;
};

// The true poses at the scan instants (the truth has a pose at every control time, scans included).
std::vector<StampedPose> truth_at(const std::vector<StampedPose>& truth, const std::vector<double>& times) {
  std::vector<StampedPose> out;
  auto it = truth.begin();
  for (double t : times) {
    it = std::lower_bound(it, truth.end(), t - 1e-6, [](const StampedPose& p, double v) { return p.t < v; });
    if (it != truth.end() && std::abs(it->t - t) <= 1e-6) out.push_back({t, it->pose});
  }
  return out;
}

// ATE (SE(2)-aligned position RMSE) of `estimate` against the truth at the scan instants, and the map
// RMSE with the same alignment: the metrics of slamkit's metrics.json, at the instants both filters
// have an estimate.
Score score(const std::vector<StampedPose>& estimate, const std::vector<Landmark>& map,
            const std::vector<StampedPose>& truth_scans, const std::vector<Landmark>& truth_map) {
  const auto pairs = slamkit::eval::match_by_time(estimate, truth_scans, 1.0);
  if (pairs.size() < 2) throw std::runtime_error("fewer than 2 estimate/truth pairs");
  const auto ate = slamkit::eval::absolute_trajectory_error(pairs);
  Score s;
  s.ate_rmse = ate.rmse;
  s.matched = pairs.size();
  if (!truth_map.empty()) {
    const auto m = slamkit::eval::map_rmse(map, truth_map, ate.align);
    s.map_rmse = m.rmse;
    s.map_paired = m.paired;
  }
  return s;
}

std::string json_score(const char* prefix, const Score& s) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "\"%s_ate_rmse_m\": %.6g, \"%s_matched_poses\": %zu, \"%s_map_rmse_m\": ", prefix,
                s.ate_rmse, prefix, s.matched, prefix);
  std::string out = buf;
  if (s.map_rmse) {
    std::snprintf(buf, sizeof buf, "%.6g", *s.map_rmse);
    out += buf;
  } else {
    out += "null";
  }
  std::snprintf(buf, sizeof buf, ", \"%s_map_paired\": %zu", prefix, s.map_paired);
  return out + buf;
}

int usage() {
  std::cerr << "usage: mrpt_ekf_slam --data SIM_LOG_DIR [--method naive|davison|none] [--slamkit-run RUN_DIR]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string data_dir, slamkit_run, method = "naive";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--data" && i + 1 < argc) data_dir = argv[++i];
    else if (a == "--method" && i + 1 < argc) method = argv[++i];
    else if (a == "--slamkit-run" && i + 1 < argc) slamkit_run = argv[++i];
    else return usage();
  }
  if (data_dir.empty() || (method != "naive" && method != "davison" && method != "none")) return usage();
  const bool run_mrpt = method != "none";

  try {
    const slamkit::Dataset ds = slamkit::load_dataset("sim:" + data_dir);
    const auto* rb = dynamic_cast<const slamkit::RangeBearingModel*>(ds.observation.get());
    if (!rb) throw std::runtime_error("the log's observation model is not range-bearing");
    const auto& motion = *ds.motion;

    mrpt::slam::CRangeBearingKFSLAM2D slam;
    slam.options.std_sensor_range = static_cast<float>(rb->params().sigma_range);
    slam.options.std_sensor_yaw = static_cast<float>(rb->params().sigma_bearing);
    slam.options.create_simplemap = false;
    slam.KF_options.method = method == "davison" ? mrpt::bayes::kfEKFAlaDavison : mrpt::bayes::kfEKFNaive;
    slam.KF_options.use_analytic_observation_jacobian = true;
    slam.KF_options.use_analytic_transition_jacobian = true;
    slam.KF_options.enable_profiler = false;
    const mrpt::poses::CPose3D sensor_on_robot(rb->params().offset_x, rb->params().offset_y, 0, 0, 0, 0);

    std::vector<StampedPose> estimate;
    std::vector<Matrix3> estimate_cov;
    std::vector<double> scan_times;
    std::size_t observations = 0;

    const auto begin = std::chrono::steady_clock::now();
    // The odometry increment since the last scan, in that scan's robot frame, and its covariance.
    Pose2 incr = Pose2::Zero();
    Matrix3 incr_cov = Matrix3::Zero();
    bool first_scan = true;
    // The first scan after which MRPT's estimate is no longer a valid Gaussian: a NaN/inf pose, or a
    // pose variance that is not positive. It blows up (variances of -1e9, the pose 1e10 m away) a scan
    // or two before it turns NaN, so scoring must stop at the first invalid covariance, not at the NaN.
    std::optional<double> first_invalid;
    const bool debug = std::getenv("MRPT_COMPARE_DEBUG") != nullptr;
    for (const slamkit::Event& event : ds.events) {
      if (const auto* c = std::get_if<slamkit::ControlEvent>(&event)) {
        const Matrix3 fx = motion.jacobian_state(incr, c->u, c->dt);
        const Matrix3 q = motion.process_noise(incr, c->u, c->dt);
        incr = motion.predict(incr, c->u, c->dt);
        incr_cov = fx * incr_cov * fx.transpose() + q;
        continue;
      }
      const auto& scan = std::get<slamkit::ScanEvent>(event);
      if (!run_mrpt) {
        scan_times.push_back(scan.t);
        continue;
      }
      mrpt::math::CMatrixDouble33 cov;
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) cov(r, k) = incr_cov(r, k);

      auto actions = mrpt::obs::CActionCollection::Create();
      if (first_scan) {
        // MRPT does not predict while the map is empty: start the state at initial pose (+) increment.
        const mrpt::poses::CPose2D x0(ds.initial_pose[0], ds.initial_pose[1], ds.initial_pose[2]);
        const mrpt::poses::CPose2D x1 = x0 + mrpt::poses::CPose2D(incr[0], incr[1], incr[2]);
        mrpt::poses::CPosePDFGaussian start(x1, cov);
        start.rotateCov(ds.initial_pose[2]);
        auto& x = slam.internal_getXkk();
        auto& p = slam.internal_getPkk();
        x.resize(3);
        x[0] = x1.x();
        x[1] = x1.y();
        x[2] = x1.phi();
        p.setSize(3, 3);
        for (int r = 0; r < 3; ++r)
          for (int k = 0; k < 3; ++k) p(r, k) = start.cov(r, k);
        first_scan = false;
      } else {
        mrpt::obs::CActionRobotMovement2D odo;
        odo.estimationMethod = mrpt::obs::CActionRobotMovement2D::emOdometry;
        odo.poseChange = mrpt::poses::CPosePDFGaussian::Create(mrpt::poses::CPose2D(incr[0], incr[1], incr[2]), cov);
        actions->insert(odo);
      }

      auto obs = mrpt::obs::CObservationBearingRange::Create();
      obs->timestamp = mrpt::Clock::fromDouble(scan.t);
      obs->setSensorPose(sensor_on_robot);
      obs->minSensorDistance = 0.0f;
      obs->maxSensorDistance = static_cast<float>(ds.sensor.max_range);
      obs->fieldOfView_yaw = static_cast<float>(ds.sensor.fov);
      obs->fieldOfView_pitch = 0.0f;
      obs->validCovariances = false;
      obs->sensor_std_range = slam.options.std_sensor_range;
      obs->sensor_std_yaw = slam.options.std_sensor_yaw;
      obs->sensor_std_pitch = 0.0f;
      obs->sensedData.resize(scan.observations.size());
      for (std::size_t i = 0; i < scan.observations.size(); ++i) {
        auto& m = obs->sensedData[i];
        m.range = static_cast<float>(scan.observations[i].z[0]);
        m.yaw = static_cast<float>(scan.observations[i].z[1]);
        m.pitch = 0.0f;
        m.landmarkID = scan.observations[i].id;  // >= 0: MRPT associates by id
      }
      auto sf = mrpt::obs::CSensoryFrame::Create();
      sf->insert(obs);

      slam.processActionObservation(actions, sf);
      observations += scan.observations.size();

      mrpt::poses::CPosePDFGaussian pose;
      slam.getCurrentRobotPose(pose);
      estimate.push_back({scan.t, Pose2(pose.mean.x(), pose.mean.y(), pose.mean.phi())});
      Matrix3 c;
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) c(r, k) = pose.cov(r, k);
      estimate_cov.push_back(c);
      const bool valid = estimate.back().pose.allFinite() && pose.cov.array().isFinite().all() &&
                         pose.cov(0, 0) > 0.0 && pose.cov(1, 1) > 0.0 && pose.cov(2, 2) > 0.0;
      if (!first_invalid && !valid) first_invalid = scan.t;
      if (debug) std::cerr << scan.t << " " << estimate.back().pose.transpose() << " | " << pose.cov(0, 0) << " "
                           << pose.cov(1, 1) << " " << pose.cov(2, 2) << "\n";
      scan_times.push_back(scan.t);
      incr.setZero();
      incr_cov.setZero();
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();

    // MRPT's map, with the log's landmark ids.
    mrpt::poses::CPosePDFGaussian pose;
    std::vector<mrpt::math::TPoint2D> points;
    std::map<unsigned int, mrpt::maps::CLandmark::TLandmarkID> ids;
    mrpt::math::CVectorDouble state;
    mrpt::math::CMatrixDouble state_cov;
    slam.getCurrentState(pose, points, ids, state, state_cov);
    std::vector<Landmark> map;
    for (std::size_t i = 0; i < points.size(); ++i) {
      Landmark lm;
      const auto it = ids.find(static_cast<unsigned int>(i));
      lm.id = it == ids.end() ? slamkit::kUnknownId : static_cast<int>(it->second);
      lm.position = slamkit::Vector2(points[i].x, points[i].y);
      map.push_back(lm);
    }

    const auto truth_scans = truth_at(ds.truth.poses, scan_times);
    // MRPT's pose NEES (3 dof, unaligned, as slamkit's metrics.json) at the scans while its estimate is valid.
    std::vector<double> nees;
    for (std::size_t i = 0, t = 0; i < estimate.size() && t < truth_scans.size(); ++i) {
      if (first_invalid && estimate[i].t >= *first_invalid) break;
      while (t < truth_scans.size() && truth_scans[t].t < estimate[i].t - 1e-6) ++t;
      if (t < truth_scans.size() && std::abs(truth_scans[t].t - estimate[i].t) <= 1e-6)
        nees.push_back(slamkit::eval::pose_nees(estimate[i].pose, estimate_cov[i], truth_scans[t].pose));
    }
    std::cout << "{\"method\": \"" << method << "\", \"scans\": " << scan_times.size() << ", \"observations\": " << observations
              << ", \"mrpt_landmarks\": " << map.size() << ", \"mrpt_wall_time_s\": " << wall
              << ", \"mrpt_first_invalid_t\": ";
    if (first_invalid) std::cout << *first_invalid; else std::cout << "null";
    if (!nees.empty()) {
      const auto summary = slamkit::eval::summarize_nees(nees, 3, 0.95);
      std::cout << ", \"mrpt_nees_pose_mean\": " << summary.mean << ", \"mrpt_nees_pose_in_95_fraction\": "
                << summary.in_interval_fraction;
    }
    if (run_mrpt && !truth_scans.empty())
      std::cout << ", " << json_score("mrpt", score(estimate, map, truth_scans, ds.truth.landmarks));
    std::vector<StampedPose> sk_traj;
    if (!slamkit_run.empty() && !truth_scans.empty()) {
      sk_traj = slamkit::read_tum(slamkit_run + "/trajectory.tum");
      const auto sk_map = slamkit::read_map(slamkit_run + "/map.txt");
      std::cout << ", " << json_score("slamkit", score(sk_traj, sk_map, truth_scans, ds.truth.landmarks));
    }
    if (first_invalid && !truth_scans.empty()) {
      // Once MRPT's estimate is invalid its accuracy is meaningless; both trajectories are also scored
      // on the scans before that, so the two filters are compared where both have an answer.
      const auto before = [&](const std::vector<StampedPose>& poses) {
        std::vector<StampedPose> out;
        for (const StampedPose& p : poses)
          if (p.t < *first_invalid) out.push_back(p);
        return out;
      };
      const auto truth_before = before(truth_scans);
      std::cout << ", \"mrpt_ate_rmse_before_invalid_m\": " << score(before(estimate), {}, truth_before, {}).ate_rmse;
      if (!sk_traj.empty())
        std::cout << ", \"slamkit_ate_rmse_before_invalid_m\": "
                  << score(before(sk_traj), {}, truth_before, {}).ate_rmse;
    }
    std::cout << "}\n";
  } catch (const std::exception& e) {
    std::cerr << "mrpt_ekf_slam: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
