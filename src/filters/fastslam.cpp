#include "slamkit/filters/fastslam.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <thread>
#include <unordered_set>

#include "fastslam_impl.hpp"
#include "slamkit/core/angles.hpp"
#include "slamkit/core/random_draws.hpp"

namespace slamkit {

using namespace fastslam_detail;

namespace {

// Work per task below which handing work to another thread costs more than it saves (a wake-up and
// a join are some microseconds): a prediction is well under a microsecond per particle, a scan
// update some microseconds.
constexpr std::size_t kPredictGrain = 256;
constexpr std::size_t kUpdateGrain = 4;

// The candidate grid drops its stale entries around the vehicle this often [scans]; they cost only
// filtering in the meantime.
constexpr std::size_t kGridPruneScans = 5;

/// The first of `origins` (pairs of id and origin, sorted by id) whose id is not below `id`.
template <class Origins>
auto origin_lower_bound(Origins& origins, int id) {
  return std::lower_bound(origins.begin(), origins.end(), id, [](const auto& entry, int key) { return entry.first < key; });
}

void validate(const FastSlamConfig& c) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("FastSLAM config: " + what); };
  if (c.version != 1 && c.version != 2) fail(fmt::format("version must be 1 or 2, found {}", c.version));
  if (c.particles < 1 || c.particles > FastSlamConfig::kMaxParticles)
    fail(fmt::format("particles must be from 1 to {}, found {}", FastSlamConfig::kMaxParticles, c.particles));
  if (!(c.pose_sample_fraction > 0.0 && c.pose_sample_fraction <= 1.0))
    fail(fmt::format("the pose sample fraction must lie in (0, 1], found {}", c.pose_sample_fraction));
  if (c.threads > FastSlamConfig::kMaxThreads)
    fail(fmt::format("threads must be from 0 (all cores) to {}, found {}", FastSlamConfig::kMaxThreads, c.threads));
  if (c.policy.kind == ResamplePolicy::Kind::kEvery && c.policy.every < 1)
    fail(fmt::format("resampling every K scans needs K >= 1, found {}", c.policy.every));
  if (c.policy.kind == ResamplePolicy::Kind::kEss && !(c.policy.ess_fraction > 0.0 && c.policy.ess_fraction <= 1.0))
    fail(fmt::format("the ESS fraction must lie in (0, 1], found {}", c.policy.ess_fraction));
  validate(c.association);
  validate(c.sensor);
  if (!c.initial_pose.allFinite()) fail("the initial pose must be finite");
  validate(c.likelihood);
}

