#pragma once
// How a Gaussian filter starts a landmark. Where one measurement determines the landmark (range and
// bearing), it starts at once from that measurement's inverse. Where it does not (a range alone puts
// the landmark on a circle, a bearing alone on a ray), the observations of the landmark wait here
// until several of them, taken from poses far enough apart, place it: delayed initialisation, the
// triangulation of Leonard and Newman's range-only and Bailey's (2003) bearing-only SLAM.
//
// The delayed start, per landmark (by its known identity):
//  - each observation is kept with the pose it was taken from, for a window of time (older ones are
//    forgotten, so a landmark seen once long ago starts afresh). The poses must be consistent with
//    each other: EkfSlam gives dead reckoning's, which no correction makes jump, and carries the
//    landmark from that frame to the estimate's once it is placed;
//  - with enough of them (3 ranges or 2 bearings at least), the landmark position m that best
//    explains them all is found by Gauss-Newton from a closed-form start (lines through the
//    sensors for bearings, the linearised circle equations for ranges), each observation weighed by
//    R plus the pose uncertainty gained since it was taken, relative to the current pose (the growth
//    of dead reckoning's covariance since, projected onto the positive semi-definite cone);
//  - it starts when its covariance (the inverse of the information sum Hm^T W Hm) has no standard
//    deviation above max_std_m, the residuals pass the chi-square gate, and no second position
//    explains the observations as well: ranges taken along a straight line fit the landmark and its
//    mirror image across that line equally, and the start waits until the vehicle turns. A view
//    whose residual fails the gate is dropped as an outlier.
// Views keep the raw measurements; the range calibration the filter estimates corrects them when
// they are fitted, and the fit says how the landmark moves with it (InitialLandmark::range_gain).
// The ring start (range only; Kantor and Singh 2002, Djugash et al.'s range-only SLAM), per landmark:
//  - its first range puts it on a circle about the sensor, held as a ring of Gaussians spread evenly
//    around it (each as wide across the ring as the range noise, along it half the spacing, at
//    most max_hypotheses of them), all equally likely;
//  - the hypotheses are held relative to the current pose: between two ranges each gains, as a
//    landmark attached to the vehicle would, the pose uncertainty dead reckoning has gained;
//  - each range updates every hypothesis (an EKF update of its position) and weighs it by how well
//    it predicted the range.
//    A hypothesis is dropped when its innovations' summed chi-square fails the gate for their
//    number, or exceeds the best hypothesis's by more than the gate for two degrees of freedom
//    allows (a significance test, not odds: dead reckoning bends a straight road a little, and
//    hundreds of ranges would turn that bend into overwhelming odds for one side);
//  - the landmark starts when the live hypotheses, equally weighted, spread no standard deviation
//    beyond max_std_m, at the mixture's moment-matched Gaussian: until the vehicle's motion rules
//    out all but one place, every hypothesis consistent with the ranges stays alive (a vehicle on a
//    straight keeps the landmark and its mirror image). A range no hypothesis explains
//    is passed over as an outlier; a ring none of whose hypotheses stays consistent, or that has
//    not collapsed within window_s, is drawn afresh from the latest range.
// The landmark joins the state rigidly attached to the current pose (as an inverted measurement
// does: P(m, :) = [I, J (m - p)] P(v, :)) with the triangulation's covariance on top, the uncertainty
// relative to that pose; the observations that placed it are not applied again.
#include <Eigen/Cholesky>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "slamkit/models/measurement_likelihood.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

/// How EkfSlam starts a landmark. Immediate is the estimator's own add_landmark(z) (the UKF
/// transforms the inverse unscented), so only the delayed start is a LandmarkInitialiser here; the
/// interface is the seam for others (multi-hypothesis starts).
enum class LandmarkInitialisation {
  kImmediate,  ///< one measurement places the landmark (needs a model that inverts it)
  kDelayed,    ///< triangulation from several observations at well-spread poses
  kRing,       ///< range only: a ring of Gaussian hypotheses that collapses as the ranges agree
  /// bearing only: the landmark joins the state at its first bearing as an inverse-distance point
  /// (models/inverse_distance.hpp); kept by the EKF's own estimator, not a LandmarkInitialiser
  kInverseDistance,
};

struct DelayedInitialisationOptions {
  int min_views = 0;           ///< observations before a triangulation is tried; 0: 3 ranges or 2 bearings
  int max_views = 40;          ///< kept per landmark, the oldest dropped first (bounds time and memory)
  double max_std_m = 1.0;      ///< the largest standard deviation a landmark may start with [m]
  double window_s = 60.0;      ///< observations older than this are forgotten [s]
  double gate_probability = 0.9999;  ///< of the residuals' chi-square test, and of the ambiguity test
  /// Set by the filters where their likelihood expects outliers (MeasurementLikelihood::robust):
  /// each candidate position is judged on the views it explains, a view beyond the single-view gate
  /// left out as an outlier (at most a quarter of them), instead of the worst view being dropped for
  /// good whenever the best position fails the test.
  bool outliers_expected = false;
  /// Set with outliers_expected where only ranges read long are outliers
  /// (MeasurementLikelihood::outliers_read_long): a view whose range is read short of a candidate
  /// position is never left out, so it counts against that position in full.
  bool outliers_read_long = false;
};

