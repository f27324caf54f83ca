#pragma once
// EKF-SLAM, eqs. (6)-(11) of the tutorial: one joint Gaussian over the vehicle pose and every
// landmark, kept by an EkfEstimator (JointGaussian, or CompressedJointGaussian for the compressed
// variant; ekf_estimator.hpp describes their storage and cost), with the association and map
// management of assoc/ on top: which landmark each observation is, when a landmark is started,
// confirmed and removed, and the map ids.
//
// A scan without identities: candidates from the grid (cells around the vehicle, then the view
// test on the predicted measurement, with margins) -> associate() (NN or JCBB on the joint
// Gaussian) -> updates in order -> new landmarks -> re-bin the touched landmarks (rebuild the grid
// after a large correction, i.e. a loop closure) -> map management (the existence rule's misses of
// landmarks expected to be seen, confirmation, removal).
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "slamkit/assoc/association.hpp"
#include "slamkit/assoc/association_config.hpp"
#include "slamkit/assoc/gate_tally.hpp"
#include "slamkit/assoc/landmark_existence.hpp"
#include "slamkit/assoc/landmark_grid.hpp"
#include "slamkit/assoc/map_matching.hpp"
#include "slamkit/assoc/pending_landmarks.hpp"
#include "slamkit/assoc/sensor_view.hpp"
#include "slamkit/filters/ekf_estimator.hpp"
#include "slamkit/filters/exactly_sparse_information_filter.hpp"
#include "slamkit/filters/landmark_initialiser.hpp"
#include "slamkit/filters/slam_filter.hpp"
#include "slamkit/filters/sparse_extended_information_filter.hpp"
#include "slamkit/filters/thin_junction_tree_filter.hpp"
#include "slamkit/filters/unscented_joint_gaussian.hpp"
#include "slamkit/models/measurement_likelihood.hpp"

