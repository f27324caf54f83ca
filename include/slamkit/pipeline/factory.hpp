#pragma once
// Builds a filter for a dataset from typed settings, so the CLI and tests choose filters the same
// way. The settings are parsed from their names (here, and in assoc/ and filters/resampling.hpp)
// before any data is read, so a misspelt name is a usage error; to_string gives the names back for
// run.json and metrics.json.
#include <cstdint>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "slamkit/assoc/association_config.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/filters/resampling.hpp"
#include "slamkit/filters/slam_filter.hpp"
#include "slamkit/gridslam/scan_match_proposal.hpp"

namespace slamkit {

enum class FilterKind { kEkf, kUkf, kFastSlam1, kFastSlam2, kEif, kSeif, kEseif, kTjtf, kScanMatching, kGridFastSlam };

/// How the EKF applies a scan's paired observations.
enum class EkfUpdate {
  kJoint,       // all at once: one joint innovation, one pass over the covariance
  kSequential,  // one after another
  kIterated,    // all at once, relinearised at the result until it converges (the iterated EKF)
};

/// How a filter starts a landmark: auto (immediately where the dataset's observation model
/// inverts a measurement, delayed where it does not), immediate, delayed (triangulated from several
/// observations), ring (range only: a ring of hypotheses that collapses), the last two with known
/// identities, or inverse-distance (bearing only, the EKF full and fej: in the state at once).
enum class LandmarkInit { kAuto, kImmediate, kDelayed, kRing, kInverseDistance };

struct FilterConfig {
  FilterKind filter = FilterKind::kEkf;
  std::uint64_t seed = 1;
  AssociationConfig association;
  // EKF and UKF.
  EkfUpdate ekf_update = EkfUpdate::kJoint;
  // EKF only.
  /// The compressed variant takes joint and sequential updates alike and equals the full EKF with
  /// the same ekf_update.
  EkfVariant ekf_variant = EkfVariant::kFull;
  // UKF only.
  UkfNoise ukf_noise = UkfNoise::kAugmented;
  // SEIF only: run.json's seif_active_landmarks, seif_recovery_sweeps and seif_covariance.
  SeifOptions seif;
  // ESEIF only: run.json's eseif_active_landmarks, eseif_recovery_sweeps and eseif_covariance.
  EseifOptions eseif;
  // TJTF only: run.json's tjtf_max_clique_landmarks.
  TjtfOptions tjtf;
  // How a landmark starts (filters/landmark_initialiser.hpp), and the delayed start's settings.
  LandmarkInit landmark_init = LandmarkInit::kAuto;
  DelayedInitialisationOptions delayed_init;
  InverseDistanceOptions inverse_distance;  // run.json's inverse_distance_min_m
  // EKF (full, fej, invariant) and FastSLAM 2.0 with known association: the range sensor's offset
  // and scale error estimated from this prior; unset: not estimated.
  std::optional<RangeCalibrationPrior> range_calibration;
  // Every filter: the measurement noise's shape (models/measurement_likelihood.hpp).
  MeasurementLikelihood likelihood;
  // The grid filters (scan-matching, grid-fastslam) only: run.json's settings.grid.
  GridSlamOptions grid;
  // Particle filters only. The settings layers (pipeline/settings.hpp) start grid-fastslam at
  // kGridFastSlamParticles, GMapping's default.
  int particles = 100;
  double pose_sample_fraction = FastSlamConfig{}.pose_sample_fraction;  // FastSLAM 2.0 only
  ResampleMethod resample = ResampleMethod::kSystematic;
  ResamplePolicy resample_when;  // default: when the ESS drops below half the particles
  unsigned threads = 0;          // 0: all cores
};

inline constexpr int kGridFastSlamParticles = 30;

/// "ekf", "ukf", "eif", "seif", "eseif", "tjtf", "fastslam1", "fastslam2", "scan-matching" or
/// "grid-fastslam"; throws std::invalid_argument naming the accepted values.
FilterKind parse_filter_kind(const std::string& name);
std::string to_string(FilterKind kind);
/// "joint", "sequential" or "iterated"; throws std::invalid_argument naming the accepted values.
EkfUpdate parse_ekf_update(const std::string& name);
std::string to_string(EkfUpdate update);
/// "full", "compressed", "fej" or "invariant"; throws std::invalid_argument naming the accepted values.
EkfVariant parse_ekf_variant(const std::string& name);
std::string to_string(EkfVariant variant);

/// "augmented" or "additive"; throws std::invalid_argument naming the accepted values.
UkfNoise parse_ukf_noise(const std::string& name);
std::string to_string(UkfNoise noise);
/// "local" or "exact".
CovarianceRecovery parse_covariance_recovery(const std::string& name);
std::string to_string(CovarianceRecovery recovery);
/// "auto", "immediate", "delayed" or "ring"; throws std::invalid_argument naming the accepted values.
LandmarkInit parse_landmark_init(const std::string& name);
std::string to_string(LandmarkInit init);

/// The filter names parse_filter_kind accepts.
std::vector<std::string> filter_names();

/// Throws std::invalid_argument, one line naming the setting and its range, for settings no filter
/// could run with (e.g. fewer than one particle). Needs no data: the CLI calls it before reading any.
void validate(const FilterConfig& config);

/// Every setting by name, as `slamkit run --print-config` shows it and run.json records it; the
/// association settings are one object (to_json(AssociationConfig)), so settings added there appear
/// here without a change.
nlohmann::json to_json(const FilterConfig& config);
/// Reads the keys to_json writes (missing keys keep their defaults) and validates the result. An
/// unknown key, a misspelt name or a value out of range is an InputError naming `source`.
FilterConfig filter_config_from_json(const nlohmann::json& json, const std::string& source);
/// The same over `config`, which keeps what `json` does not name (in settings.association too),
/// without validating: for settings given in layers (pipeline/settings.hpp).
void read_filter_settings(const nlohmann::json& json, const std::string& source, FilterConfig& config);

/// Calls validate(config) and builds the filter for the dataset's models, sensor limits and start.
/// Throws InputError naming the dataset when a landmark filter is asked for on a dataset without an
/// observation model (a laser log).
std::unique_ptr<SlamFilter> make_filter(const FilterConfig& config, const Dataset& dataset);

}  // namespace slamkit
