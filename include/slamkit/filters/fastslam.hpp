#pragma once
// FastSLAM 1.0 and 2.0: the Rao-Blackwellized particle filter of the tutorial's FastSLAM section
// (eqs. 12-18; Montemerlo et al. 2002 and 2003). Each particle is a sampled vehicle path with its own
// map of independent 2-D landmark Gaussians (eq. 12): given the path, landmarks are independent.
//
// FastSLAM 1.0 proposes from the motion model (eq. 16): each control step, every particle applies a
// control drawn with MotionModel::sample_control. A scan weights it by the marginal likelihood of
// its observations with the map integrated out (eqs. 15, 17): N(nu; 0, Hm P Hm^T + R) per paired
// observation, and updates the landmarks with 2-D EKFs.
//
// FastSLAM 2.0 proposes from the motion model AND the scan (eq. 18). Between scans a particle keeps
// a Gaussian of its pose, mean f(x, u) and covariance F S F^T + Fu M Fu^T accumulated over the
// controls since its last scan (S starts from what the last scan left, below); a scan refines that
// Gaussian with each paired observation in turn, relinearising at the current mean (the covariance
// form of Sigma = (Hx^T Z^-1 Hx + Sigma^-1)^-1, mu += Sigma Hx^T Z^-1 (z - zhat), Z = R + Hm P Hm^T:
// the same by the matrix inversion lemma, but it needs no inverse of the rank-deficient motion noise),
// and the particle's pose is drawn from the result, N(mu, f Sigma) with f = pose_sample_fraction;
// the particle keeps (1 - f) Sigma as its pose's covariance about the draw. f = 1 is the textbook
// filter. With f < 1 the Gaussian per particle carries the part of the pose uncertainty that
// sampling would turn into error: a particle maps its landmarks from its drawn pose, so what it draws
// it maps, and resampling soon leaves one lineage whose path is then one draw from the posterior, as
// far from the truth as that posterior is wide. Noise inflated to keep an EKF consistent
// (Victoria Park's: 2 m/s, 6 degrees of steering, 1 m, 3 degrees) makes it wide, and the drawn paths
// drift over 100 s of new ground by 5-25 m where the EKF's mean drifts by 2 m. The carried
// covariance enters the next proposal's prior (and so the gates and the weight), and a landmark
// update or a new landmark at the particle's pose x with covariance X adds Hx X Hx^T to R, or
// Gx X Gx^T to the new landmark's covariance (pose and map taken as independent, as between
// particles' landmarks). The weight is the proposal's normalising
// constant, p(z | x_{k-1}, m) = prod_j N(z_j - zhat_j; 0, Hx S_{j-1} Hx^T + Hm P Hm^T + R), where
// S_{j-1} is the pose covariance after the previous j-1 observations: for the first observation
// this is the standard FastSLAM 2.0 weight at the prediction, and taking the factors in sequence
// makes the product the exact (linearised) joint likelihood of the scan. The usual product of
// factors all evaluated at the prediction counts the shared pose uncertainty once per observation
// and so over-weights particles in scans with many observations.
//
// A range sensor's calibration (FastSlamConfig::range_calibration: an offset b and a scale error s,
// so that a range reads (1 + s) d + b for a distance d) is a parameter every observation shares, so
// it cannot be one of the map's independent Gaussians, and a landmark placed from ranges moves with
// it. Given the path, though, the landmarks are independent given the calibration c, so each
// particle keeps p(c | path) as a Gaussian and each landmark as a Gaussian given c whose mean moves
// linearly with c (a gain dm/dc beside the map, in a second tree of the map's shape): the joint is
// then exact in the linearisation, and an observation of one landmark changes only the
// calibration's Gaussian and that landmark's (a 4-dimensional update), as the others given c do not
// depend on it. FastSLAM 2.0's proposal runs over the pose and c, with the landmark given c
// marginalised (the range row's Jacobian in c is (1, d) plus Hm dm/dc); the pose is drawn from it and
// the landmark updates then refine c. A landmark the initialiser places starts with the gain the
// triangulation gives (InitialLandmark::range_gain). Given a particle's path the calibration is
// learnt as if that path were true, so after resampling has collapsed the paths its deviation is far
// too small (docs/sensing.md measures it).
//
// Measurements of any dimension the models have (range and bearing, range only, bearing only): a
// scan's particle updates run on types fixed at the model's dimension, chosen once per scan.
//
// New landmarks start from the particle's (sampled) pose with the inverse observation model:
// mean g(x, z), covariance Gz R Gz^T (plus the pose's, above). Where one measurement does not place
// a landmark (a range or a bearing alone), or FastSlamConfig::initialisation asks for it, the
// observations of a landmark not yet mapped wait in one LandmarkInitialiser for the whole filter
// (filters/landmark_initialiser.hpp: the delayed or the ring start), which works in dead reckoning's
// frame; every particle then starts the landmark it places where it lies relative to the particle's
// own pose, with the triangulation's covariance plus the pose's carried through. Observations that
// wait are recorded as pending. Every observation not paired with a
// landmark (new, pending or discarded) multiplies the weight by the constant p0, the likelihood of an
// innovation lying exactly on the new-landmark gate of a landmark observed once from its inverse
// (S = 2R, since Hm Gz = I): log p0 = -gate/2 - (dim/2) log(2 pi) - log(det(2R))/2. A particle thus
// gains by pairing an observation exactly when the pairing explains it better than a new landmark
// would, and particles that create landmarks are not favoured over particles that recognise them.
// (Where landmarks start through the initialiser, identities are known and every particle makes the
// same decisions, so p0 scales every weight alike.)
//
// Data association (AssociationConfig), decided per particle:
//   kKnown: the observation id names the landmark; an observation without an id is discarded, and
//     so is one beyond the new-landmark gate of its landmark in that particle when
//     AssociationConfig::gate_known is set (unset: not gated; the verdicts of all particles are
//     tallied, assoc/gate_tally.hpp). Identities are certain, so landmarks are confirmed at once and
//     never removed.
//   kNearestNeighbour, kJcbb: each particle runs the association the EKF family runs
//     (assoc/association.hpp), on its own belief: its pose, with Sigma, the predicted pose
//     covariance FastSLAM 2.0 carries (none for 1.0), and its landmarks, independent of the pose and
//     of each other given its path. So S = Hm P Hm^T + R (1.0) or plus Hx Sigma Hx^T (2.0), with the
//     same gates, pairing probability and new-landmark rule. For 1.0 the joint compatibility of a
//     hypothesis is then the sum of the individual distances; for 2.0 Sigma correlates the
//     observations of a scan, and JCBB finds the pairings that one pose error explains together.
//     Whether a landmark is provisional, confirmed or removed is decided per particle by the
//     ExistenceRule both filters share (assoc/landmark_existence.hpp); removal is a tombstone in the
//     particle's map.
//   Candidates come from a per-filter LandmarkGrid (assoc/landmark_grid.hpp) over every particle's
//   version of every landmark, kept up to date as the particles change their maps: a landmark is
//   listed in its cell when a particle creates it and again when an update moves it into another
//   cell, so every live version is always listed where its mean is; entries no particle needs any
//   more are dropped around the vehicle every few scans. A scan's query covers the sensor disc
//   around the mean pose, widened by the particle spread. So a particle checks the O(landmarks in
//   view) candidates, not its whole map, and the grid costs O(changes) per scan, not O(map size)
//   (bench/bench_fastslam.cpp). The view tests are the shared SensorView's.
//
// Memory: the nodes of the landmark trees and of the particles' paths come from pools the filter
// owns (NodePool), the grid recycles its entries, and per-scan scratch is kept between scans, so
// once the pools have grown to the working set (a lap of a route) predict() and update() make no heap
// allocation (tests/fastslam_allocation_test.cpp). What grows for good is the map and the surviving
// path, one pose per predict(); their storage grows in large chunks, and reserve() takes it ahead.
//
// Map ids: kKnown uses the observation ids. Otherwise a new landmark's id names the observation
// that created it: every particle that starts a landmark from observation k of scan s gives it the
// same id, assigned 0, 1, 2, ... per filter in order of (s, k) and never reused. An id thus means the
// same thing in every particle, and landmark_origin() tells which observation it came from.
//
// Parallelism and determinism: per-particle work runs on a small pool of threads. Each particle slot
// owns a random stream seeded from (seed, slot) through splitmix64, advanced only by that slot's
// work in a fixed order, and resampling has its own stream; results are therefore identical for a
// seed whatever the number of threads. (A stream per slot, rather than one re-seeded per step:
// seeding a Mersenne Twister costs about as much as a particle's whole prediction.) Work is handed
// to the threads only when there is enough of it: a prediction costs well under a microsecond per
// particle, so small particle sets predict on the calling thread.
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "slamkit/assoc/association_config.hpp"
#include "slamkit/filters/landmark_initialiser.hpp"
#include "slamkit/filters/resampling.hpp"
#include "slamkit/filters/slam_filter.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/models/measurement_likelihood.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

