#pragma once
// Settings of data association and map management, shared by every filter: how observations are
// paired with landmarks (known identities, nearest neighbour, joint compatibility), the chi-square
// gates, and when provisional landmarks are confirmed or removed. validate() is the one check of
// these settings: both filters call it, and so may a front end before it reads any data.
#include <cstddef>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>

namespace slamkit {

enum class AssociationMethod {
  kKnown,             // the observation's id names its landmark
  kNearestNeighbour,  // individual compatibility, Mahalanobis nearest neighbour with two gates
  kJcbb,              // joint compatibility branch and bound over a whole scan
};

/// "known", "nn" or "jcbb"; throws std::invalid_argument naming the accepted values otherwise.
AssociationMethod parse_association_method(const std::string& name);
std::string to_string(AssociationMethod method);

struct AssociationConfig {
  AssociationMethod method = AssociationMethod::kKnown;
  /// An observation is paired with a landmark only if its innovation's Mahalanobis distance squared
  /// lies inside this chi-square quantile (2 dof): 0.99 -> 9.21. JCBB applies the same confidence
  /// to the joint innovation of a whole hypothesis (2k dof).
  double accept_probability = 0.99;
  /// An unpaired observation starts a new landmark only if it lies outside this quantile for every
  /// candidate (0.9999 -> 18.4); between the two gates it is ambiguous and discarded.
  double new_landmark_probability = 0.9999;
  /// An observation inside the acceptance gate of a landmark is paired with it only if the pairing's
  /// probability is at least this: the landmark's innovation likelihood over the sum of every
  /// candidate's and the clutter density (clutter_per_scan). Below it the observation could as well
  /// be another landmark or a false detection, and is discarded: at a loop closure after a long
  /// drift the gates hold several landmarks, and a wrong pairing there corrupts the map for good
  /// while a discarded one costs one update. 0 keeps every pairing the gates and the search allow.
  double min_pairing_probability = 0.0;
  /// Expected false detections per scan, uniform over the sensor's view (range x bearing): the
  /// clutter density of min_pairing_probability.
  double clutter_per_scan = 0.0;
  /// With known identities, an observation whose innovation lies beyond the new-landmark gate is
  /// rejected as an outlier: an identity does not make a wild measurement right. Unset, each filter
  /// keeps its own default: the EKF gates (one wild update corrupts its single Gaussian for good),
  /// FastSLAM does not (each particle's weight already judges how well it explains the scan).
  std::optional<bool> gate_known;
  /// A new landmark is provisional until it has been observed this many times (the first included).
  int confirm_after = 3;
  /// A provisional landmark predicted in view but not seen this many scans in a row is removed.
  int provisional_max_misses = 3;
  /// A confirmed landmark predicted in view but not seen this many scans in a row is removed
  /// (0: never remove confirmed landmarks).
  int confirmed_max_misses = 8;
  /// "In view" for the miss count means inside the sensor's range and field of view shrunk by these
  /// margins, so landmarks at the edge are not punished for the sensor's noise.
  double view_margin_m = 2.0;
  double view_margin_rad = 0.1;
  /// JCBB explores at most this many nodes of its search tree per scan. Past the budget it returns
  /// the best hypothesis found so far; the first one it completes is the nearest-neighbour-like
  /// descent, so the budget degrades JCBB towards NN rather than towards nothing.
  std::size_t jcbb_max_nodes = 20000;
  /// Relocalisation at a loop closure, for every filter without identities and the EKF family with
  /// them (0 turns it off; 2, chosen on tuning seeds of the sparse worlds, is the default). After a
  /// long drift a filter back at its first landmarks finds them beyond its gates, or finds clutter
  /// inside them, and maps them again or takes a false detection for one; one observation cannot
  /// tell. So a landmark unseen for relocalise_window_s seconds is recognised only jointly: when at
  /// least this many confirmed landmarks started since then pair (JCBB, the joint gate of
  /// accept_probability) with landmarks mapped before the window, the pairing is taken and each
  /// duplicate fused into its original.
  ///  - EKF and UKF: old landmarks (confirmed, unseen for the window) are left out of association
  ///    and of the miss count until the vehicle is anchored to them again; the match is made on
  ///    the joint Gaussian's exact covariances (assoc/map_matching.hpp) when a landmark started in
  ///    the window is confirmed, the fusion is a noiseless update on m_duplicate - m_original, and
  ///    it anchors the vehicle for a window, as does each direct re-observation of an old landmark
  ///    while anchored.
  ///  - FastSLAM: each particle's map is built from its own path, so a landmark's estimate carries
  ///    none of the odometry drift since the particle last saw it; the spread of the particles
  ///    should, but resampling collapses it long before a loop returns. A particle that has started
  ///    landmarks in the window searches for their pairing with the landmarks it mapped before the
  ///    window whose joint discrepancy the drift since then explains (the motion model's process
  ///    noise propagated along the path, unless a landmark seen again since, conditioning it,
  ///    leaves less: the pose prior of the search). If this many confirmed ones pair jointly, and
  ///    more than twice as many as the old landmarks the corrected pose should see but does not,
  ///    the particle's pose takes the correction that best explains the pairs (iterated, as a pose
  ///    update with the drift as prior), the landmarks it saw in the window move with it, and each
  ///    duplicate is fused into the landmark it duplicates.
  ///  - The EKF family (UKF included) with known identities and gate_known: observations the gate
  ///    rejects place copies of their landmarks outside the state; when this many fit their
  ///    originals up to one rigid motion that the pose covariance does not admit, the pose
  ///    covariance takes that drift, so that the old landmarks pass the gate again
  ///    (docs/association.md, "Known identities").
  std::size_t relocalise_min_pairs = 2;
  double relocalise_window_s = 30.0;
  /// The probability that a landmark in view is detected: with clutter_per_scan, how the evidence
  /// of a pending landmark (assoc/pending_landmarks.hpp) weighs a scan that does not see it.
  double detection_probability = 0.9;
};

/// Throws std::invalid_argument naming the first setting out of its range and the range:
/// 0 < accept_probability < 1, accept_probability <= new_landmark_probability < 1,
/// 0 <= min_pairing_probability < 1, finite clutter_per_scan >= 0,
/// confirm_after >= 1, provisional_max_misses >= 1, confirmed_max_misses >= 0, finite view margins
/// >= 0, jcbb_max_nodes >= 1, relocalise_min_pairs 0 or >= 2, finite relocalise_window_s > 0,
/// 0 < detection_probability < 1.
void validate(const AssociationConfig& config);

/// Every setting, under the names association_config_from_json reads (run.json's provenance).
nlohmann::json to_json(const AssociationConfig& config);
/// Reads the keys to_json writes over the defaults (missing keys keep them), then validates. An
/// unknown key or a value of the wrong kind or range is an InputError naming `source`.
AssociationConfig association_config_from_json(const nlohmann::json& json, const std::string& source);
/// The same over `config`, which keeps what `json` does not name, without validating: for settings
/// given in layers (pipeline/settings.hpp), which are validated once whole.
void read_association_settings(const nlohmann::json& json, const std::string& source, AssociationConfig& config);

}  // namespace slamkit
