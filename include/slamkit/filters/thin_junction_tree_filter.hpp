#pragma once
// Paskin's thin junction tree filter (TJTF; IJCAI 2003): the SLAM belief as a Gaussian over a
// junction tree whose cliques hold a bounded number of variables, thinned by maximum-likelihood
// (KL-optimal) projections whenever a clique would grow past the bound.
//
// Representation: a tree of cliques, each holding the marginal (mean and covariance) of its
// variables; the joint is the product of the clique marginals over the product of the separator
// marginals (neighbours share exactly their separator's variables, and each variable's cliques form
// a connected subtree). The vehicle lives in one clique, the root, so that
//  * the time update is exact and touches the root alone (no separator holds the vehicle);
//  * a measurement of a landmark in the root is the EKF's update restricted to the root, exact:
//    evidence on the root's variables leaves every other clique's conditional given its separator
//    as it was, so the other cliques are brought up to date lazily, when read (Hugin messages from
//    the root outward along the path to what is read; `epoch` marks what is current);
//  * a landmark seen again that is not in the root is first added, exactly, to every clique on the
//    path from one that holds it to the root (from the conditional of the landmark given each
//    separator), as Paskin extends cliques to give a potential a home.
//
// Thinning: a clique holding more than `max_clique_landmarks` landmarks drops one by variable
// contraction: a variable held by exactly one of the clique's neighbours leaves the clique, which is
// the projection imposing that it is independent of the rest of the clique given the separator. Its
// cost is that conditional mutual information (nats, from the clique's marginal), and the cheapest
// goes (the vehicle never does). When the root is full and too few of its landmarks are also in its
// child to contract, it first pushes a copy of its landmarks down as a new clique between itself and
// its children (exact: the copy is their marginal), so that the cliques form a chain along the
// route, consecutive ones sharing at least half the bound. The projections are where TJTF
// approximates: every clique's marginal is exact at the time of each projection, and the sum of
// their costs is reported (tjtf_projection_nats).
//
// Removal of a landmark (the existence rule) drops it from every clique that holds it, the same
// projection; a fusion (map matching) brings both landmarks into the root and conditions on their
// being one, exact there.
//
// Cost: a scan costs what its cliques cost, (3 + 2k)^3 for a bound of k, plus the walk along the path
// to a landmark seen again and the cliques read (association's candidates), however large the map;
// reading the whole map (the runner's cadence) brings every clique up to date, O(n k^2).
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include "slamkit/filters/ekf_estimator.hpp"

namespace slamkit {

/// The thin junction tree filter's settings (run.json's tjtf_* keys).
struct TjtfOptions {
  /// The landmarks a clique holds at most (the vehicle's clique holds the vehicle besides). More
  /// keeps more of the exact filter's correlations, and each clique costs (3 + 2k)^3.
  std::size_t max_clique_landmarks = 24;
  static constexpr std::size_t kMinCliqueLandmarks = 3;
  static constexpr std::size_t kMaxCliqueLandmarks = 200;
};
/// Throws std::invalid_argument naming tjtf_max_clique_landmarks if it is out of range.
void validate(const TjtfOptions& options);

class ThinJunctionTreeFilter final : public EkfEstimator {
 public:
  /// A singular initial covariance is allowed (the tree is in moment form, as the EKF).
  ThinJunctionTreeFilter(std::shared_ptr<const MotionModel> motion,
                         std::shared_ptr<const ObservationModel> observation, const Pose2& initial_pose,
                         const Matrix3& initial_covariance, const TjtfOptions& options);

  Matrix3 pose_covariance() const override;
  Vector2 landmark_position(std::size_t index) const override;
  Matrix2 landmark_covariance(std::size_t index) const override;
  Matrix23 landmark_pose_covariance(std::size_t index) const override;
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override;
  /// The joint covariance of the vehicle and `landmarks`, from the cliques on their paths to the
  /// root at once, kept for the reads that follow until the belief changes.
  void prepare_covariances(std::span<const std::size_t> landmarks) const override;
  /// Brings every clique up to date once and reads each landmark from a clique that holds it.
  void landmark_marginals(std::vector<Vector2>& means, std::vector<Matrix2>& covariances) const override;
  Eigen::VectorXd state() const override;
  /// The joint the tree stands for, dense (each clique's variables regressed on its separator).
  Eigen::MatrixXd covariance() const override;

