#include "slamkit/filters/fastslam.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <thread>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

#include "slamkit/assoc/association.hpp"
#include "slamkit/assoc/landmark_existence.hpp"
#include "slamkit/assoc/landmark_grid.hpp"
#include "slamkit/assoc/sensor_view.hpp"
#include "slamkit/core/angles.hpp"
#include "slamkit/filters/landmark_tree.hpp"
#include "slamkit/filters/particle_path.hpp"
#include "slamkit/filters/worker_pool.hpp"

namespace slamkit {

namespace {

constexpr double kLog2Pi = 1.8378770664093454836;
constexpr double kMinusInf = -std::numeric_limits<double>::infinity();

// Work per task below which handing work to another thread costs more than it saves (a wake-up and
// a join are some microseconds): a prediction is well under a microsecond per particle, a scan
// update some microseconds.
constexpr std::size_t kPredictGrain = 256;
constexpr std::size_t kUpdateGrain = 4;

// The candidate grid drops its stale entries around the vehicle this often [scans]; they cost only
// filtering in the meantime.
constexpr std::size_t kGridPruneScans = 5;

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Inverse and log-determinant of a 2x2 covariance; false if it is not positive definite.
bool invert_spd(const Matrix2& s, Matrix2& inverse, double& log_det) {
  const double det = s(0, 0) * s(1, 1) - s(0, 1) * s(1, 0);
  if (!(det > 0.0) || !(s(0, 0) > 0.0) || !std::isfinite(det)) return false;
  inverse << s(1, 1), -s(0, 1), -s(1, 0), s(0, 0);
  inverse /= det;
  log_det = std::log(det);
  return true;
}

/// The symmetric part of a covariance expression: rounding breaks symmetry, and a 2x2 inverse and
/// an LDLT read both triangles.
template <class Derived>
typename Derived::PlainObject symmetric(const Eigen::MatrixBase<Derived>& expression) {
  const typename Derived::PlainObject m = expression;
  return 0.5 * (m + m.transpose());
}

/// A draw from N(mean, cov) for a positive semi-definite cov: the motion noise of a two-entry
/// control makes a rank-2 pose covariance, which LDLT factors where LLT would fail.
Pose2 sample_gaussian(const Pose2& mean, const Matrix3& cov, std::mt19937_64& rng) {
  const Eigen::LDLT<Matrix3> ldlt(cov);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector3d e;
  for (int i = 0; i < 3; ++i) e[i] = normal(rng);
  const Eigen::Vector3d scaled = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt().cwiseProduct(e);
  const Eigen::Vector3d correlated = ldlt.matrixL() * scaled;
  Pose2 x = mean + ldlt.transpositionsP().transpose() * correlated;
  x[2] = wrap_angle(x[2]);
  return x;
}

/// Makes sure a scratch vector can take n elements, growing it to twice that when it must grow:
/// a scan a little busier than any before then does not allocate again.
template <class T>
void make_room(std::vector<T>& v, std::size_t n) {
  if (v.capacity() < n) v.reserve(2 * n);
}

/// The first of `origins` (pairs of id and origin, sorted by id) whose id is not below `id`.
template <class Origins>
auto origin_lower_bound(Origins& origins, int id) {
  return std::lower_bound(origins.begin(), origins.end(), id, [](const auto& entry, int key) { return entry.first < key; });
}

}  // namespace

// ---- Filter state --------------------------------------------------------------------------------

struct FastSlam::Impl {
  struct Particle {
    Pose2 pose = Pose2::Zero();  // FastSLAM 2.0 between scans: the mean of the motion prediction
    Matrix3 pose_cov = Matrix3::Zero();  // FastSLAM 2.0: prediction covariance since the last scan
    double log_weight = 0.0;             // log of the normalised weight
    LandmarkTree map;
    ParticlePath path;
  };