/// Throws std::invalid_argument naming the first setting out of its range.
void validate(const DelayedInitialisationOptions& options);

/// `options` with the outliers the filter's `likelihood` expects of `model`'s measurements (its two
/// outlier flags). Throws std::invalid_argument where the likelihood takes outliers to be ranges read
/// long and the model measures no range.
DelayedInitialisationOptions expecting_outliers_of(DelayedInitialisationOptions options,
                                                   const MeasurementLikelihood& likelihood,
                                                   const ObservationModel& model);

/// The ring start's own setting; it shares max_std_m and window_s with the delayed start.
struct RingInitialisationOptions {
  int max_hypotheses = 120;  ///< on one ring; a wider ring spaces them further apart
};

class LandmarkInitialiser;

/// The initialiser a filter starts landmarks through for `initialisation` (unset: immediate where
/// the model inverts a measurement, delayed where it does not); null for immediate, which is the
/// filter's own. Throws std::invalid_argument for inverse distance (a filter that keeps it handles it
/// before asking), for an immediate start the model cannot make, for
/// a delayed or ring start without known identities, which is what gathers one landmark's
/// observations, and for the ring where the filter calibrates its ranges (its hypotheses are updated
/// through the calibration of their time, and not correlated with it).
std::unique_ptr<LandmarkInitialiser> make_landmark_initialiser(std::optional<LandmarkInitialisation> initialisation,
                                                               std::shared_ptr<const ObservationModel> model,
                                                               bool known_identities, bool calibrating_ranges,
                                                               const DelayedInitialisationOptions& delayed,
                                                               const RingInitialisationOptions& ring);

/// dm/dx of a landmark at m attached rigidly to a vehicle at x, as an inverted measurement is:
/// [I, J (m - p)], J the quarter turn.
Matrix23 attached_to_pose(const Pose2& x, const Vector2& m);

/// Dead reckoning from the start pose, which no update corrects: the frame the initialisers work
/// in. There the poses of a landmark's observations are consistent with each other (an estimate's
/// jump at a correction would bend their geometry), and the covariance's growth between two
/// observations stands for how uncertain one pose is relative to the other.
struct DeadReckoning {
  Pose2 pose = Pose2::Zero();
  Matrix3 covariance = Matrix3::Zero();

  void advance(const MotionModel& motion, const Control& u, double dt);
  /// A landmark an initialiser placed (in this frame, relative to the pose now) where it lies
  /// relative to a vehicle estimated at x: the same place relative to the vehicle.
  InitialLandmark carried_to(const Pose2& x, const InitialLandmark& placed) const;
};

class LandmarkInitialiser {
 public:
  virtual ~LandmarkInitialiser() = default;
  /// Observation z of landmark `id` (not yet in the map) from a vehicle estimated at x, at time t:
  /// the landmark to start now, or nothing while it waits. `odometry_covariance` is dead
  /// reckoning's covariance at t, which only grows: its growth between two observations stands for
  /// the uncertainty of one pose relative to the other. Ranges are read through `correction`, the
  /// filter's current estimate of the sensor's calibration.
  virtual std::optional<InitialLandmark> offer(int id, const Pose2& x, const Matrix3& odometry_covariance,
                                               const Measurement& z, double t, const RangeCorrection& correction) = 0;
  /// How many landmarks have observations waiting.
  virtual std::size_t waiting() const = 0;
  /// Where the landmarks with observations waiting may lie, in the frame of the offers: those
  /// offered within the window of the latest offer, for the replay page to draw.
  virtual std::vector<LandmarkHypothesis> hypotheses() const = 0;
};

/// The initialiser's hypotheses (in dead reckoning's frame) where they lie relative to a vehicle
/// estimated at x, as a landmark started now would be placed (DeadReckoning::carried_to).
std::vector<LandmarkHypothesis> hypotheses_at(const LandmarkInitialiser& initialiser, const DeadReckoning& dead_reckoning,
                                              const Pose2& x);

/// Delayed: triangulation (see the file's comment).
class DelayedInitialiser final : public LandmarkInitialiser {
 public:
  /// Throws std::invalid_argument for invalid options or a model that is neither range-only nor
  /// bearing-only nor range-bearing (the closed-form start needs one of those).
  DelayedInitialiser(std::shared_ptr<const ObservationModel> model, const DelayedInitialisationOptions& options);
  std::optional<InitialLandmark> offer(int id, const Pose2& x, const Matrix3& odometry_covariance,
                                       const Measurement& z, double t, const RangeCorrection& correction) override;
  std::size_t waiting() const override { return views_.size(); }
  /// The positions the last offer of each landmark found to explain its views: one, or while they
  /// admit more (a range's mirror image), each of them; with a position too uncertain to start, that.
  std::vector<LandmarkHypothesis> hypotheses() const override;