unsigned thread_count(unsigned requested) {
  return requested > 0 ? requested : std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace

FastSlam::Impl::Impl(std::shared_ptr<const MotionModel> motion_model,
                     std::shared_ptr<const ObservationModel> observation_model, const FastSlamConfig& cfg)
    : config((validate(cfg), cfg)),
      pool(thread_count(cfg.threads)),
      map_nodes(pool),
      link_nodes(pool),
      path_nodes(pool),
      motion(std::move(motion_model)),
      observation(observation_model ? std::move(observation_model)
                                    : throw std::invalid_argument("FastSLAM needs a motion and an observation model")),
      gates(Gates::from(cfg.association, observation->dim())),
      gate_known(cfg.association.gate_known.value_or(false)),
      association_view(slamkit::association_view(cfg.sensor, cfg.association)),
      clutter_density(slamkit::clutter_density(cfg.association, cfg.sensor, *observation)),
      existence(cfg.association, cfg.sensor),
      pending(cfg.association, cfg.sensor, *observation),
      particles(static_cast<std::size_t>(cfg.particles), Particle{}, cfg.resample, cfg.policy, cfg.seed),
      grid(std::max(5.0, 0.5 * cfg.sensor.max_range)),
      relocalise_association(cfg.association) {
  if (!motion) throw std::invalid_argument("FastSLAM needs a motion and an observation model");
  require_searchable(config.association, *observation);
  // The search for pairings, relocalisation's drift in measurement space and its view test read a
  // measurement's range and bearing.
  if (!known() && (observation->dim() != 2 || observation->rows().range < 0 || observation->rows().bearing < 0))
    throw std::invalid_argument("FastSLAM's search for pairings reads range and bearing; a " + observation->name() +
                                " sensor needs association 'known'");
  dead_reckoning.pose = config.initial_pose;
  range_row = observation->rows().range;
  // Only the delayed start gives a landmark its gain in the calibration, so it is the default there.
  std::optional<LandmarkInitialisation> start = config.initialisation;
  if (calibrating()) {
    validate(*config.range_calibration, *observation);
    if (config.version != 2 || !known())
      throw std::invalid_argument("a range calibration is estimated by FastSLAM 2.0's proposal with association "
                                  "'known': FastSLAM 1.0 proposes from the motion alone, and nn predicts measurements "
                                  "without it");
    if (start == LandmarkInitialisation::kImmediate)
      throw std::invalid_argument("FastSLAM starts a landmark that moves with the range calibration through the "
                                  "delayed start; with --range-calibration use --landmark-init delayed");
    start = start.value_or(LandmarkInitialisation::kDelayed);
  }
  const DelayedInitialisationOptions delayed =
      expecting_outliers_of(config.delayed_initialisation, config.likelihood, *observation);
  initialiser = make_landmark_initialiser(start, observation, known(), calibrating(), delayed, config.ring_initialisation);
  relocalise_association.method = AssociationMethod::kJcbb;
  const double detection = config.association.detection_probability;
  const double accept = config.association.accept_probability;
  duplicate_log_ratio = -std::log(2.0 * (1.0 - detection));
  duplicate_log_odds_bar = std::log(accept / (1.0 - accept));
  with_measurement_dim(observation->dim(), [&]<int D>(std::integral_constant<int, D>) {
    MeasurementKernels<D>& k = kernels.get<D>();
    k.model = observation.get();
    k.r = observation->noise();
    MeasurementSquare<D> unused;
    double log_det_2r = 0.0;
    if (!invert_spd(MeasurementSquare<D>(2.0 * k.r), unused, log_det_2r))
      throw std::invalid_argument("FastSLAM needs a positive definite measurement noise R");
    // A new landmark's likelihood: that of an innovation on the new-landmark gate of a landmark seen
    // once (S = 2R).
    log_p0 = -0.5 * gates.new_landmark - kLogGaussianConstant<D> - 0.5 * log_det_2r;
  });

  const std::size_t n = particles.size();
  for (Particle& p : particles) {
    p.map = LandmarkTree(&map_nodes);
    p.pose = config.initial_pose;
    p.pose[2] = wrap_angle(p.pose[2]);
    if (const std::optional<RangeCalibrationPrior>& prior = config.range_calibration) {
      p.links = CalibrationLinks(&link_nodes);
      p.calibration = Vector2(prior->offset_m, prior->scale_error);
      p.calibration_cov = Vector2(prior->offset_std_m * prior->offset_std_m,
                                  prior->scale_error_std * prior->scale_error_std).asDiagonal();
    }
  }
  slots.resize(n);
  log_likelihoods.resize(n);
}

void FastSlam::Impl::start(double t) {
  if (!keep_paths || !particles.front().path.empty()) return;
  const ParticlePath root(path_nodes, t, particles.front().pose);
  for (Particle& p : particles) p.path = root;
}

void FastSlam::Impl::predict_particle(std::size_t i, const ControlEvent& c) {
  Particle& p = particles[i];
  if (config.version == 1) {
    const Control u = motion->sample_control(c.u, c.dt, particles.stream(i));
    p.pose = motion->predict(p.pose, u, c.dt);
  } else {
    const Matrix3 f = motion->jacobian_state(p.pose, c.u, c.dt);
    p.pose_cov = symmetric(f * p.pose_cov * f.transpose() + motion->process_noise(p.pose, c.u, c.dt));
    p.pose = motion->predict(p.pose, c.u, c.dt);
  }
  if (keep_paths) p.path.extend(c.t, p.pose);
}

void FastSlam::Impl::plan_known_association(const ScanEvent& scan, std::size_t scan_index) {
  // Known identities make every particle's decisions the same, and so its map indices.
  auto next_index = static_cast<std::uint32_t>(particles.front().map.size());
  make_room(known_plan, scan.observations.size());
  known_plan.assign(scan.observations.size(), Pairing{});
  if (initialiser) {
    make_room(placements, scan.observations.size());
    placements.resize(scan.observations.size());
    if (calibrating()) placement_calibration = mean_calibration();
  }
  for (std::size_t k = 0; k < scan.observations.size(); ++k) {
    const int id = scan.observations[k].id;
    if (!valid[k] || id == kUnknownId) continue;
    if (const auto it = known_index.find(id); it != known_index.end()) {
      known_plan[k] = {AssociationDecision::kUpdate, it->second};
      continue;
    }
    if (initialiser) {
      std::optional<InitialLandmark> placed =
          initialiser->offer(id, dead_reckoning.pose, dead_reckoning.covariance, scan.observations[k].z, scan.t,
                             RangeCorrection{placement_calibration[0], placement_calibration[1]});
      if (!placed) {
        known_plan[k] = {AssociationDecision::kPending, 0};
        ++observations_waiting;
        continue;
      }
      placements[k] = *placed;
    }
    known_index.emplace(id, next_index);
    known_plan[k] = {AssociationDecision::kNew, next_index++};
    set_origin(id, {scan_index, k});
  }
}

Vector2 FastSlam::Impl::mean_calibration() const {
  Vector2 mean = Vector2::Zero();
  for (std::size_t i = 0; i < particles.size(); ++i) mean += particles.weights()[i] * particles[i].calibration;
  return mean;
}

namespace {
void sort_unique(std::vector<std::uint32_t>& v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
}
}  // namespace

void FastSlam::Impl::gather_candidates() {
  const Pose2 centre_pose = particles.mean_pose();
  double spread = 0.0;
  for (const Particle& p : particles) spread = std::max(spread, (p.pose.head<2>() - centre_pose.head<2>()).norm());
  // The sensor may be mounted off the pose origin: a particle's
  // sensor lies within spread + 2 * offset of this one (position difference plus the offset turned
  // by any heading difference), and the grid lists every landmark version at its current mean.
  const Vector2 sensor = observation->sensor_position(centre_pose);
  const double radius = association_view.reach() + spread + 2.0 * (sensor - centre_pose.head<2>()).norm();
  // Each landmark once, in index order: a particle's candidates stop at the first index beyond its map.
  grid.query(sensor, radius, scan_candidates);
  sort_unique(scan_candidates);
  if (!relocalising()) return;
  // Relocalisation looks at the landmarks mapped since the window's first scan, which lie within the
  // sensor's reach of some pose since, and at those mapped before it that some particle's drift
  // (drift_of, which is largest relative to the first scan) can have carried there.
  double travelled = 0.0;
  for (std::size_t k = window_start; k < scan_positions.size(); ++k)
    travelled = std::max(travelled, (scan_positions[k] - centre_pose.head<2>()).norm());
  double largest = 0.0;  // a bound of the position drift's largest eigenvalue: the trace
  for (const Particle& p : particles) largest = std::max(largest, drift_of(p, 0).topLeftCorner<2, 2>().trace());
  const double drift_reach = std::sqrt(gates.new_landmark * largest);
  // Room for every entry: the drift, and with it the square, can grow at any time.
  make_room(relocalise_candidates, grid.max_entries());
  grid.list(sensor, radius + std::max(travelled, drift_reach), relocalise_candidates);
  sort_unique(relocalise_candidates);
}

void FastSlam::Impl::decide_new_landmarks(const ScanEvent& scan) {
  const std::size_t n_obs = scan.observations.size();
  make_room(start_detections, n_obs);
  start_detections.assign(n_obs, 1);
  pending.begin_scan(scan.t, particles.best_particle().pose);
  const auto started = static_cast<std::size_t>(next_id - first_started_id);
  for (std::size_t k = 0; k < n_obs; ++k) {
    double weight_new = 0.0;
    for (std::size_t i = 0; i < particles.size(); ++i)
      if (slots[i].pairings[k].decision == AssociationDecision::kNew) weight_new += particles.weights()[i];
    // Explained by the particles that hold most of the weight: those that see a new landmark in it
    // are off, and start it as they would anyway.
    if (weight_new <= 0.5) continue;
    start_detections[k] = pending.offer(scan.observations[k].z, *observation, started, scans - 1);
    if (start_detections[k] == 0) ++pending_observations;
  }
  pending.end_scan(*observation, existence.detection_view());
  // The observations that wait are discarded by every particle, and the new landmarks' indices follow.
  for (std::size_t i = 0; i < particles.size(); ++i) {
    auto next_index = static_cast<std::uint32_t>(particles[i].map.size());
    for (std::size_t k = 0; k < n_obs; ++k) {
      Pairing& pairing = slots[i].pairings[k];
      if (pairing.decision != AssociationDecision::kNew) continue;
      if (start_detections[k] == 0)
        pairing = Pairing{};
      else
        pairing.index = next_index++;
    }
  }
}

void FastSlam::Impl::assign_new_ids(std::size_t observations, std::size_t scan_index) {
  make_room(new_ids, observations);
  new_ids.assign(observations, kUnknownId);
  for (const Slot& s : slots)
    for (std::size_t k = 0; k < observations; ++k)
      if (s.pairings[k].decision == AssociationDecision::kNew) new_ids[k] = 0;
  for (std::size_t k = 0; k < observations; ++k) {
    if (new_ids[k] == kUnknownId) continue;
    new_ids[k] = next_id++;
    set_origin(new_ids[k], {scan_index, k});
  }
  for (std::size_t i = 0; i < particles.size(); ++i)
    for (std::size_t k = 0; k < observations; ++k)
      if (slots[i].pairings[k].decision == AssociationDecision::kNew)
        particles[i].map.mutate(slots[i].pairings[k].index).id = new_ids[k];
}

void FastSlam::Impl::record_associations(std::size_t slot, const ScanEvent& scan) {
  const std::vector<Pairing>& pairings = slots[slot].pairings;
  make_room(last_records, pairings.size());
  last_records.assign(pairings.size(), AssociationRecord{});
  for (std::size_t k = 0; k < pairings.size(); ++k)
    if (pairings[k].decision == AssociationDecision::kPending)
      last_records[k] = {AssociationDecision::kPending, scan.observations[k].id};
    else if (pairings[k].decision != AssociationDecision::kDiscard)
      last_records[k] = {pairings[k].decision, particles[slot].map[pairings[k].index].id};
}

void FastSlam::Impl::reweight_and_resample(const ScanEvent& scan) {
  particles.weigh(log_likelihoods);
  record_associations(particles.best(), scan);
  if (slots[particles.best()].relocalised) ++relocalisations;
  duplicates_fused += slots[particles.best()].fused_now;
  particles.resample_if_due();
}

void FastSlam::Impl::index_grid_entries() {
  for (const Slot& s : slots)
    for (const auto& [mean, index] : s.grid_entries) grid.insert(grid.cell_of(mean), index);
}

void FastSlam::Impl::prune_grid() {
  // An entry is needed while some particle's live version of the landmark has its mean in the cell.
  grid.prune([&](LandmarkGrid::Cell cell, std::uint32_t index) {
    return std::any_of(particles.begin(), particles.end(), [&](const Particle& p) {
      if (index >= p.map.size()) return false;
      const LandmarkGaussian& lm = p.map[index];
      return !lm.removed && grid.cell_of(lm.mean) == cell;
    });
  });
  scans_since_prune = 0;
}

void FastSlam::Impl::set_origin(int id, const LandmarkOrigin& origin) {
  const auto it = origin_lower_bound(origins, id);
  if (it != origins.end() && it->first == id)
    it->second = origin;
  else
    origins.insert(it, {id, origin});
}

// ---- Public interface ----------------------------------------------------------------------------

FastSlam::FastSlam(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
                   const FastSlamConfig& config)
    : impl_(std::make_unique<Impl>(std::move(motion), std::move(observation), config)) {}

FastSlam::~FastSlam() = default;

std::string FastSlam::name() const { return impl_->config.version == 1 ? "fastslam1" : "fastslam2"; }

void FastSlam::reserve(std::size_t steps, std::size_t landmarks) {
  Impl& s = *impl_;
  if (s.keep_paths) s.path_nodes.reserve(steps);
  s.origins.reserve(s.origins.size() + landmarks);
  if (s.relocalising()) {
    s.drift_at_scan.reserve(s.drift_at_scan.size() + steps);
    s.scan_times.reserve(s.scan_times.size() + steps);
    s.scan_positions.reserve(s.scan_positions.size() + steps);
  }
}

double FastSlam::memory_estimate(std::size_t particles, std::size_t landmarks) {
  // Resampling leaves particles sharing the parts of their maps not changed since their common
  // ancestor: on the default world's route with maps of 100 and 1,000 landmarks, a particle held
  // about 40 bytes of its own per landmark, half a LandmarkGaussian. (A range calibration adds a
  // 48-byte link per landmark, left out: radios range to a few beacons.)
  constexpr double kOwnShare = 0.5;
  return static_cast<double>(particles) *
         (static_cast<double>(sizeof(Impl::Particle) + sizeof(Impl::Slot)) +
          kOwnShare * static_cast<double>(landmarks) * static_cast<double>(sizeof(LandmarkGaussian)));
}

const FastSlamConfig& FastSlam::config() const { return impl_->config; }

unsigned FastSlam::threads() const { return impl_->pool.size(); }

void FastSlam::predict(const ControlEvent& control) {
  Impl& s = *impl_;
  if (control.u.size() != s.motion->control_dim())
    throw std::invalid_argument(fmt::format("FastSLAM: a control of size {} for the {} motion model, which takes {}",
                                            control.u.size(), s.motion->name(), s.motion->control_dim()));
  s.start(control.t - control.dt);
  // The drift is followed along the best particle's path: the particles differ by metres over a
  // lap, which changes the lever arms of the drift little.
  const Matrix3 q = s.relocalising() ? s.motion->process_noise(s.particles.best_particle().pose, control.u, control.dt)
                                     : Matrix3::Zero();
  s.pool.run(s.particles.size(), kPredictGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) s.predict_particle(i, control);
  });
  if (s.initialiser) s.dead_reckoning.advance(*s.motion, control.u, control.dt);
  if (s.relocalising()) s.drift.add(q, s.particles.best_particle().pose.head<2>());
}