namespace slamkit {

enum class EkfVariant {
  kFull,        ///< JointGaussian: every update touches the whole joint covariance
  kCompressed,  ///< CompressedJointGaussian: updates confined to a local area, the rest on leaving it
  kFirstEstimates,  ///< JointGaussian with first-estimates Jacobians (consistent)
  kInvariant,       ///< JointGaussian with the right-invariant error (consistent)
  kUnscented,       ///< UnscentedJointGaussian: UKF-SLAM, the filter named "ukf"
  kInformation,     ///< ExtendedInformationFilter: the EKF in information form, the filter named "eif"
  kSparseInformation,  ///< SparseExtendedInformationFilter: SEIF, the filter named "seif"
  kExactlySparseInformation,  ///< ExactlySparseInformationFilter: ESEIF, the filter named "eseif"
  kThinJunctionTree,          ///< ThinJunctionTreeFilter: Paskin's TJTF, the filter named "tjtf"
};

struct EkfSlamOptions {
  Pose2 initial_pose = Pose2::Zero();
  /// The map frame is defined by the start pose, so by default it is known exactly.
  Matrix3 initial_covariance = Matrix3::Zero();
  AssociationConfig association;
  /// Decides which landmarks are association candidates and which count as missed when unseen.
  SensorLimits sensor;
  EkfVariant variant = EkfVariant::kFull;
  /// Compressed variant: side of the square the vehicle may roam before the accumulated update is
  /// applied to the whole map and a new area opens ahead of it [m]; 0 means 2 x sensor.max_range.
  /// Larger areas mean fewer flushes (each O(n^2) times the area's size) and dearer steps inside
  /// (O(area^2)); so do reads of the whole map (the runner's, every second: O(n area^2)). On a
  /// 1,000-landmark loop with a 30 m sensor, the filter alone ran as fast with 60 m as with 90 m,
  /// and with the runner's reads 60 m was the faster (docs/performance.md).
  double local_area_side = 0.0;
  /// Every variant: update with all of a scan's paired observations at once (one joint innovation
  /// and one symmetric rank-2k downdate, a single pass over the covariance) instead of one after
  /// another. Equal to the sequential update for linear models; for nonlinear ones every
  /// observation is linearised at the prior of the scan, as in eqs. (10)-(11) with z_k the scan.
  /// On the default world it is both faster and more accurate (ATE 0.199 m against 0.209 m).
  bool joint_scan_update = true;
  /// Full and first-estimates variants, and the information filters (EIF, SEIF, ESEIF):
  /// linearisations per update, the next one at the result of the last until it stops moving (the
  /// iterated EKF); 1 is the EKF's single one.
  int update_iterations = 1;
  /// The information filters' Jacobians: at the estimates (kStandard) or at first estimates.
  Linearisation information_linearisation = Linearisation::kStandard;
  /// Threads for the covariance's O(n^2) passes (0: every core); the estimate does not depend on it.
  unsigned threads = 0;
  /// Unscented variant: how its time update treats the control noise.
  UkfNoise ukf_noise = UkfNoise::kAugmented;
  /// The SEIF's settings (variant kSparseInformation).
  SeifOptions seif;
  /// The ESEIF's settings (variant kExactlySparseInformation).
  EseifOptions eseif;
  /// The thin junction tree filter's settings (variant kThinJunctionTree).
  TjtfOptions tjtf;
  /// How a landmark starts (filters/landmark_initialiser.hpp); unset: immediately where the
  /// observation model inverts a measurement, delayed where it does not. Delayed needs known
  /// identities.
  std::optional<LandmarkInitialisation> initialisation;
  DelayedInitialisationOptions delayed_initialisation;  // the ring start's max_std_m and window_s too
  RingInitialisationOptions ring_initialisation;
  InverseDistanceOptions inverse_distance;  ///< the inverse-distance start's prior
  /// Full, first-estimates and invariant variants, known association: estimate the range sensor's
  /// offset and scale error in the state from this prior (EkfEstimator::estimate_range_calibration).
  std::optional<RangeCalibrationPrior> range_calibration;
  /// The measurement noise's shape: Gaussian, or Student-t for sensors with outliers between one
  /// standard deviation and the gate (models/measurement_likelihood.hpp).
  MeasurementLikelihood likelihood;
};

class EkfSlam final : public SlamFilter {
 public:
  /// Throws std::invalid_argument for a missing model or settings out of range.
  EkfSlam(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
          const EkfSlamOptions& options = {});
  /// Continues from a joint Gaussian built elsewhere (e.g. a map made before), whose landmark i has
  /// the identity ids[i] (one per landmark, unique, not kUnknownId); they count as confirmed. Of
  /// `options`, the association, sensor, joint_scan_update and likelihood settings apply.
  EkfSlam(std::unique_ptr<EkfEstimator> estimator, std::span<const int> ids, const EkfSlamOptions& options = {});

  std::string name() const override { return name_; }
  void predict(const ControlEvent& control) override;
  /// Pairs the scan's observations with landmarks (known ids, NN or JCBB, as configured), applies
  /// the updates, then adds the new landmarks. With known association an observation without an id
  /// is discarded, and so is one beyond the new-landmark gate (AssociationConfig::gate_known, on
  /// unless set off; its verdicts are tallied, assoc/gate_tally.hpp), though a copy of its landmark
  /// is kept for the recovery (recover_known). With unknown association the map is managed: provisional landmarks are
  /// confirmed after repeated observations, and landmarks expected to be seen but repeatedly unseen
  /// are removed (ExistenceRule).
  void update(const ScanEvent& scan) override;

  Pose2 pose() const override { return estimator_->pose(); }
  Matrix3 pose_covariance() const override { return estimator_->pose_covariance(); }
  /// Every landmark in the state, provisional ones included.
  std::size_t num_landmarks() const override { return ids_.size(); }
  /// The map: confirmed landmarks only (with known association, every landmark is confirmed).
  std::vector<Landmark> landmarks() const override;
  std::vector<LandmarkHypothesis> landmark_hypotheses() const override;
  const std::vector<AssociationRecord>& last_associations() const override { return last_associations_; }
  std::map<std::string, double> statistics() const override;
  std::vector<InformationMatrixPanel> information_panels() const override { return estimator_->information_panels(); }
  /// About the bytes of the joint covariance once the map has `landmarks` landmarks, which dwarfs
  /// the rest of the filter's state.
  static double memory_estimate(std::size_t landmarks);