struct FastSlamConfig {
  /// Ten thousand particles are already far beyond what landmark SLAM uses (tens to hundreds); a
  /// million of them hold a gigabyte of paths every thousand steps.
  static constexpr int kMaxParticles = 1'000'000;
  /// A thread per particle chunk; more than any machine's cores only adds hand-over cost.
  static constexpr unsigned kMaxThreads = 1024;

  int version = 2;  // 1: FastSLAM 1.0, 2: FastSLAM 2.0
  int particles = 100;
  /// FastSLAM 2.0: the share of a scan's proposal covariance a particle draws its pose from, in
  /// (0, 1]; it keeps the rest as a Gaussian about the drawn pose (see above). 1, the textbook
  /// filter, is the default because relocalisation's loop closing on the sparse worlds was built
  /// and measured with it; 0.01 is Victoria Park's setting (docs/results.md).
  double pose_sample_fraction = 1.0;
  ResampleMethod resample = ResampleMethod::kSystematic;
  ResamplePolicy policy;  // default: when the ESS drops below half the particles
  AssociationConfig association;
  std::uint64_t seed = 1;
  unsigned threads = 0;  // 0: std::thread::hardware_concurrency()
  Pose2 initial_pose = Pose2::Zero();
  SensorLimits sensor;
  /// How a landmark starts (filters/landmark_initialiser.hpp); unset: immediately where the
  /// observation model inverts a measurement, delayed where it does not. Delayed and ring need
  /// known identities.
  std::optional<LandmarkInitialisation> initialisation;
  DelayedInitialisationOptions delayed_initialisation;  // the ring start's max_std_m and window_s too
  RingInitialisationOptions ring_initialisation;
  /// FastSLAM 2.0 with known identities and a sensor that measures range: the range sensor's offset
  /// and scale error (RangeCorrection) estimated per particle from this prior (see above); unset: not
  /// estimated.
  std::optional<RangeCalibrationPrior> range_calibration;
  /// The measurement noise's shape (models/measurement_likelihood.hpp). With the Student-t, each
  /// particle's landmark updates and proposal take an observation far from its prediction with R
  /// inflated, and its weight is the t density, so that one outlier does not decide which particles
  /// survive.
  MeasurementLikelihood likelihood;
};