void FastSlam::update(const ScanEvent& scan) {
  Impl& s = *impl_;
  s.start(scan.t);
  const std::size_t scan_index = s.scans++;
  const std::size_t n_obs = scan.observations.size();
  make_room(s.valid, n_obs);
  s.valid.resize(n_obs);
  for (std::size_t k = 0; k < n_obs; ++k) s.valid[k] = scan.observations[k].z.allFinite();

  if (s.relocalising()) {
    s.drift_at_scan.push_back(s.drift);
    s.scan_times.push_back(scan.t);
    s.scan_positions.push_back(s.particles.best_particle().pose.head<2>());
    while (s.scan_times[s.window_start] < scan.t - s.config.association.relocalise_window_s) ++s.window_start;
  }
  if (s.known())
    s.plan_known_association(scan, scan_index);
  else
    s.gather_candidates();
  if (!s.known()) {
    s.pool.run(s.particles.size(), kUpdateGrain, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) s.associate(s.particles[i], s.slots[i], scan);
    });
    if (s.pending.active()) s.decide_new_landmarks(scan);
  }
  with_measurement_dim(s.observation->dim(), [&]<int D>(std::integral_constant<int, D>) {
    s.pool.run(s.particles.size(), kUpdateGrain, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) s.update_particle<D>(i, scan);
    });
  });
  if (!s.known()) {
    s.assign_new_ids(n_obs, scan_index);
    s.index_grid_entries();
  } else if (s.gate_known) {
    std::size_t judged = 0, rejected = 0;
    for (const Impl::Slot& slot : s.slots) {
      judged += slot.gate_judged;
      rejected += slot.gate_rejected;
    }
    s.gate_tally.add_scan(scan.t, judged, rejected);
  }
  s.reweight_and_resample(scan);
  if (!s.known() && ++s.scans_since_prune >= kGridPruneScans) s.prune_grid();
}

