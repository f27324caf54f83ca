#include "slamkit/gridslam/grid_fastslam.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/random_draws.hpp"
#include "slamkit/filters/particle_moments.hpp"
#include "slamkit/filters/particle_path.hpp"
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
    Matrix3 covariance = Matrix3::Zero();  // of the prediction since the last scan
    double log_weight = 0.0;
    OccupancyGrid map;
    ParticlePath path;
    bool matched = false;  // at the last scan
  };

  Impl(std::shared_ptr<const MotionModel> motion_model, const Pose2& initial_pose, const GridFastSlamConfig& cfg)
      : config(cfg), motion(std::move(motion_model)), matcher(cfg.slam.matcher), pool(thread_count(cfg.threads)),
        path_nodes(pool), resample_rng(splitmix64(cfg.seed ^ 0x47726964ULL)) {
    if (!motion) throw std::invalid_argument("grid FastSLAM needs a motion model");
    if (cfg.particles < 1) throw std::invalid_argument("grid FastSLAM needs at least one particle");
    const auto n = static_cast<std::size_t>(cfg.particles);
    slots.resize(n);
    for (std::size_t i = 0; i < n; ++i) slots[i].seed(splitmix64(splitmix64(cfg.seed) ^ i));
    particles.reserve(n);
    for (std::size_t i = 0; i < n; ++i)
      particles.push_back({initial_pose, Matrix3::Zero(), 0.0, OccupancyGrid(cfg.slam.grid), {}, false});
    weights.assign(n, 1.0 / static_cast<double>(n));
  }

  std::size_t best() const {
    return static_cast<std::size_t>(std::max_element(weights.begin(), weights.end()) - weights.begin());
  }

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
    const bool first = scans++ == 0;
    log_weights.resize(particles.size());
    pool.run(particles.size(), kScanGrain, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        Particle& p = particles[i];
        // The first scan has no map to be matched against: it makes every particle's map from the
        // start pose, which is known.
        if (!first) {
          const PoseProposal proposal =
              scan_match_proposal(matcher, p.map, scan, p.pose, p.covariance, config.slam, &slots[i]);
          p.pose = proposal.mean;
          p.covariance = proposal.covariance;
          p.log_weight += proposal.log_weight / config.slam.weight_temperature;
          p.matched = proposal.matched;
        }
        p.map.integrate(p.pose, scan);
        log_weights[i] = p.log_weight;
      }
    });
    unmatched += static_cast<std::size_t>(
        std::count_if(particles.begin(), particles.end(), [&](const Particle& p) { return !first && !p.matched; }));
    if (!normalize_log_weights(log_weights, weights)) ++collapses;
    // Keep the log-weights near zero so that they never lose precision however long the run.
    const double shift = *std::max_element(log_weights.begin(), log_weights.end());
    if (std::isfinite(shift))
      for (Particle& p : particles) p.log_weight -= shift;
    extend_paths(scan.t);
    const double ess = effective_sample_size(weights);
    ess_sum += ess;
    if (config.resample_when.should_resample(scans, ess, particles.size())) resample();
  }

  void resample() {
    parents.clear();
    slamkit::resample(config.resample, weights, resample_rng, scratch, parents);
    std::vector<Particle> drawn;
    drawn.reserve(particles.size());
    for (std::size_t parent : parents) drawn.push_back(particles[parent]);
    particles = std::move(drawn);
    for (Particle& p : particles) p.log_weight = 0.0;
    weights.assign(particles.size(), 1.0 / static_cast<double>(particles.size()));
    ++resamples;
  }

  GridFastSlamConfig config;
  std::shared_ptr<const MotionModel> motion;
  ScanMatcher matcher;
  // The threads first: the path nodes serve them, and the particles' paths must die before both.
  WorkerPool pool;
  ParticlePath::NodeStorage path_nodes;
  std::vector<std::mt19937_64> slots;
  std::vector<Particle> particles;
  std::vector<double> weights, log_weights;
  std::mt19937_64 resample_rng;
  ResampleScratch scratch;
  std::vector<std::size_t> parents;
  bool keep_paths = true;
  double last_path_t = NAN;
  std::size_t scans = 0, resamples = 0, collapses = 0, unmatched = 0;
  double ess_sum = 0.0;
  std::vector<AssociationRecord> no_associations;
};

GridFastSlam::GridFastSlam(std::shared_ptr<const MotionModel> motion, const Pose2& initial_pose,
                           const GridFastSlamConfig& config)
    : impl_(std::make_unique<Impl>(std::move(motion), initial_pose, config)) {}

GridFastSlam::~GridFastSlam() = default;

void GridFastSlam::predict(const ControlEvent& control) {
  Impl& s = *impl_;
  for (Impl::Particle& p : s.particles) predict_pose(*s.motion, control, p.pose, p.covariance);
  s.extend_paths(control.t);
}

void GridFastSlam::update_range_scan(const RangeScanEvent& scan) { impl_->scan(scan); }

Pose2 GridFastSlam::pose() const {
  const Impl& s = *impl_;
  return weighted_mean_pose(s.weights, [&](std::size_t i) -> const Pose2& { return s.particles[i].pose; });
}

Matrix3 GridFastSlam::pose_covariance() const {
  const Impl& s = *impl_;
  const Matrix3 covariance = mixture_covariance(
      s.weights, pose(), [&](std::size_t i) -> const Pose2& { return s.particles[i].pose; },
      [&](std::size_t i) -> const Matrix3& { return s.particles[i].covariance; });
  return 0.5 * (covariance + covariance.transpose());
}

const std::vector<AssociationRecord>& GridFastSlam::last_associations() const { return impl_->no_associations; }

std::vector<StampedPose> GridFastSlam::smoothed_trajectory() const {
  const Impl& s = *impl_;
  return s.particles[s.best()].path.poses();
}

void GridFastSlam::forget_smoothed_trajectory() {
  impl_->keep_paths = false;
  for (Impl::Particle& p : impl_->particles) p.path = ParticlePath();
}

std::vector<WeightedPose> GridFastSlam::pose_samples() const {
  const Impl& s = *impl_;
  std::vector<WeightedPose> out;
  out.reserve(s.particles.size());
  for (std::size_t i = 0; i < s.particles.size(); ++i) out.push_back({s.particles[i].pose, s.weights[i]});
  return out;
}

const OccupancyGrid& GridFastSlam::best_map() const { return impl_->particles[impl_->best()].map; }

GridMap GridFastSlam::grid_map() const { return to_grid_map(best_map()); }

std::map<std::string, double> GridFastSlam::statistics() const {
  const Impl& s = *impl_;
  const auto n = static_cast<double>(s.particles.size());
  std::vector<const OccupancyGrid*> maps;
  for (const Impl::Particle& p : s.particles) maps.push_back(&p.map);
  const auto distinct = static_cast<double>(OccupancyGrid::distinct_bytes(maps));
  return {{"particles", n},
          {"range_scans", static_cast<double>(s.scans)},
          {"ess_mean", s.scans > 0 ? s.ess_sum / static_cast<double>(s.scans) : n},
          {"resamples", static_cast<double>(s.resamples)},
          {"weight_collapses", static_cast<double>(s.collapses)},
          {"unmatched_particle_scans", static_cast<double>(s.unmatched)},
          {"grid_bytes_per_particle", distinct / n},
          {"grid_bytes_unshared_per_particle", static_cast<double>(s.particles.front().map.bytes())}};
}

}  // namespace slamkit