class FastSlam final : public SlamFilter {
 public:
  /// Throws std::invalid_argument for a missing model or a config value out of range.
  FastSlam(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
           const FastSlamConfig& config);
  ~FastSlam() override;
  FastSlam(const FastSlam&) = delete;
  FastSlam& operator=(const FastSlam&) = delete;

  /// "fastslam1" or "fastslam2".
  std::string name() const override;
  /// Throws std::invalid_argument if the control's size is not the motion model's.
  void predict(const ControlEvent& control) override;
  void update(const ScanEvent& scan) override;

  /// Weighted mean of the particles' poses, the heading by circular mean.
  Pose2 pose() const override;
  /// Weighted covariance of the particle cloud about pose() (heading differences wrapped); for
  /// FastSLAM 2.0 between scans, plus the weighted mean of the particles' prediction covariances.
  Matrix3 pose_covariance() const override;
  /// Landmarks of the highest-weight particle's map, removed ones excluded.
  std::size_t num_landmarks() const override;
  std::vector<Landmark> landmarks() const override;
  /// The highest-weight particle's decisions for the last scan.
  const std::vector<AssociationRecord>& last_associations() const override;
  /// The highest-weight particle's path: the start, then one pose per predict() at the control's t.
  std::vector<StampedPose> smoothed_trajectory() const override;
  /// Drops the particles' paths and stops extending them.
  void forget_smoothed_trajectory() override;
  std::vector<WeightedPose> pose_samples() const override;
  /// Relative to pose(), the mean of the particles' poses.
  std::vector<LandmarkHypothesis> landmark_hypotheses() const override;
  /// "particles", "ess_mean" (mean ESS over scans, before resampling), "resamples",
  /// "weight_collapses" (scans in which every particle's likelihood was zero or undefined),
  /// "relocalisations" (scans in which the best particle relocalised, see
  /// AssociationConfig::relocalise_min_pairs), "relocalisation_searches" (the joint searches for
  /// one run, all particles: relocalisation's cost).
  std::map<std::string, double> statistics() const override;

  /// Starts every particle from a known map (shared, not copied), e.g. for localisation in a prior
  /// map. Its landmarks count as confirmed. Only before the first update(); ids must be unique and
  /// not kUnknownId. Throws std::logic_error / std::invalid_argument otherwise.
  void set_initial_map(const std::vector<Landmark>& map);
  /// Which observation started the landmark with this map id; nullopt for an id never created by
  /// update() (e.g. from set_initial_map).
  std::optional<LandmarkOrigin> landmark_origin(int id) const override;

  /// Pre-allocates what `steps` more predict() calls and `landmarks` more map ids made by update()
  /// (without identities) add for good: the poses by which the particles' shared past grows, one per
  /// step, the ids' origins and relocalisation's record of each scan (room for as many scans as
  /// steps). The steps then run without a heap allocation once the pools have
  /// seen the map (everything else a step needs is recycled); without reserve, that storage grows
  /// in chunks of thousands of poses, and by doubling.
  void reserve(std::size_t steps, std::size_t landmarks);

  /// About the bytes `particles` particles hold once their maps have `landmarks` landmarks: each
  /// particle's state and scratch, and the part of its map it shares with no other particle.
  static double memory_estimate(std::size_t particles, std::size_t landmarks);

  const FastSlamConfig& config() const;
  /// Threads the per-particle work runs on, the calling thread included.
  unsigned threads() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace slamkit