Pose2 FastSlam::pose() const { return impl_->particles.mean_pose(); }

Matrix3 FastSlam::pose_covariance() const { return impl_->particles.pose_covariance(); }

std::size_t FastSlam::num_landmarks() const {
  std::size_t n = 0;
  impl_->best_particle().map.for_each([&](std::size_t, const LandmarkGaussian& lm) { n += lm.removed ? 0 : 1; });
  return n;
}

// Confirmed landmarks only, as the EKF reports them: a provisional one may still be clutter. With a
// range calibration, each at the particle's calibration, with that calibration's uncertainty.
std::vector<Landmark> FastSlam::landmarks() const {
  const Impl& s = *impl_;
  const Impl::Particle& p = s.best_particle();
  std::vector<Landmark> out;
  p.map.for_each([&](std::size_t index, const LandmarkGaussian& lm) {
    if (lm.removed || !s.existence.confirmed(lm.existence)) return;
    if (!s.calibrating()) {
      out.push_back({lm.id, lm.mean, lm.covariance});
      return;
    }
    const Matrix2& gain = p.links[index].gain;
    out.push_back({lm.id, s.mean_at(p, static_cast<std::uint32_t>(index), p.calibration),
                   symmetric(lm.covariance + gain * p.calibration_cov * gain.transpose())});
  });
  return out;
}