 private:
  struct View {
    Pose2 pose;
    Matrix3 odometry_covariance;
    Measurement z;
    double t = 0.0;
  };
  struct Fit {
    Vector2 position;
    Matrix2 covariance;
    double chi2 = 0.0;       // over the views it explains
    std::size_t outliers = 0;  // views it leaves out (only where outliers are expected)
    std::size_t worst = 0;   // the view with the largest residual
    double worst_chi2 = 0.0;
    Vector2 range_gain = Vector2::Zero();        // InitialLandmark's
    Vector2 range_scale_gain = Vector2::Zero();  // InitialLandmark's
  };
  /// The best position for `views` weighed against the uncertainty gained since each, by
  /// Gauss-Newton from `start`, leaving out each view whose chi-square exceeds trim_above at the
  /// current iterate; nothing if the information stays singular.
  std::optional<Fit> fit(const std::vector<View>& views, const Matrix3& odometry_covariance_now, Vector2 start,
                         double trim_above) const;
  /// Whether a fit explains its views: few enough outliers, and the rest within the chi-square gate.
  bool explains(const Fit& fit, std::size_t views) const;
  /// Closed-form starting points for the fit from the views and their sensors' positions: one, or
  /// for ranges from collinear sensors the two mirror images; none if the views do not intersect.
  struct Starts {
    std::array<Vector2, 2> points;
    std::size_t count = 0;
    std::span<const Vector2> all() const& { return std::span(points).first(count); }
    // A temporary's points would be gone before the loop over them ran.
    std::span<const Vector2> all() const&& = delete;
  };
  Starts starts(const std::vector<View>& views, const std::vector<Vector2>& sensors) const;

  std::shared_ptr<const ObservationModel> model_;
  DelayedInitialisationOptions options_;
  bool measures_range_;
  bool measures_bearing_;
  int min_views_;
  double view_gate_;  // one view's chi-square gate; the trim where outliers are expected
  std::vector<double> gates_;  // the chi-square gate of n views' residuals, by n
  double rival_gate_;  // how much worse than the best fit a rival may be (2 dof: the position's)
  std::map<int, std::vector<View>> views_;  // by landmark id; ordered, so the order of work is fixed
  struct Candidates {
    double t = 0.0;  // of the offer that found them
    std::vector<Fit> fits;
  };
  std::map<int, Candidates> candidates_;  // by landmark id, for hypotheses(); no fits: none found
  double latest_t_ = -INFINITY;           // of the latest offer
  // Scratch of offer() and fit(), kept so that a landmark waiting for views costs no allocation per
  // observation once its window is full.
  std::vector<View> corrected_, others_;
  std::vector<Vector2> sensors_;
  std::vector<Fit> fits_;
  struct FitScratch {
    std::vector<Matrix3> gained;
    Eigen::VectorXd common_range, residual, w_residual, w_range;
    Eigen::MatrixXd s, hm, w_hm;
    Eigen::LLT<Eigen::MatrixXd> llt;
  };
  mutable FitScratch fit_scratch_;
};

/// Ring: multiple hypotheses (see the file's comment).
class RingInitialiser final : public LandmarkInitialiser {
 public:
  /// Throws std::invalid_argument for invalid options or a model that does not measure range alone.
  RingInitialiser(std::shared_ptr<const ObservationModel> model, const DelayedInitialisationOptions& options,
                  const RingInitialisationOptions& ring = {});
  std::optional<InitialLandmark> offer(int id, const Pose2& x, const Matrix3& odometry_covariance,
                                       const Measurement& z, double t, const RangeCorrection& correction) override;
  std::size_t waiting() const override { return rings_.size(); }
  std::vector<LandmarkHypothesis> hypotheses() const override;

  struct Hypothesis {
    Vector2 mean;
    Matrix2 covariance;
    double log_weight = 0.0;
    double chi2 = 0.0;  // of its innovations so far
  };
  /// The live hypotheses of landmark `id`'s ring (empty if it has none), their weights normalised.
  std::vector<Hypothesis> hypotheses(int id) const;

 private:
  struct Ring {
    double t0 = 0.0;
    Matrix3 odometry_covariance;  // dead reckoning's at the last range
    int updates = 0;               // ranges applied since
    std::vector<Hypothesis> hypotheses;
  };
  /// A ring about the sensor at pose x for the distance `distance`.
  Ring draw(const Pose2& x, const Matrix3& odometry_covariance, double distance, double t) const;

  std::shared_ptr<const ObservationModel> model_;
  DelayedInitialisationOptions options_;
  RingInitialisationOptions ring_;
  double range_gate_;  // one range's chi-square gate
  double worse_gate_;  // how much worse than the best a hypothesis may explain the ranges (2 dof)
  std::map<int, Ring> rings_;  // by landmark id
  double latest_t_ = -INFINITY;  // of the latest offer
};

}  // namespace slamkit