  /// The joint Gaussian, indexed by map index (landmarks in the order they were added, less the
  /// removed ones).
  const EkfEstimator& estimator() const { return *estimator_; }
  /// The id of each landmark of the joint Gaussian, by map index (provisional ones included).
  const std::vector<int>& landmark_ids() const { return ids_; }
  /// Map index of the landmark with this id, or -1.
  /// Landmarks in the state the existence rule has not confirmed.
  std::size_t provisional() const;
  long find_landmark(int id) const;
  /// The association step of update() alone (NN or JCBB, as configured): pairs the scan's
  /// observations with the landmarks that can be in view. Changes no estimate. The pairings are
  /// valid until the next call of associate_scan or update.
  const std::vector<Pairing>& associate_scan(const ScanEvent& scan);

 private:
  void update_known(const ScanEvent& scan);
  /// The squared Mahalanobis distance of observation z from landmark `index`'s prediction: what
  /// the known-identity gate (the new-landmark gate) and the t likelihood judge.
  double innovation_distance(std::size_t index, const Measurement& z) const;
  /// The update for observation z of landmark `index`, its noise inflated as the likelihood has it
  /// (`distance`: its innovation_distance where already known).
  LandmarkObservation weighed(std::size_t index, const Measurement& z,
                              std::optional<double> distance = std::nullopt) const;
  /// Each observation the known-identity gate rejected this scan (rejected_) places a copy of its
  /// landmark from the current pose, outside the state; copies unseen for the relocalisation window
  /// are dropped. Once relocalise_min_pairs copies fit their originals up to one rigid motion, the
  /// vehicle's covariance takes the drift that motion shows, and the copies are dropped.
  void recover_known(const ScanEvent& scan);
  /// If the copies sit where their originals do up to one rigid motion (within the chi-square gate of
  /// accept_probability), the vehicle's error that motion implies, as a diagonal covariance;
  /// otherwise nothing.
  std::optional<Matrix3> drift_the_copies_show();
  /// Applies the scan's collected updates jointly (joint_scan_update).
  void apply_joint_batch();
  void update_unknown(const ScanEvent& scan);
  /// The landmarks predicted in `view` from the current pose, in index order, into candidates_.
  void find_candidates(const SensorView& view);
  /// Counts misses of the landmarks expected to be seen (not in seen_) and removes those the
  /// existence rule gives up.
  void manage_map();
  /// Adds the landmark seen as z to the estimator and the map's bookkeeping.
  void add_landmark(const Measurement& z, int id);
  /// Takes landmark `index` out of the estimator and the map's bookkeeping.
  void remove_landmark(std::size_t index);
  /// The bookkeeping of a landmark the estimator has just added with index ids_.size().
  void register_landmark(int id, const LandmarkExistence& existence);
  /// Whether landmark `index` is left out of association and the miss count: a confirmed landmark
  /// unseen for the relocalisation window while the vehicle is not anchored to its old map.
  bool held_back(std::size_t index) const;
  /// Matches the confirmed landmarks started in the window with those unseen since before it and
  /// fuses the duplicates of a jointly compatible match of at least relocalise_min_pairs. Returns
  /// whether it fused any.
  bool relocalise();
  /// Bins every landmark at its current estimate.
  void rebuild_grid();
  /// Moves landmark `index` to the cell of its current estimate.
  void rebin(std::size_t index);

