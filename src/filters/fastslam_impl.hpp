#pragma once
// FastSLAM's private state, shared by fastslam.cpp (the filter: particles, threads, candidates,
// resampling, map ids, the public interface), fastslam_particle.cpp (one particle's scan:
// association, the proposal and the landmark updates, eqs. 15-18) and fastslam_relocalise.cpp (the
// drift and relocalisation).
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

#include "slamkit/assoc/association.hpp"
#include "slamkit/assoc/gate_tally.hpp"
#include "slamkit/assoc/landmark_existence.hpp"
#include "slamkit/assoc/landmark_grid.hpp"
#include "slamkit/assoc/pending_landmarks.hpp"
#include "slamkit/assoc/sensor_view.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/filters/landmark_initialiser.hpp"
#include "slamkit/filters/landmark_tree.hpp"
#include "slamkit/filters/particle_path.hpp"
#include "slamkit/filters/particle_set.hpp"
#include "slamkit/filters/worker_pool.hpp"

namespace slamkit {

namespace fastslam_detail {

constexpr double kLog2Pi = 1.8378770664093454836;
constexpr double kMinusInf = -std::numeric_limits<double>::infinity();

/// Inverse and log-determinant of a measurement's covariance (one per measurement dimension);
/// false if it is not positive definite.
inline bool invert_spd(const Eigen::Matrix<double, 1, 1>& s, Eigen::Matrix<double, 1, 1>& inverse, double& log_det) {
  if (!(s(0, 0) > 0.0) || !std::isfinite(s(0, 0))) return false;
  inverse(0, 0) = 1.0 / s(0, 0);
  log_det = std::log(s(0, 0));
  return true;
}

inline bool invert_spd(const Matrix2& s, Matrix2& inverse, double& log_det) {
  const double det = s(0, 0) * s(1, 1) - s(0, 1) * s(1, 0);
  if (!(det > 0.0) || !(s(0, 0) > 0.0) || !std::isfinite(det)) return false;
  inverse << s(1, 1), -s(0, 1), -s(1, 0), s(0, 0);
  inverse /= det;
  log_det = std::log(det);
  return true;
}

inline bool invert_spd(const Matrix3& s, Matrix3& inverse, double& log_det) {
  const Eigen::LLT<Matrix3> llt(s);
  if (llt.info() != Eigen::Success || !s.allFinite()) return false;
  inverse = llt.solve(Matrix3::Identity());
  log_det = 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  return true;
}

/// log((2 pi)^(D/2)): the constant of a D-dimensional Gaussian's log density.
template <int D>
constexpr double kLogGaussianConstant = 0.5 * D * kLog2Pi;

/// The symmetric part of a covariance expression: rounding breaks symmetry, and a 2x2 inverse and
/// an LDLT read both triangles.
template <class Derived>
typename Derived::PlainObject symmetric(const Eigen::MatrixBase<Derived>& expression) {
  const typename Derived::PlainObject m = expression;
  return 0.5 * (m + m.transpose());
}

/// Makes sure a scratch vector can take n elements, growing it to twice that when it must grow:
/// a scan a little busier than any before then does not allocate again.
template <class T>
void make_room(std::vector<T>& v, std::size_t n) {
  if (v.capacity() < n) v.reserve(2 * n);
}

/// Sums over the control steps k of the odometry drift's terms, from which drift_between() makes
/// the drift covariance of any interval in O(1). With every motion model here, a pose error at step
/// k + 1 reaches step n through [I  J (p_n - p_{k+1}); 0 1] (J the 90-degree rotation), so the drift
/// from s to n is the sum over k in [s, n) of that matrix times Q_k times its transpose, and
/// expanding the lever arm J p_n - J p_{k+1} leaves sums that do not depend on n.
struct DriftSums {
  Matrix2 q_pp = Matrix2::Zero();     // position block of Q_k
  Vector2 q_pt = Vector2::Zero();     // position-heading block of Q_k
  double q_tt = 0.0;                  // heading entry of Q_k
  Vector2 q_tt_b = Vector2::Zero();   // q_tt,k b_k, with b_k = J p_{k+1}
  Matrix2 q_tt_bb = Matrix2::Zero();  // q_tt,k b_k b_k^T
  Matrix2 q_pt_b = Matrix2::Zero();   // q_pt,k b_k^T