  /// Counts scans: a landmark observed in this one leaves the vehicle's clique only if no other can.
  void begin_scan() override;
  void predict(const Control& u, double dt) override;
  void inflate_pose(const Matrix3& q) override;
  using EkfEstimator::update_landmark;
  bool update_landmark(const LandmarkObservation& observation) override;
  /// One observation at a time (the root holds one landmark more than the bound at most). Returns
  /// false if an innovation covariance was not positive definite; that observation changes nothing,
  /// the others are applied.
  bool update_landmarks(std::span<const LandmarkObservation> batch) override;
  using EkfEstimator::add_landmark;
  std::size_t add_landmark(const InitialLandmark& landmark) override;
  void remove_landmark(std::size_t index) override;
  /// One pair at a time (conditioning on each in turn is conditioning on all). Returns false if a
  /// pair's discrepancy has no positive definite covariance; the pairs before it stay fused.
  bool fuse_landmarks(std::span<const LandmarkPair> pairs) override;

  /// The information matrix the tree stands for (the clique marginals' inverses, less the
  /// separators'): sparse, a block wherever two variables share a clique.
  std::vector<InformationMatrixPanel> information_panels() const override;
  /// tjtf_cliques, tjtf_widest_clique (landmarks), tjtf_contractions, tjtf_pushes,
  /// tjtf_path_extensions, tjtf_projection_nats.
  void add_statistics(std::map<std::string, double>& statistics) const override;

  /// About the bytes of the tree once the map has `landmarks` landmarks: a clique for every half
  /// bound of landmarks, each a full (3 + 2k)-square covariance, twice over for slack.
  static double memory_estimate(std::size_t landmarks, const TjtfOptions& options);

  /// The number of cliques, and the landmarks each holds (the vehicle's clique first): for tests.
  std::vector<std::vector<std::size_t>> cliques() const;

 private:
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  static constexpr std::size_t kRoot = 0;  // the vehicle's clique
  // Added to a covariance's diagonal (m^2, rad^2) before it is inverted, for the exactly known start
  // pose: far below any sensor's or motion's noise.
  static constexpr double kInformationJitter = 1e-12;

  struct Clique {
    bool vehicle = false;
    bool alive = true;
    std::vector<std::size_t> landmarks;  // map indices, in row order after the vehicle's rows
    Eigen::VectorXd mean;
    Eigen::MatrixXd covariance;
    std::size_t parent = kNone;
    std::vector<std::size_t> children;
    std::uint64_t epoch = 0;  // current while equal to the filter's
    // cov(vehicle, this clique's variables), valid while cross_version is the filter's version_.
    Eigen::MatrixXd vehicle_cross;
    std::uint64_t cross_version = 0;

    Eigen::Index rows() const { return (vehicle ? 3 : 0) + 2 * static_cast<Eigen::Index>(landmarks.size()); }
    /// The first row of `landmark`, or -1 if the clique does not hold it.
    Eigen::Index row_of(std::size_t landmark) const;
    bool holds(std::size_t landmark) const { return row_of(landmark) >= 0; }
  };

  /// The landmarks two cliques share, and their first rows in each.
  struct Separator {
    std::vector<std::size_t> landmarks;
    std::vector<Eigen::Index> rows_a, rows_b;
    Eigen::Index size() const { return 2 * static_cast<Eigen::Index>(landmarks.size()); }
  };
  Separator separator(const Clique& a, const Clique& b) const;

  /// A joint covariance over the vehicle (rows 0-2) and landmarks (their first rows by map index).
  struct Joint {
    Eigen::MatrixXd covariance;
    std::unordered_map<std::size_t, Eigen::Index> rows;
    std::uint64_t version = 0;  // the filter's version_ it was computed at
  };
  /// The joint of every variable of the `included` cliques (by clique index; they must form a
  /// subtree holding the root), each clique regressed on its separator.
  Joint joint(const std::vector<char>& included) const;
  /// Landmark `index`'s first row in the prepared joint, or null if it is not there or out of date.
  const Eigen::Index* prepared_row(std::size_t index) const;
  std::vector<std::size_t> neighbours(std::size_t c) const;