  std::unique_ptr<EkfEstimator> estimator_;
  // Delayed initialisation: the observations of landmarks not yet placed (null: each starts from
  // its first observation's inverse, through the estimator, which the UKF transforms unscented).
  std::unique_ptr<LandmarkInitialiser> initialiser_;
  std::optional<InverseDistanceOptions> inverse_distance_;  // set where landmarks start at inverse distance
  double reach_ = 0.0;  // the sensor's range: how far an inverse-distance landmark is drawn as a hypothesis
  std::size_t observations_waiting_ = 0;
  DeadReckoning dead_reckoning_;  // the initialiser's frame
  // Per landmark, by map index.
  std::vector<int> ids_;
  std::vector<LandmarkExistence> existence_;
  std::vector<LandmarkGrid::Cell> binned_;  // the cell it is listed in
  std::vector<double> started_, last_seen_;  // times of its first and last observation
  std::unordered_map<int, std::size_t> index_of_id_;
  int next_id_ = 0;  // ids of landmarks started without a known identity
  AssociationConfig association_;
  Gates gates_;  // from association_, computed once
  bool gate_known_;
  MeasurementLikelihood likelihood_;
  GateTally gate_tally_;
  SensorView association_view_;
  double clutter_density_;  // of association_ over the sensor's view
  ExistenceRule existence_rule_;
  PendingLandmarks pending_;  // observations that may start landmarks, where clutter is expected
  std::size_t scans_ = 0;
  int first_started_id_ = 0;  // ids from here on were started by update()
  std::size_t pending_observations_ = 0;
  LandmarkGrid grid_;
  double drift_since_rebuild_ = 0.0;  // vehicle corrections since the grid was last rebuilt [m]
  std::vector<AssociationRecord> last_associations_;
  // Relocalisation (AssociationConfig::relocalise_min_pairs): on without identities when the
  // setting asks for it. Until anchored_until_, a return has been verified and the old map is
  // recognised directly.
  bool relocalise_;
  // Recovery with known identities: on where the gate is and relocalise_min_pairs asks for it. A
  // filter whose gate rejects the old landmarks at a loop closure has lost itself (its covariance
  // no longer admits its own drift), and would otherwise run on odometry from then on.
  bool recover_known_;
  struct KnownCopy {
    std::size_t original = 0;  // its landmark's map index (stable: with identities none is removed)
    Vector2 position;
    Matrix2 covariance;        // of the measurement alone
    double seen = 0.0;  // the time of the observation that placed it
  };
  std::map<int, KnownCopy> copies_;    // by landmark id; ordered, so the fit sums in one order
  std::vector<Vector2> copy_positions_, original_positions_;  // the fit's points, reused
  std::vector<std::size_t> rejected_;  // observations the gate rejected this scan
  std::vector<std::size_t> restarts_;  // of those, the ones of landmarks at inverse distance
  std::size_t inverse_distance_restarts_ = 0;
  struct GateVerdicts {
    double t = 0.0;
    std::size_t judged = 0, rejected = 0;
  };
  std::vector<GateVerdicts> recent_verdicts_;  // per scan, over the relocalisation window
  std::size_t known_recoveries_ = 0;
  double now_ = 0.0;  // the time of the scan being processed
  double anchored_until_ = 0.0;
  bool first_scan_ = true;
  bool recent_confirmed_ = false;  // a landmark started in the window was confirmed this scan
  std::vector<std::size_t> recent_, old_;
  bool joint_scan_update_;
  std::string name_;  // "ekf", or the filter its estimator makes it: "ukf", "eif", "seif", "eseif", "tjtf"
  std::vector<LandmarkObservation> batch_;  // a scan's updates, when applied jointly
  // Reused per scan.
  std::vector<std::size_t> new_observations_;
  std::vector<std::size_t> candidates_, doomed_;
  std::vector<std::uint32_t> nearby_;
  std::vector<bool> seen_;  // per landmark: paired in this scan
  AssociationWorkspace association_workspace_;
  std::vector<Pairing> pairings_;
  // Statistics.
  AssociationStats association_stats_;
  std::size_t discarded_ = 0, removed_ = 0;
  std::size_t relocalisations_ = 0, landmarks_fused_ = 0;
  MapMatcher map_matcher_;
  std::vector<LandmarkPair> fused_pairs_;
  MapMatchStats map_match_stats_;
};

}  // namespace slamkit