  /// Adds the control step that ends at position p with process noise q.
  void add(const Matrix3& q, const Vector2& p) {
    const Vector2 b(-p.y(), p.x());
    q_pp += q.topLeftCorner<2, 2>();
    q_pt += q.topRightCorner<2, 1>();
    q_tt += q(2, 2);
    q_tt_b += q(2, 2) * b;
    q_tt_bb += q(2, 2) * b * b.transpose();
    q_pt_b += q.topRightCorner<2, 1>() * b.transpose();
  }
};

/// The covariance that the odometry drift of the steps summed in `to` but not in `from` adds to the
/// pose at position p (the end of `to`), linearised along the trajectory the sums followed.
inline Matrix3 drift_between(const DriftSums& from, const DriftSums& to, const Vector2& p) {
  const Vector2 a(-p.y(), p.x());
  const Matrix2 q_pp = to.q_pp - from.q_pp;
  const Vector2 q_pt = to.q_pt - from.q_pt;
  const double q_tt = to.q_tt - from.q_tt;
  const Vector2 q_tt_b = to.q_tt_b - from.q_tt_b;
  const Matrix2 q_tt_bb = to.q_tt_bb - from.q_tt_bb;
  const Matrix2 q_pt_b = to.q_pt_b - from.q_pt_b;
  // The sums of Q_pt l_k^T with the lever arm l_k = a - b_k, and of q_tt l_k l_k^T.
  const Matrix2 pt_l = q_pt * a.transpose() - q_pt_b;
  const Matrix2 tt_ll = q_tt * a * a.transpose() - a * q_tt_b.transpose() - q_tt_b * a.transpose() + q_tt_bb;
  Matrix3 d;
  d.topLeftCorner<2, 2>() = q_pp + pt_l + pt_l.transpose() + tt_ll;
  d.topRightCorner<2, 1>() = q_pt + q_tt * a - q_tt_b;
  d.bottomLeftCorner<1, 2>() = d.topRightCorner<2, 1>().transpose();
  d(2, 2) = q_tt;
  return symmetric(d);
}

/// An observation model's answers in types fixed at its measurement dimension D.
template <int D>
struct MeasurementKernels {
  using Vector = MeasurementVector<D>;
  using Square = MeasurementSquare<D>;
  const ObservationModel* model = nullptr;
  Square r = Square::Zero();  // the measurement noise

  Vector predict(const Pose2& x, const Vector2& m) const { return model->predict(x, m); }
  void jacobians(const Pose2& x, const Vector2& m, PoseRows<D>& hx, LandmarkRows<D>& hm) const {
    PoseJacobian pose_rows;
    LandmarkJacobian landmark_rows;
    model->jacobians(x, m, pose_rows, landmark_rows);
    hx = pose_rows;
    hm = landmark_rows;
  }
  Vector residual(const Vector& z, const Vector& zhat) const { return model->residual(z, zhat); }
  Vector2 inverse(const Pose2& x, const Vector& z) const { return model->invert(x, z)->position; }
  void inverse_jacobians(const Pose2& x, const Vector& z, Matrix23& gx, Eigen::Matrix<double, 2, D>& gz) const {
    const InverseObservation g = *model->invert(x, z);
    gx = g.gx;
    gz = g.gz;
  }
};

/// The Jacobian of a measurement in the range calibration (offset, scale error).
template <int D>
using CalibrationRows = Eigen::Matrix<double, D, 2>;

/// With a range calibration c, a landmark's Gaussian given c: its mean moves with c, mean + gain
/// (c - at), about the covariance the map's LandmarkGaussian keeps (see fastslam.hpp).
struct CalibrationLink {
  Matrix2 gain = Matrix2::Zero();  // dm/dc
  Vector2 at = Vector2::Zero();    // the calibration at which the map's mean holds
};
using CalibrationLinks = BasicLandmarkTree<kLandmarkTreeFanOut, CalibrationLink>;

/// A particle's pose error relative to its old map, as of the scan at which a landmark it saw again
/// after the window, or its relocalisation, tied its pose to that map (see drift_of()).
struct Anchor {
  std::uint32_t scan = 0;
  Vector2 position = Vector2::Zero();  // the particle's at `scan`
  Matrix3 covariance = Matrix3::Zero();
};

/// Association's view of one particle: a pose with a covariance (FastSLAM 2.0's proposal, none for
/// 1.0, or relocalisation's drift) and landmarks that, given the particle's path, are independent of
/// the pose and of each other. It shows either the whole map or the landmarks a list of indices
/// names, in that list's order.
class ParticleMapView final : public GaussianMapView {
 public:
  ParticleMapView(const Pose2& pose, const Matrix3& pose_cov, const LandmarkTree& map)
      : pose_(pose), pose_cov_(pose_cov), map_(map) {}
  ParticleMapView(const Pose2& pose, const Matrix3& pose_cov, const LandmarkTree& map,
                  std::span<const std::uint32_t> shown)
      : pose_(pose), pose_cov_(pose_cov), map_(map), shown_(shown) {}
  Pose2 pose() const override { return pose_; }
  Matrix3 pose_covariance() const override { return pose_cov_; }
  Vector2 landmark_position(std::size_t index) const override { return landmark(index).mean; }
  Matrix23 landmark_pose_covariance(std::size_t) const override { return Matrix23::Zero(); }
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override {
    return i == j ? landmark(i).covariance : Matrix2::Zero();
  }