  /// What one particle does with one observation; `index` is in that particle's map.
  struct Pairing {
    AssociationDecision decision = AssociationDecision::kDiscard;
    std::uint32_t index = 0;
  };

  /// A landmark in view of a particle, with what gating needs, computed once per scan.
  struct Candidate {
    std::uint32_t index;
    Vector2 zhat;
    Matrix2 s_inverse;
    bool taken = false;  // paired with an observation of this scan
  };

  /// Per particle slot (not per particle: resampling moves particles, slots stay): the random
  /// stream and the scratch of a scan update.
  struct Slot {
    std::mt19937_64 rng;
    std::vector<Pairing> pairings;
    std::vector<Candidate> candidates;
    std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> pairs;  // d2, observation, candidate
    std::vector<double> min_d2;
    std::vector<std::uint32_t> observed;
    // (mean, index) of each landmark this scan created or moved into another grid cell.
    std::vector<std::pair<Vector2, std::uint32_t>> grid_entries;
    double log_likelihood = 0.0;
  };

  Impl(std::shared_ptr<const MotionModel> motion_model, std::shared_ptr<const ObservationModel> observation_model,
       const FastSlamConfig& cfg);

  bool known() const { return config.association.method == AssociationMethod::kKnown; }

  void start(double t);
  void predict_particle(std::size_t i, const ControlEvent& control);
  void plan_known_association(const ScanEvent& scan, std::size_t scan_index);
  void gather_candidates();
  void associate(const Particle& p, Slot& s, const ScanEvent& scan) const;
  void reject_known_outliers(const Particle& p, Slot& s, const ScanEvent& scan) const;
  /// The covariance of the innovation of landmark lm as particle p predicts it, and the Jacobians.
  Matrix2 innovation_covariance(const Particle& p, const LandmarkGaussian& lm, Matrix23& hx, Matrix2& hm) const;
  /// Whether z lies beyond the new-landmark gate of landmark lm as particle p predicts it.
  bool beyond_gate(const Particle& p, const LandmarkGaussian& lm, const Vector2& z) const;
  void update_particle(std::size_t i, const ScanEvent& scan);
  double update_landmark(LandmarkGaussian& lm, const Pose2& x, const Vector2& z) const;
  LandmarkGaussian new_landmark(const Pose2& x, const Vector2& z, int id) const;
  void count_misses(Particle& p, Slot& s) const;
  void assign_new_ids(std::size_t observations, std::size_t scan_index);
  void record_associations(std::size_t slot);
  void reweight_and_resample();
  void index_grid_entries();
  void prune_grid();
  void set_origin(int id, const LandmarkOrigin& origin);
  const Particle& best_particle() const { return particles[best]; }

  FastSlamConfig config;
  // The threads first: the node storage serves them. The node storage next: it must outlive every
  // map and path, i.e. the particles.
  WorkerPool pool;
  LandmarkTree::NodeStorage map_nodes;
  ParticlePath::NodeStorage path_nodes;
  std::shared_ptr<const MotionModel> motion;
  std::shared_ptr<const ObservationModel> observation;
  Matrix2 r;
  Gates gates;
  bool gate_known;
  SensorView association_view;
  ExistenceRule existence;
  double log_p0 = 0.0;

  std::vector<Particle> particles;
  std::vector<Slot> slots;
  std::vector<double> weights;
  std::vector<double> log_weights;  // scratch of reweighting
  std::mt19937_64 resample_rng;
  // Scratch of resampling; next_particles is empty between scans (its elements would hold
  // references that make every node look shared) but keeps its capacity.
  ResampleScratch resample_scratch;
  std::vector<std::size_t> parents;
  std::vector<Particle> next_particles;
  std::size_t best = 0;

  std::vector<char> valid;  // per observation of the current scan: finite measurement
  std::vector<Pairing> known_plan;
  std::unordered_map<int, std::uint32_t> known_index;
  LandmarkGrid grid;
  std::size_t scans_since_prune = 0;
  std::vector<std::uint32_t> scan_candidates;