  /// Brings clique `c` up to date from its nearest current ancestor down.
  void make_current(std::size_t c) const;
  /// c's marginal given its parent's (current): c's conditional given their separator kept.
  void propagate(std::size_t parent, std::size_t c) const;
  /// Every clique up to date.
  void calibrate_all() const;
  /// A clique holding landmark `index`, current.
  const Clique& current_home(std::size_t index) const;
  /// cov(vehicle, c's variables), c current.
  const Eigen::MatrixXd& vehicle_cross(std::size_t c) const;
  /// cov(landmark `index`, every variable of clique `to`), along the tree's path.
  Eigen::MatrixXd landmark_cross(std::size_t index, std::size_t to) const;

  /// Evidence entered the root: every other clique is now behind it.
  void root_changed();
  /// Brings landmark `index` into the root (exactly, along the path), thinning the path's cliques;
  /// `pinned` must stay in the root for the update to come.
  void admit(std::size_t index, const std::vector<std::size_t>& pinned);
  /// Adds landmark `index` to `target` from `source`, a neighbour that holds it (both current).
  void extend(std::size_t target, std::size_t source, std::size_t index);
  /// Appends landmark `index` to clique `c` with its mean, its covariance with c's variables and its
  /// own.
  static void append(Clique& c, std::size_t index, const Vector2& mean, const Eigen::MatrixXd& cross,
                     const Matrix2& own);
  /// The cliques holding landmark `index` connected to `from` (which holds it) other than through
  /// `excluded` (kNone: all of them), each made current: before any changes, as a drop changes
  /// separators.
  std::vector<std::size_t> current_holders(std::size_t index, std::size_t from, std::size_t excluded) const;
  /// Before a landmark enters a full root: pushes the root down if too few of its landmarks
  /// (`pinned` aside) could be contracted to its child.
  void make_room_in_root(const std::vector<std::size_t>& pinned);
  /// A copy of the root's landmarks, put between the root and its children.
  void push_root();
  /// How many of the root's landmarks, `pinned` aside, one child alone holds.
  std::size_t contractible_in_root(const std::vector<std::size_t>& pinned) const;
  /// Drops landmarks from clique `c` until it holds the bound (the cheapest contraction each time,
  /// none of `pinned`); false if no landmark could go.
  bool thin(std::size_t c, const std::vector<std::size_t>& pinned);
  /// The conditional mutual information a contraction of `landmark` from `c` to `keeper` forgets.
  /// `information` is c's covariance inverted.
  double contraction_cost(const Clique& c, const Eigen::MatrixXd& information, std::size_t landmark,
                          const Clique& keeper) const;
  /// Removes landmark `index` from clique `c` (its marginal is the old one's without it).
  void drop(std::size_t c, std::size_t index);
  /// Removes landmark `index` from `c` and every clique holding it beyond `c` away from `kept`.
  void cut(std::size_t index, std::size_t c, std::size_t kept);
  /// A clique (not the root) whose landmarks its parent holds too hands its children to the parent
  /// and goes.
  void dissolve_if_redundant(std::size_t c);
  std::size_t new_clique();

  /// After a fusion conditioned `pair` equal in the root: the duplicate's place in the tree goes to
  /// the original, and the duplicate is left as an independent clique of its own.
  void set_duplicate_aside(const LandmarkPair& pair);
  /// The Kalman update of the root with z = h(root) linearised (rows of `h` over the root's rows).
  bool update_root(const Eigen::MatrixXd& h, const Eigen::VectorXd& innovation, const Eigen::MatrixXd& noise);

  TjtfOptions options_;
  mutable std::vector<Clique> cliques_;
  std::vector<std::size_t> free_;
  std::vector<std::size_t> home_;  // by map index: a clique that holds the landmark
  std::vector<std::size_t> last_observed_;  // by map index: the scan count when last observed
  std::size_t scans_ = 0;
  mutable std::uint64_t epoch_ = 1;
  mutable Joint prepared_;  // prepare_covariances'
  // landmark_cross's answers (key: landmark << 32 | clique), while the belief is at
  // cross_cache_version_.
  mutable std::unordered_map<std::uint64_t, Eigen::MatrixXd> cross_cache_;
  mutable std::uint64_t cross_cache_version_ = 0;

  std::uint64_t version_ = 1;  // changes with every change of the belief (caches of vehicle_cross)
  std::size_t contractions_ = 0, pushes_ = 0, path_extensions_ = 0;
  double projection_nats_ = 0.0;
};

}  // namespace slamkit