 private:
  const LandmarkGaussian& landmark(std::size_t index) const { return map_[shown_ ? (*shown_)[index] : index]; }

  Pose2 pose_;
  Matrix3 pose_cov_;
  const LandmarkTree& map_;
  std::optional<std::span<const std::uint32_t>> shown_;
};

}  // namespace fastslam_detail

struct FastSlam::Impl {
  struct Particle {
    Pose2 pose = Pose2::Zero();  // FastSLAM 2.0: the mean of the Gaussian below
    // FastSLAM 2.0: the pose's covariance about `pose`: the part of the last scan's proposal not
    // sampled (FastSlamConfig::pose_sample_fraction), plus the motion noise since.
    Matrix3 pose_cov = Matrix3::Zero();
    // With a range calibration: the particle's Gaussian of (offset, scale error).
    Vector2 calibration = Vector2::Zero();
    Matrix2 calibration_cov = Matrix2::Zero();
    fastslam_detail::CalibrationLinks links;  // one per landmark of `map`
    LandmarkTree map;
    ParticlePath path;
    // Relocalisation: the particle's latest anchor, and the scan of its last relocalisation (see
    // drift_of()).
    std::optional<fastslam_detail::Anchor> anchor;
    std::optional<std::uint32_t> relocalised_at;
  };

  /// What one particle does with one observation; `index` is in that particle's map.
  struct Pairing {
    AssociationDecision decision = AssociationDecision::kDiscard;
    std::uint32_t index = 0;
  };

  /// What one observation's acceptance gate holds of the confirmed landmarks in view.
  struct SharedGate {
    std::uint32_t count = 0;
    std::array<std::uint32_t, 2> first = {0, 0};  // positions in Slot::in_view, in index order
  };

  /// Per particle slot (not per particle: resampling moves particles, slots stay): the scratch of
  /// a scan update. The slot's random stream is the particle set's.
  struct Slot {
    std::vector<Pairing> pairings;
    // Association without identities: the landmarks in the widened view of the particle's pose, in
    // index order, and what the shared kernel decided for each observation.
    std::vector<std::size_t> in_view;
    AssociationWorkspace association;
    std::vector<slamkit::Pairing> decisions;
    AssociationStats association_stats;  // all scans
    std::vector<std::uint32_t> observed;
    // (mean, index) of each landmark this scan created or moved into another grid cell.
    std::vector<std::pair<Vector2, std::uint32_t>> grid_entries;
    // Relocalisation's scratch: the landmarks mapped since the window and those before it, the
    // former as measurements from the pose, and the joint search's workspace and answer.
    std::vector<std::uint32_t> recent;
    std::vector<std::uint32_t> old;
    std::vector<std::uint32_t> started;  // of recent, those started in the window
    std::vector<std::uint32_t> confirmed_now;  // of those, the ones this scan confirmed
    std::vector<Observation> recent_as_seen;  // the started ones as the particle sees them
    std::vector<std::size_t> old_positions;  // 0, 1, ...: the search's candidates, positions in old
    std::vector<Matrix2> duplicate_noise;     // per pair: the duplicate's covariance as measured
    AssociationWorkspace workspace;
    std::vector<slamkit::Pairing> matches;
    std::vector<char> paired;  // per old landmark
    bool relocalised = false;  // in this scan
    // The duplicate test's scratch (see weigh_duplicates): per observation, how many confirmed
    // landmarks in view its acceptance gate holds and the first two (positions in in_view); per
    // landmark of in_view, how many observations' gates hold it; the landmarks this scan paired;
    // the copies whose odds reached the bar, and how many were fused.
    std::vector<SharedGate> shared_gates;
    std::vector<std::uint32_t> gated_by;
    std::vector<std::uint32_t> paired_now;
    std::vector<std::uint32_t> copies_to_fuse;
    std::size_t fused_now = 0;
    std::size_t gate_judged = 0, gate_rejected = 0;  // the known-identity gate's verdicts, this scan
    std::size_t relocalisation_searches = 0;  // joint searches run in this slot, all scans
  };