const std::vector<AssociationRecord>& FastSlam::last_associations() const { return impl_->last_records; }

std::vector<StampedPose> FastSlam::smoothed_trajectory() const { return impl_->best_particle().path.poses(); }

void FastSlam::forget_smoothed_trajectory() {
  impl_->keep_paths = false;
  for (Impl::Particle& p : impl_->particles) p.path = ParticlePath();
}

std::vector<WeightedPose> FastSlam::pose_samples() const { return impl_->particles.pose_samples(); }

std::vector<LandmarkHypothesis> FastSlam::landmark_hypotheses() const {
  const Impl& s = *impl_;
  return s.initialiser ? hypotheses_at(*s.initialiser, s.dead_reckoning, pose()) : std::vector<LandmarkHypothesis>{};
}

std::map<std::string, double> FastSlam::statistics() const {
  const Impl& s = *impl_;
  std::size_t provisional = 0;
  s.best_particle().map.for_each([&](std::size_t, const LandmarkGaussian& lm) {
    provisional += !lm.removed && !s.existence.confirmed(lm.existence) ? 1 : 0;
  });
  std::size_t searches = 0;
  for (const Impl::Slot& slot : s.slots) searches += slot.relocalisation_searches;
  std::map<std::string, double> statistics = {
      {"landmarks_provisional", static_cast<double>(provisional)},
      {"relocalisations", static_cast<double>(s.relocalisations)},
      {"duplicates_fused", static_cast<double>(s.duplicates_fused)},
      {"relocalisation_searches", static_cast<double>(searches)}};
  s.particles.add_statistics(statistics);
  if (!s.known() && s.pending.active()) {
    statistics["observations_pending"] = static_cast<double>(s.pending_observations);
    statistics["landmarks_pending"] = static_cast<double>(s.pending.size());
  }
  if (s.initialiser) {
    statistics["observations_pending"] = static_cast<double>(s.observations_waiting);
    statistics["landmarks_pending"] = static_cast<double>(s.initialiser->waiting());
  }
  if (s.calibrating()) {
    // The mixture of the particles' Gaussians: their weighted covariance plus their means' spread.
    const Vector2 mean = s.mean_calibration();
    Matrix2 cov = Matrix2::Zero();
    for (std::size_t i = 0; i < s.particles.size(); ++i) {
      const Vector2 d = s.particles[i].calibration - mean;
      cov += s.particles.weights()[i] * (s.particles[i].calibration_cov + d * d.transpose());
    }
    statistics["range_offset_m"] = mean[0];
    statistics["range_offset_std_m"] = std::sqrt(cov(0, 0));
    statistics["range_scale_error"] = mean[1];
    statistics["range_scale_error_std"] = std::sqrt(cov(1, 1));
  }
  // Summed over the particles: each judges its own landmarks.
  if (s.known() && s.gate_known) s.gate_tally.add_statistics(statistics);
  if (s.config.association.method == AssociationMethod::kJcbb) {
    AssociationStats jcbb;
    for (const Impl::Slot& slot : s.slots) {
      jcbb.jcbb_nodes += slot.association_stats.jcbb_nodes;
      jcbb.jcbb_budget_exhausted = jcbb.jcbb_budget_exhausted || slot.association_stats.jcbb_budget_exhausted;
    }
    statistics["jcbb_nodes"] = static_cast<double>(jcbb.jcbb_nodes);
    statistics["jcbb_budget_exhausted"] = jcbb.jcbb_budget_exhausted ? 1.0 : 0.0;
  }
  return statistics;
}

