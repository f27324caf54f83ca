#include "slamkit/gridslam/grid_fastslam.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/filters/particle_path.hpp"
#include "slamkit/filters/particle_set.hpp"
#include "slamkit/filters/worker_pool.hpp"
#include "slamkit/grid/grid_snapshot.hpp"
#include "slamkit/models/motion_model.hpp"

namespace slamkit {

namespace {

// A scan's work per particle is a scan match (tens of likelihood evaluations): one particle is
// already worth a thread's hand-over.
constexpr std::size_t kScanGrain = 1;

unsigned thread_count(unsigned requested) {
  return requested > 0 ? requested : std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace

struct GridFastSlam::Impl {
  struct Particle {
    Pose2 pose;  // drawn at the last scan, then moved by the odometry's prediction
    Matrix3 pose_cov = Matrix3::Zero();  // of the prediction since the last scan
    OccupancyGrid map;
    ParticlePath path;
    bool matched = false;  // at the last scan
  };

  /// Spreads the move the scan's match made, from the odometry's prediction to `matched`, over the
  /// poses the particle predicted since its last scan, in proportion to the motion up to each (a
  /// radian counting as a metre): between two mapped scans the path then bends as the odometry's
  /// error did on average instead of jumping at the scan. The path is what the trajectory written
  /// and its relative error show; the filtered pose of each step stays what was known at that step.
  void bend_path(Particle& p, const Pose2& matched) {
    thread_local std::vector<Pose2*> since_scan;  // newest first
    since_scan.clear();
    const std::optional<Pose2> at_scan = p.path.own_poses_after(last_mapped_t, since_scan);
    if (!at_scan) return;
    const auto motion = [](const Pose2& a, const Pose2& b) {
      return (b.head<2>() - a.head<2>()).norm() + std::abs(wrap_angle(b.z() - a.z()));
    };
    double total = 0.0;
    Pose2 previous = *at_scan;
    for (auto it = since_scan.rbegin(); it != since_scan.rend(); ++it) {
      total += motion(previous, **it);
      previous = **it;
    }
    total += motion(previous, p.pose);
    Pose2 move = matched - p.pose;
    move.z() = wrap_angle(move.z());
    double travelled = 0.0;
    previous = *at_scan;
    for (auto it = since_scan.rbegin(); it != since_scan.rend(); ++it) {
      Pose2& pose = **it;
      travelled += motion(previous, pose);
      previous = pose;
      pose += (total > 0.0 ? travelled / total : 1.0) * move;
      pose.z() = wrap_angle(pose.z());
    }
  }

  Impl(std::shared_ptr<const MotionModel> motion_model, const Pose2& initial_pose, const GridFastSlamConfig& cfg)
      : config(cfg),
        motion(motion_model ? std::move(motion_model) : throw std::invalid_argument("grid FastSLAM needs a motion model")),
        matcher(cfg.slam.matcher),
        pool(thread_count(cfg.threads)),
        path_nodes(pool),
        particles(cfg.particles >= 1 ? static_cast<std::size_t>(cfg.particles)
                                     : throw std::invalid_argument("grid FastSLAM needs at least one particle"),
                  Particle{initial_pose, Matrix3::Zero(), OccupancyGrid(cfg.slam.grid), {}, false}, cfg.resample,
                  cfg.resample_when, cfg.seed) {}

  void extend_paths(double t) {
    if (!keep_paths) return;
    for (Particle& p : particles) {
      if (p.path.empty())
        p.path = ParticlePath(path_nodes, t, p.pose);
      else if (t == last_path_t)
        p.path.replace_newest(p.pose);
      else
        p.path.extend(t, p.pose);
    }
    last_path_t = t;
  }

  void scan(const RangeScanEvent& scan) {
    if (!cadence.take(config.slam)) return;
    const bool first = particles.weighed_scans() == 0;
    log_likelihoods.assign(particles.size(), 0.0);
    pool.run(particles.size(), kScanGrain, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        Particle& p = particles[i];
        // The first scan has no map to be matched against: it makes every particle's map from the
        // start pose, which is known.
        if (!first) {
          const PoseProposal proposal =
              scan_match_proposal(matcher, p.map, scan, p.pose, p.pose_cov, config.slam, &particles.stream(i));
          if (keep_paths) bend_path(p, proposal.mean);
          p.pose = proposal.mean;
          p.pose_cov = proposal.covariance;
          log_likelihoods[i] = proposal.log_weight / config.slam.weight_temperature;
          p.matched = proposal.matched;
        }
        p.map.integrate(p.pose, scan);
      }
    });
    unmatched += static_cast<std::size_t>(
        std::count_if(particles.begin(), particles.end(), [&](const Particle& p) { return !first && !p.matched; }));
    extend_paths(scan.t);
    last_mapped_t = scan.t;
    particles.weigh(log_likelihoods);
    particles.resample_if_due();
  }