  Impl(std::shared_ptr<const MotionModel> motion_model, std::shared_ptr<const ObservationModel> observation_model,
       const FastSlamConfig& cfg);

  bool known() const { return config.association.method == AssociationMethod::kKnown; }
  bool calibrating() const { return config.range_calibration.has_value(); }

  void start(double t);
  void predict_particle(std::size_t i, const ControlEvent& control);
  void plan_known_association(const ScanEvent& scan, std::size_t scan_index);
  void gather_candidates();
  void associate(const Particle& p, Slot& s, const ScanEvent& scan) const;
  template <int D>
  void reject_known_outliers(const Particle& p, Slot& s, const ScanEvent& scan) const;
  /// The covariance of the innovation of landmark lm as particle p predicts it, and the Jacobians.
  template <int D>
  MeasurementSquare<D> innovation_covariance(const Particle& p, const LandmarkGaussian& lm, PoseRows<D>& hx,
                                             LandmarkRows<D>& hm) const;
  /// Whether z lies beyond the new-landmark gate of landmark `index` as particle p predicts it; the
  /// verdict is counted in the slot.
  template <int D>
  bool beyond_gate(const Particle& p, std::uint32_t index, const MeasurementVector<D>& z, Slot& s) const;
  /// With a range calibration: the mean of landmark `index` of particle p given the calibration c.
  Vector2 mean_at(const Particle& p, std::uint32_t index, const Vector2& c) const;
  /// With a range calibration: that landmark's measurement predicted from x and read through c, with
  /// its Jacobians in the pose, the landmark and (through the range row alone) c.
  template <int D>
  MeasurementVector<D> predict_given(const Particle& p, std::uint32_t index, const Pose2& x, const Vector2& c,
                                     PoseRows<D>& hx, LandmarkRows<D>& hm,
                                     fastslam_detail::CalibrationRows<D>& hc) const;
  /// Particle i's scan update, with measurements of dimension D (the model's).
  template <int D>
  void update_particle(std::size_t i, const ScanEvent& scan);
  /// FastSLAM 2.0's proposal (eq. 18) for particle p, the landmarks paired in its slot below map
  /// index old_size: the prediction refined by each paired observation in turn, over the pose, or
  /// (N = 5) the pose and the range calibration; the pose is then drawn. Returns the log of the
  /// proposal's normalising constant, the particle's weight factor.
  template <int D, int N>
  double propose(Particle& p, Slot& s, const ScanEvent& scan, std::size_t old_size, std::mt19937_64& rng) const;
  /// The log likelihood of an innovation at squared Mahalanobis distance m2 from a prediction whose
  /// covariance S has log determinant log_det (FastSlamConfig::likelihood).
  template <int D>
  double log_likelihood_of(double m2, double log_det) const {
    if (!config.likelihood.robust()) return -0.5 * m2 - fastslam_detail::kLogGaussianConstant<D> - 0.5 * log_det;
    return config.likelihood.log_density(m2, D, log_det);
  }
  /// Adds to `noise` (R plus any other uncertainty) what the t likelihood inflates R by for an
  /// innovation at squared Mahalanobis distance m2; returns whether it did (and S must be formed
  /// anew).
  template <int D>
  bool inflate_noise(double m2, MeasurementSquare<D>& noise) const {
    const double inflation = config.likelihood.noise_inflation(m2, D);
    if (inflation == 1.0) return false;
    noise += (inflation - 1.0) * kernels.get<D>().r;
    return true;
  }
  /// The update of landmark lm, and the likelihood of z, at particle p's pose with the covariance it
  /// carries (FastSLAM 2.0: see FastSlamConfig::pose_sample_fraction; else zero).
  template <int D>
  double update_landmark(LandmarkGaussian& lm, const Particle& p, const MeasurementVector<D>& z) const;
  /// With a range calibration: the update of landmark `index` and particle p's calibration, jointly.
  template <int D>
  double update_calibrated(Particle& p, std::uint32_t index, const MeasurementVector<D>& z) const;
  template <int D>
  LandmarkGaussian new_landmark(const Pose2& x, const Matrix3& x_cov, const MeasurementVector<D>& z, int id) const;
  /// Particle p starts the landmark the initialiser placed (placements, in dead reckoning's frame):
  /// the same place relative to the particle, and with a range calibration moving with it from
  /// where it was placed (placement_calibration).
  void start_placed(Particle& p, const InitialLandmark& placed, int id) const;
  /// The particles' weighted mean range calibration.
  Vector2 mean_calibration() const;
  void count_misses(Particle& p, Slot& s) const;
  /// Whether the existence rule expects particle p to see landmark lm from its pose.
  bool expected_in_view(const Particle& p, const LandmarkGaussian& lm) const;
  /// A landmark's copy in particle p's map: a place mapped again (a return beyond the gates, a
  /// relocalisation that missed one) whose copy then sits next to the original, each observation
  /// paired with one or the other, so that neither is ever missed. Called after association, at the
  /// predicted pose: a scan whose observation alone holds two confirmed landmarks in the detection
  /// view in its acceptance gate, neither held by another observation's, is evidence that they are
  /// one landmark. If they are, one detection is what the sensor gives with probability P_D; if they
  /// are two, one detection of both is 2 P_D (1 - P_D): each such scan adds log(1 / (2 (1 - P_D)))
  /// to the newer one's log odds of being the older one's copy (from even odds), and a scan that
  /// pairs both with observations of their own settles that they are two. At the odds of
  /// accept_probability the copy is queued for fuse_duplicates. Only a landmark started more than
  /// relocalise_window_s after the other can be its copy (twins seen together are started
  /// together), so the test runs where relocalisation does.
  void weigh_duplicates(Particle& p, Slot& s, const ScanEvent& scan) const;
  /// Fuses each queued copy into its original, after the scan's updates.
  void fuse_duplicates(Particle& p, Slot& s) const;
  /// Two estimates of one landmark of p's map, independent given the particle's path, become one:
  /// the duplicate is fused into the original and removed.
  void fuse(Particle& p, std::uint32_t original, std::uint32_t duplicate, Slot& s) const;
  bool weighing_duplicates() const { return relocalising() && !calibrating() && duplicate_log_ratio > 0.0; }
  /// Particle p's relocalisation after a scan update that started a landmark or confirmed one started
  /// in the window (AssociationConfig::relocalise_min_pairs); landmarks from index `first_new` on
  /// were started by this scan.
  void relocalise(Particle& p, Slot& s, std::uint32_t first_new) const;
  bool relocalising() const { return !known() && config.association.relocalise_min_pairs > 0; }
  /// The covariance of particle p's pose error relative to what it saw at scan `seen`: the odometry
  /// drift since then or, if smaller (by position variance), the anchor's error carried to the pose
  /// now plus the drift since the anchor. The anchor counts only if it is later than `seen` and no
  /// relocalisation lies between them: the pose jumped there to the map seen before the drift, and
  /// what the particle saw between that and the jump is as far off as the drift made it.
  Matrix3 drift_of(const Particle& p, std::uint32_t seen) const;
  /// Ties particle p's pose to an old landmark it sees again, lm as before this scan's update: the
  /// drift since lm was last seen, conditioned on the observation, becomes p's anchor.
  void anchor_at(Particle& p, const LandmarkGaussian& lm) const;
  /// drift_of(p, lm.last_seen) as a covariance of lm's predicted measurement, and the measurement's
  /// Jacobian in the landmark.
  Matrix2 drift_in_measurement(const Particle& p, const LandmarkGaussian& lm, Matrix2& hm) const;
  /// With pending landmarks: after every particle's association, which of the scan's observations
  /// start landmarks (start_detections), and the particles' pairings to match.
  void decide_new_landmarks(const ScanEvent& scan);
  void assign_new_ids(std::size_t observations, std::size_t scan_index);
  void record_associations(std::size_t slot, const ScanEvent& scan);
  void reweight_and_resample(const ScanEvent& scan);
  void index_grid_entries();
  void prune_grid();
  void set_origin(int id, const LandmarkOrigin& origin);
  const Particle& best_particle() const { return particles.best_particle(); }