void FastSlam::set_initial_map(const std::vector<Landmark>& map) {
  Impl& s = *impl_;
  if (s.scans > 0) throw std::logic_error("FastSLAM: set_initial_map after the first update");
  std::unordered_set<int> ids;
  LandmarkTree tree(&s.map_nodes);
  s.known_index.clear();
  s.next_id = 0;
  for (const Landmark& lm : map) {
    if (lm.id == kUnknownId || !ids.insert(lm.id).second)
      throw std::invalid_argument(fmt::format("FastSLAM: initial map landmark id {} is unknown or repeated", lm.id));
    LandmarkGaussian g;
    g.mean = lm.position;
    g.covariance = lm.covariance;
    g.id = lm.id;
    g.existence = s.existence.given();
    s.known_index[lm.id] = static_cast<std::uint32_t>(tree.size());
    s.next_id = std::max(s.next_id, lm.id + 1);
    if (!s.known()) s.grid.insert(s.grid.cell_of(g.mean), static_cast<std::uint32_t>(tree.size()));
    tree.push_back(g);
  }
  s.first_started_id = s.next_id;
  // A given landmark does not move with the range calibration.
  CalibrationLinks links(&s.link_nodes);
  if (s.calibrating())
    for (std::size_t i = 0; i < tree.size(); ++i) links.push_back({Matrix2::Zero(), s.particles.front().calibration});
  for (Impl::Particle& p : s.particles) {
    p.map = tree;
    p.links = links;
  }
}

std::optional<LandmarkOrigin> FastSlam::landmark_origin(int id) const {
  const auto& origins = impl_->origins;
  const auto it = origin_lower_bound(origins, id);
  if (it == origins.end() || it->first != id) return std::nullopt;
  return it->second;
}

}  // namespace slamkit