  GridFastSlamConfig config;
  std::shared_ptr<const MotionModel> motion;
  ScanMatcher matcher;
  // The threads first: the path nodes serve them, and the particles' paths must die before both.
  WorkerPool pool;
  ParticlePath::NodeStorage path_nodes;
  ParticleSet<Particle> particles;
  std::vector<double> log_likelihoods;  // per particle of the current scan
  bool keep_paths = true;
  double last_path_t = NAN;
  double last_mapped_t = -std::numeric_limits<double>::infinity();
  std::size_t unmatched = 0;
  ScanCadence cadence;
  std::vector<AssociationRecord> no_associations;
};

GridFastSlam::GridFastSlam(std::shared_ptr<const MotionModel> motion, const Pose2& initial_pose,
                           const GridFastSlamConfig& config)
    : impl_(std::make_unique<Impl>(std::move(motion), initial_pose, config)) {}

GridFastSlam::~GridFastSlam() = default;

void GridFastSlam::predict(const ControlEvent& control) {
  Impl& s = *impl_;
  // Every particle moves by the same odometry: the first one's motion is the robot's.
  const Pose2 before = s.particles.front().pose;
  for (Impl::Particle& p : s.particles) predict_pose(*s.motion, control, p.pose, p.pose_cov);
  s.cadence.moved(before, s.particles.front().pose);
  s.extend_paths(control.t);
}

void GridFastSlam::update_range_scan(const RangeScanEvent& scan) { impl_->scan(scan); }

Pose2 GridFastSlam::pose() const { return impl_->particles.mean_pose(); }

Matrix3 GridFastSlam::pose_covariance() const { return impl_->particles.pose_covariance(); }

const std::vector<AssociationRecord>& GridFastSlam::last_associations() const { return impl_->no_associations; }

std::vector<StampedPose> GridFastSlam::smoothed_trajectory() const {
  const Impl& s = *impl_;
  return s.particles.best_particle().path.poses();
}

void GridFastSlam::forget_smoothed_trajectory() {
  impl_->keep_paths = false;
  for (Impl::Particle& p : impl_->particles) p.path = ParticlePath();
}

std::vector<WeightedPose> GridFastSlam::pose_samples() const { return impl_->particles.pose_samples(); }

const OccupancyGrid& GridFastSlam::best_map() const { return impl_->particles.best_particle().map; }

GridMap GridFastSlam::grid_map() const { return to_grid_map(best_map()); }

std::map<std::string, double> GridFastSlam::statistics() const {
  const Impl& s = *impl_;
  const auto n = static_cast<double>(s.particles.size());
  std::vector<const OccupancyGrid*> maps;
  for (const Impl::Particle& p : s.particles) maps.push_back(&p.map);
  const auto distinct = static_cast<double>(OccupancyGrid::distinct_bytes(maps));
  std::map<std::string, double> statistics = {
      {"range_scans", static_cast<double>(s.particles.weighed_scans())},
      {"unmatched_particle_scans", static_cast<double>(s.unmatched)},
      {"skipped_range_scans", static_cast<double>(s.cadence.skipped())},
      {"grid_bytes_per_particle", distinct / n},
      {"grid_bytes_unshared_per_particle", static_cast<double>(s.particles.front().map.bytes())}};
  s.particles.add_statistics(statistics);
  return statistics;
}

}  // namespace slamkit