  FastSlamConfig config;
  // The threads first: the node storage serves them. The node storage next: it must outlive every
  // map and path, i.e. the particles.
  WorkerPool pool;
  LandmarkTree::NodeStorage map_nodes;
  fastslam_detail::CalibrationLinks::NodeStorage link_nodes;
  ParticlePath::NodeStorage path_nodes;
  bool keep_paths = true;
  std::shared_ptr<const MotionModel> motion;
  std::shared_ptr<const ObservationModel> observation;
  /// The model's kernels at its measurement dimension (only that one is set): a scan's particle
  /// updates are dispatched once to the code fixed at it.
  PerMeasurementDim<fastslam_detail::MeasurementKernels> kernels;
  /// The two-row kernels of range and bearing: the search for pairings (nn) and relocalisation
  /// need a measurement that places a landmark, which only range and bearing is.
  const fastslam_detail::MeasurementKernels<2>& measurements = kernels.two;
  Gates gates;
  bool gate_known;
  GateTally gate_tally;  // over every particle's verdicts
  SensorView association_view;
  double clutter_density;  // of config.association over the sensor's view
  ExistenceRule existence;
  // New landmarks where clutter is expected (assoc/pending_landmarks.hpp): the filter decides for
  // every particle, from the best one's pose, whether an observation most particles cannot explain
  // starts a landmark, and with how many detections.
  PendingLandmarks pending;
  std::vector<int> start_detections;  // per observation of the current scan
  std::size_t pending_observations = 0;
  double log_p0 = 0.0;