  int next_id = 0;
  std::vector<int> new_ids;  // per observation of the current scan
  // Sorted by id. Ids made by update() increase, so they are appended; a vector rather than a hash
  // map, so that a new id costs an allocation only when the capacity doubles (or not after reserve).
  std::vector<std::pair<int, LandmarkOrigin>> origins;
  std::vector<AssociationRecord> last_records;

  std::size_t scans = 0;
  std::size_t resamples = 0;
  std::size_t collapses = 0;
  double ess_sum = 0.0;
};

namespace {

void validate(const FastSlamConfig& c) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("FastSLAM config: " + what); };
  if (c.version != 1 && c.version != 2) fail(fmt::format("version must be 1 or 2, found {}", c.version));
  if (c.particles < 1) fail(fmt::format("particles must be >= 1, found {}", c.particles));
  if (c.policy.kind == ResamplePolicy::Kind::kEvery && c.policy.every < 1)
    fail(fmt::format("resampling every K scans needs K >= 1, found {}", c.policy.every));
  if (c.policy.kind == ResamplePolicy::Kind::kEss && !(c.policy.ess_fraction > 0.0 && c.policy.ess_fraction <= 1.0))
    fail(fmt::format("the ESS fraction must lie in (0, 1], found {}", c.policy.ess_fraction));
  validate(c.association);
  validate(c.sensor);
  if (!c.initial_pose.allFinite()) fail("the initial pose must be finite");
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
      path_nodes(pool),
      motion(std::move(motion_model)),
      observation(std::move(observation_model)),
      gates(Gates::from(cfg.association)),
      gate_known(cfg.association.gate_known.value_or(false)),
      association_view(slamkit::association_view(cfg.sensor, cfg.association)),
      existence(cfg.association, cfg.sensor),
      resample_rng(splitmix64(cfg.seed ^ 0x526573616d706c65ULL)),
      grid(std::max(5.0, 0.5 * cfg.sensor.max_range)) {
  if (!motion || !observation) throw std::invalid_argument("FastSLAM needs a motion and an observation model");
  r = observation->noise();
  Matrix2 unused;
  double log_det_2r = 0.0;
  if (!invert_spd(2.0 * r, unused, log_det_2r))
    throw std::invalid_argument("FastSLAM needs a positive definite measurement noise R");
  log_p0 = -0.5 * gates.new_landmark - kLog2Pi - 0.5 * log_det_2r;

  const auto n = static_cast<std::size_t>(config.particles);
  particles.resize(n);
  next_particles.reserve(n);
  parents.reserve(n);
  for (Particle& p : particles) {
    p.map = LandmarkTree(&map_nodes);
    p.pose = config.initial_pose;
    p.pose[2] = wrap_angle(p.pose[2]);
    p.log_weight = -std::log(static_cast<double>(n));
  }
  slots.resize(n);
  for (std::size_t i = 0; i < n; ++i) slots[i].rng.seed(splitmix64(splitmix64(config.seed) ^ i));
  weights.assign(n, 1.0 / static_cast<double>(n));
}

void FastSlam::Impl::start(double t) {
  if (!particles.front().path.empty()) return;
  const ParticlePath root(path_nodes, t, particles.front().pose);
  for (Particle& p : particles) p.path = root;
}

void FastSlam::Impl::predict_particle(std::size_t i, const ControlEvent& c) {
  Particle& p = particles[i];
  if (config.version == 1) {
    const Control u = motion->sample_control(c.u, c.dt, slots[i].rng);
    p.pose = motion->predict(p.pose, u, c.dt);
  } else {
    const Matrix3 f = motion->jacobian_state(p.pose, c.u, c.dt);
    p.pose_cov = symmetric(f * p.pose_cov * f.transpose() + motion->process_noise(p.pose, c.u, c.dt));
    p.pose = motion->predict(p.pose, c.u, c.dt);
  }
  p.path.extend(c.t, p.pose);
}

void FastSlam::Impl::plan_known_association(const ScanEvent& scan, std::size_t scan_index) {
  // Known identities make every particle's decisions the same, and so its map indices.
  auto next_index = static_cast<std::uint32_t>(particles.front().map.size());
  make_room(known_plan, scan.observations.size());
  known_plan.assign(scan.observations.size(), Pairing{});
  for (std::size_t k = 0; k < scan.observations.size(); ++k) {
    const int id = scan.observations[k].id;
    if (!valid[k] || id == kUnknownId) continue;
    const auto [it, inserted] = known_index.try_emplace(id, next_index);
    if (inserted) {
      known_plan[k] = {AssociationDecision::kNew, next_index++};
      set_origin(id, {scan_index, k});
    } else {
      known_plan[k] = {AssociationDecision::kUpdate, it->second};
    }
  }
}

void FastSlam::Impl::gather_candidates() {
  const Pose2 centre_pose = [&] {
    Pose2 mean = Pose2::Zero();
    double s = 0.0, c = 0.0;
    for (std::size_t i = 0; i < particles.size(); ++i) {
      mean.head<2>() += weights[i] * particles[i].pose.head<2>();
      s += weights[i] * std::sin(particles[i].pose[2]);
      c += weights[i] * std::cos(particles[i].pose[2]);
    }
    mean[2] = std::atan2(s, c);
    return mean;
  }();
  double spread = 0.0;
  for (const Particle& p : particles) spread = std::max(spread, (p.pose.head<2>() - centre_pose.head<2>()).norm());
  // A zero measurement is the sensor itself, which may be mounted off the pose origin: a particle's
  // sensor lies within spread + 2 * offset of this one (position difference plus the offset turned
  // by any heading difference), and the grid lists every landmark version at its current mean.
  const Vector2 sensor = observation->inverse(centre_pose, Vector2::Zero());
  const double radius = association_view.reach() + spread + 2.0 * (sensor - centre_pose.head<2>()).norm();
  grid.query(sensor, radius, scan_candidates);
}

Matrix2 FastSlam::Impl::innovation_covariance(const Particle& p, const LandmarkGaussian& lm, Matrix23& hx,
                                              Matrix2& hm) const {
  // At the pose as predicted: for FastSLAM 2.0 its covariance enters S, as the proposal's
  // uncertainty should when judging whether an observation fits a landmark.
  observation->jacobians(p.pose, lm.mean, hx, hm);
  Matrix2 cov = hm * lm.covariance * hm.transpose() + r;
  if (config.version == 2) cov += hx * p.pose_cov * hx.transpose();
  return cov;
}

bool FastSlam::Impl::beyond_gate(const Particle& p, const LandmarkGaussian& lm, const Vector2& z) const {
  Matrix23 hx;
  Matrix2 hm;
  Matrix2 inverse;
  double log_det = 0.0;
  if (!invert_spd(symmetric(innovation_covariance(p, lm, hx, hm)), inverse, log_det)) return false;
  const Vector2 nu = observation->residual(z, observation->predict(p.pose, lm.mean));
  return nu.dot(inverse * nu) > gates.new_landmark;
}

void FastSlam::Impl::reject_known_outliers(const Particle& p, Slot& s, const ScanEvent& scan) const {
  for (std::size_t k = 0; k < s.pairings.size(); ++k) {
    const Pairing& pairing = s.pairings[k];
    if (pairing.decision == AssociationDecision::kUpdate && pairing.index < p.map.size() &&
        beyond_gate(p, p.map[pairing.index], scan.observations[k].z))
      s.pairings[k] = Pairing{};
  }
}

void FastSlam::Impl::associate(const Particle& p, Slot& s, const ScanEvent& scan) const {
  const std::size_t n_obs = scan.observations.size();
  s.candidates.clear();
  make_room(s.candidates, scan_candidates.size());
  for (const std::uint32_t index : scan_candidates) {
    if (index >= p.map.size()) break;
    const LandmarkGaussian& lm = p.map[index];
    if (lm.removed) continue;
    const Vector2 zhat = observation->predict(p.pose, lm.mean);
    if (!association_view.contains(zhat)) continue;
    Matrix23 hx;
    Matrix2 hm;
    Matrix2 inverse;
    double log_det = 0.0;
    if (invert_spd(symmetric(innovation_covariance(p, lm, hx, hm)), inverse, log_det))
      s.candidates.push_back({index, zhat, inverse});
  }

  s.pairs.clear();
  make_room(s.pairs, n_obs * s.candidates.size());
  make_room(s.min_d2, n_obs);
  s.min_d2.assign(n_obs, std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k < n_obs; ++k) {
    if (!valid[k]) continue;
    const Vector2& z = scan.observations[k].z;
    for (std::size_t c = 0; c < s.candidates.size(); ++c) {
      const Vector2 nu = observation->residual(z, s.candidates[c].zhat);
      const double d2 = nu.dot(s.candidates[c].s_inverse * nu);
      s.min_d2[k] = std::min(s.min_d2[k], d2);
      if (d2 < gates.accept) s.pairs.emplace_back(d2, static_cast<std::uint32_t>(k), static_cast<std::uint32_t>(c));
    }
  }
  // Greedy by distance: the most certain pairings first, each observation and landmark once.
  std::sort(s.pairs.begin(), s.pairs.end());
  make_room(s.pairings, n_obs);
  s.pairings.assign(n_obs, Pairing{});
  for (const auto& [d2, k, c] : s.pairs) {
    if (s.pairings[k].decision != AssociationDecision::kDiscard || s.candidates[c].taken) continue;
    s.candidates[c].taken = true;
    s.pairings[k] = {AssociationDecision::kUpdate, s.candidates[c].index};
  }
  auto next_index = static_cast<std::uint32_t>(p.map.size());
  for (std::size_t k = 0; k < n_obs; ++k)
    if (valid[k] && s.pairings[k].decision == AssociationDecision::kDiscard && s.min_d2[k] > gates.new_landmark)
      s.pairings[k] = {AssociationDecision::kNew, next_index++};
}

double FastSlam::Impl::update_landmark(LandmarkGaussian& lm, const Pose2& x, const Vector2& z) const {
  Matrix23 hx;
  Matrix2 hm;
  observation->jacobians(x, lm.mean, hx, hm);
  const Vector2 nu = observation->residual(z, observation->predict(x, lm.mean));
  const Matrix2 pht = lm.covariance * hm.transpose();
  Matrix2 s_inverse;
  double log_det = 0.0;
  if (!nu.allFinite() || !invert_spd(symmetric(hm * pht + r), s_inverse, log_det)) return kMinusInf;
  const Matrix2 gain = pht * s_inverse;
  lm.mean += gain * nu;
  // Joseph form: stays symmetric positive definite however the gain is rounded.
  const Matrix2 ikh = Matrix2::Identity() - gain * hm;
  lm.covariance = symmetric(ikh * lm.covariance * ikh.transpose() + gain * r * gain.transpose());
  existence.observed(lm.existence);
  return -0.5 * nu.dot(s_inverse * nu) - kLog2Pi - 0.5 * log_det;
}

LandmarkGaussian FastSlam::Impl::new_landmark(const Pose2& x, const Vector2& z, int id) const {
  Matrix23 gx;
  Matrix2 gz;
  observation->inverse_jacobians(x, z, gx, gz);
  LandmarkGaussian lm;
  lm.mean = observation->inverse(x, z);
  lm.covariance = symmetric(gz * r * gz.transpose());
  lm.id = id;
  lm.existence = known() ? existence.given() : existence.first_observed();
  return lm;
}

void FastSlam::Impl::update_particle(std::size_t i, const ScanEvent& scan) {
  Particle& p = particles[i];
  Slot& s = slots[i];
  const std::size_t n_obs = scan.observations.size();
  if (known()) {
    // Every particle starts from the common plan; the outlier gate is each particle's own.
    make_room(s.pairings, n_obs);
    s.pairings = known_plan;
    if (gate_known) reject_known_outliers(p, s, scan);
  } else {
    associate(p, s, scan);
  }
  s.grid_entries.clear();
  make_room(s.grid_entries, n_obs);
  // A landmark update at the particle's final pose; a landmark leaving its grid cell is listed in
  // the new one.
  auto update_at = [&](std::uint32_t index, const Vector2& z) {
    LandmarkGaussian& lm = p.map.mutate(index);
    if (known()) return update_landmark(lm, p.pose, z);
    const LandmarkGrid::Cell before = grid.cell_of(lm.mean);
    const double ll = update_landmark(lm, p.pose, z);
    if (grid.cell_of(lm.mean) != before) s.grid_entries.emplace_back(lm.mean, index);
    return ll;
  };
  std::vector<Pairing>& pairings = s.pairings;
  const std::size_t old_size = p.map.size();
  auto is_old_update = [&](std::size_t k) {
    return pairings[k].decision == AssociationDecision::kUpdate && pairings[k].index < old_size;
  };
  double log_likelihood = 0.0;

  if (config.version == 2) {
    // The proposal (eq. 18): the prediction refined by each paired observation in turn.
    Pose2 mu = p.pose;
    Matrix3 sigma = p.pose_cov;
    for (std::size_t k = 0; k < n_obs; ++k) {
      if (!is_old_update(k)) continue;
      const LandmarkGaussian& lm = p.map[pairings[k].index];
      Matrix23 hx;
      Matrix2 hm;
      observation->jacobians(mu, lm.mean, hx, hm);
      const Vector2 nu = observation->residual(scan.observations[k].z, observation->predict(mu, lm.mean));
      const Matrix2 z_cov = hm * lm.covariance * hm.transpose() + r;
      const Eigen::Matrix<double, 3, 2> sht = sigma * hx.transpose();
      Matrix2 s_inverse;
      double log_det = 0.0;
      if (!nu.allFinite() || !invert_spd(symmetric(hx * sht + z_cov), s_inverse, log_det)) {
        log_likelihood = kMinusInf;
        continue;
      }
      log_likelihood += -0.5 * nu.dot(s_inverse * nu) - kLog2Pi - 0.5 * log_det;
      const Eigen::Matrix<double, 3, 2> gain = sht * s_inverse;
      mu += gain * nu;
      mu[2] = wrap_angle(mu[2]);
      const Matrix3 ikh = Matrix3::Identity() - gain * hx;
      sigma = symmetric(ikh * sigma * ikh.transpose() + gain * z_cov * gain.transpose());
    }
    p.pose = sample_gaussian(mu, sigma, s.rng);
    p.pose_cov.setZero();
    p.path.replace_newest(p.pose);
  }

  // Landmark updates at the particle's final pose; for FastSLAM 1.0 they also give the weight.
  for (std::size_t k = 0; k < n_obs; ++k) {
    if (!is_old_update(k)) continue;
    const double ll = update_at(pairings[k].index, scan.observations[k].z);
    if (config.version == 1) log_likelihood += ll;
  }
  // New landmarks, and repeated observations of landmarks started in this scan, in scan order.
  for (std::size_t k = 0; k < n_obs; ++k) {
    Pairing& pairing = pairings[k];
    const Vector2& z = scan.observations[k].z;
    // A landmark started in this scan and seen again in it meets the outlier gate only now.
    if (known() && gate_known && pairing.decision == AssociationDecision::kUpdate && !is_old_update(k) &&
        beyond_gate(p, p.map[pairing.index], z))
      pairing = Pairing{};
    if (pairing.decision == AssociationDecision::kNew) {
      p.map.push_back(new_landmark(p.pose, z, known() ? scan.observations[k].id : kUnknownId));
      if (!known()) s.grid_entries.emplace_back(p.map[pairing.index].mean, pairing.index);
      log_likelihood += log_p0;
    } else if (pairing.decision == AssociationDecision::kDiscard) {
      log_likelihood += log_p0;
    } else if (!is_old_update(k)) {
      log_likelihood += update_at(pairing.index, z);
    }
  }
  if (!known()) count_misses(p, s);
  s.log_likelihood = log_likelihood;
}

void FastSlam::Impl::count_misses(Particle& p, Slot& s) const {
  s.observed.clear();
  make_room(s.observed, s.pairings.size());
  for (const Pairing& pairing : s.pairings)
    if (pairing.decision == AssociationDecision::kUpdate) s.observed.push_back(pairing.index);
  std::sort(s.observed.begin(), s.observed.end());
  // The candidates were chosen in the widened view of the predicted pose, so they include every
  // landmark the existence rule expects to be seen from the final pose.
  for (const Candidate& c : s.candidates) {
    if (std::binary_search(s.observed.begin(), s.observed.end(), c.index)) continue;
    if (!existence.detection_view().contains(observation->predict(p.pose, p.map[c.index].mean))) continue;
    LandmarkGaussian& lm = p.map.mutate(c.index);
    if (existence.missed(lm.existence)) lm.removed = true;
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

void FastSlam::Impl::record_associations(std::size_t slot) {
  const std::vector<Pairing>& pairings = slots[slot].pairings;
  make_room(last_records, pairings.size());
  last_records.assign(pairings.size(), AssociationRecord{});
  for (std::size_t k = 0; k < pairings.size(); ++k)
    if (pairings[k].decision != AssociationDecision::kDiscard)
      last_records[k] = {pairings[k].decision, particles[slot].map[pairings[k].index].id};
}

void FastSlam::Impl::reweight_and_resample() {
  const std::size_t n = particles.size();
  log_weights.resize(n);
  for (std::size_t i = 0; i < n; ++i) log_weights[i] = particles[i].log_weight + slots[i].log_likelihood;
  if (!normalize_log_weights(log_weights, weights)) ++collapses;
  const double ess = effective_sample_size(weights);
  ess_sum += ess;
  best = static_cast<std::size_t>(std::max_element(weights.begin(), weights.end()) - weights.begin());
  record_associations(best);

  if (config.policy.should_resample(scans, ess, n)) {
    resample(config.resample, weights, resample_rng, resample_scratch, parents);
    // Copies share the maps and paths: O(1) per particle however large the maps.
    for (const std::size_t parent : parents) next_particles.push_back(particles[parent]);
    // The best particle stays best: the first copy of the highest-weight parent drawn.
    std::size_t new_best = 0;
    for (std::size_t j = 1; j < n; ++j)
      if (weights[parents[j]] > weights[parents[new_best]]) new_best = j;
    best = new_best;
    particles.swap(next_particles);
    next_particles.clear();
    weights.assign(n, 1.0 / static_cast<double>(n));
    ++resamples;
  }
  for (std::size_t i = 0; i < n; ++i) particles[i].log_weight = std::log(weights[i]);
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
  impl_->path_nodes.reserve(steps);
  impl_->origins.reserve(impl_->origins.size() + landmarks);
}

const FastSlamConfig& FastSlam::config() const { return impl_->config; }

unsigned FastSlam::threads() const { return impl_->pool.size(); }

void FastSlam::predict(const ControlEvent& control) {
  Impl& s = *impl_;
  if (control.u.size() != s.motion->control_dim())
    throw std::invalid_argument(fmt::format("FastSLAM: a control of size {} for the {} motion model, which takes {}",
                                            control.u.size(), s.motion->name(), s.motion->control_dim()));
  s.start(control.t - control.dt);
  s.pool.run(s.particles.size(), kPredictGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) s.predict_particle(i, control);
  });
}

void FastSlam::update(const ScanEvent& scan) {
  Impl& s = *impl_;
  s.start(scan.t);
  const std::size_t scan_index = s.scans++;
  const std::size_t n_obs = scan.observations.size();
  make_room(s.valid, n_obs);
  s.valid.resize(n_obs);
  for (std::size_t k = 0; k < n_obs; ++k) s.valid[k] = scan.observations[k].z.allFinite();

  if (s.known())
    s.plan_known_association(scan, scan_index);
  else
    s.gather_candidates();
  s.pool.run(s.particles.size(), kUpdateGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) s.update_particle(i, scan);
  });
  if (!s.known()) {
    s.assign_new_ids(n_obs, scan_index);
    s.index_grid_entries();
  }
  s.reweight_and_resample();
  if (!s.known() && ++s.scans_since_prune >= kGridPruneScans) s.prune_grid();
}