  ParticleSet<Particle> particles;
  std::vector<Slot> slots;
  std::vector<double> log_likelihoods;  // per particle slot: its weight factor from the current scan

  std::vector<char> valid;  // per observation of the current scan: finite measurement
  std::vector<Pairing> known_plan;
  // Where one measurement does not place a landmark (or a setting asks for it), the observations of
  // a landmark not yet mapped wait in the initialiser, which works in dead reckoning's frame, shared
  // by every particle; a landmark it places is started by each particle where it lies relative to
  // the particle (placements: per observation of the current scan, for those it placed).
  std::unique_ptr<LandmarkInitialiser> initialiser;
  DeadReckoning dead_reckoning;
  std::vector<InitialLandmark> placements;
  Vector2 placement_calibration = Vector2::Zero();  // what the current scan's placements read ranges through
  int range_row = -1;  // of the measurement
  std::size_t observations_waiting = 0;
  std::unordered_map<int, std::uint32_t> known_index;
  LandmarkGrid grid;
  std::size_t scans_since_prune = 0;
  std::vector<std::uint32_t> scan_candidates;

  int next_id = 0;
  int first_started_id = 0;  // ids from here on were started by update()
  std::vector<int> new_ids;  // per observation of the current scan
  // Sorted by id. Ids made by update() increase, so they are appended; a vector rather than a hash
  // map, so that a new id costs an allocation only when the capacity doubles (or not after reserve).
  std::vector<std::pair<int, LandmarkOrigin>> origins;
  std::vector<AssociationRecord> last_records;

  // Relocalisation: the odometry drift along the best particle's path, its sums at each scan, each
  // scan's time and best position, the first scan of the window, and the landmarks any particle may
  // relocalise with in this scan (grid candidates, in index order).
  AssociationConfig relocalise_association;  // config.association with JCBB
  fastslam_detail::DriftSums drift;
  std::vector<fastslam_detail::DriftSums> drift_at_scan;
  std::vector<double> scan_times;
  std::vector<Vector2> scan_positions;
  std::uint32_t window_start = 0;
  std::vector<std::uint32_t> relocalise_candidates;
  std::size_t relocalisations = 0;  // of the best particle's lineage: counted where the best relocalised
  // The duplicate test (weigh_duplicates): the log likelihood ratio of one scan's evidence, the log
  // odds at which a copy is fused, and the fusions of the best particle's lineage.
  double duplicate_log_ratio = 0.0;
  double duplicate_log_odds_bar = 0.0;
  std::size_t duplicates_fused = 0;

  std::size_t scans = 0;
};

}  // namespace slamkit