Pose2 FastSlam::pose() const {
  const Impl& s = *impl_;
  Pose2 mean = Pose2::Zero();
  double sin_sum = 0.0, cos_sum = 0.0;
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    const Pose2& x = s.particles[i].pose;
    mean.head<2>() += s.weights[i] * x.head<2>();
    sin_sum += s.weights[i] * std::sin(x[2]);
    cos_sum += s.weights[i] * std::cos(x[2]);
  }
  mean[2] = std::atan2(sin_sum, cos_sum);
  return mean;
}

Matrix3 FastSlam::pose_covariance() const {
  const Impl& s = *impl_;
  const Pose2 mean = pose();
  Matrix3 cov = Matrix3::Zero();
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    Eigen::Vector3d d = s.particles[i].pose - mean;
    d[2] = wrap_angle(d[2]);
    cov += s.weights[i] * (d * d.transpose() + s.particles[i].pose_cov);
  }
  return cov;
}

std::size_t FastSlam::num_landmarks() const {
  std::size_t n = 0;
  impl_->best_particle().map.for_each([&](std::size_t, const LandmarkGaussian& lm) { n += lm.removed ? 0 : 1; });
  return n;
}

std::vector<Landmark> FastSlam::landmarks() const {
  std::vector<Landmark> out;
  impl_->best_particle().map.for_each([&](std::size_t, const LandmarkGaussian& lm) {
    if (!lm.removed) out.push_back({lm.id, lm.mean, lm.covariance});
  });
  return out;
}

const std::vector<AssociationRecord>& FastSlam::last_associations() const { return impl_->last_records; }

std::vector<StampedPose> FastSlam::smoothed_trajectory() const { return impl_->best_particle().path.poses(); }

std::vector<WeightedPose> FastSlam::pose_samples() const {
  const Impl& s = *impl_;
  std::vector<WeightedPose> out(s.particles.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {s.particles[i].pose, s.weights[i]};
  return out;
}

std::map<std::string, double> FastSlam::statistics() const {
  const Impl& s = *impl_;
  const auto n = static_cast<double>(s.particles.size());
  return {{"particles", n},
          {"ess_mean", s.scans > 0 ? s.ess_sum / static_cast<double>(s.scans) : n},
          {"resamples", static_cast<double>(s.resamples)},
          {"weight_collapses", static_cast<double>(s.collapses)}};
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
  for (Impl::Particle& p : s.particles) p.map = tree;
}

std::optional<LandmarkOrigin> FastSlam::landmark_origin(int id) const {
  const auto& origins = impl_->origins;
  const auto it = origin_lower_bound(origins, id);
  if (it == origins.end() || it->first != id) return std::nullopt;
  return it->second;
}

}  // namespace slamkit
