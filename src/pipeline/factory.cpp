#include "slamkit/pipeline/factory.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <utility>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/names.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/gridslam/grid_fastslam.hpp"
#include "slamkit/gridslam/scan_matching_filter.hpp"

namespace slamkit {
namespace {

// Each enum's names, in the order help texts list them.
constexpr std::pair<FilterKind, const char*> kFilterNames[] = {
    {FilterKind::kEkf, "ekf"},
    {FilterKind::kUkf, "ukf"},
    {FilterKind::kEif, "eif"},
    {FilterKind::kSeif, "seif"},
    {FilterKind::kEseif, "eseif"},
    {FilterKind::kTjtf, "tjtf"},
    {FilterKind::kFastSlam1, "fastslam1"},
    {FilterKind::kFastSlam2, "fastslam2"},
    {FilterKind::kScanMatching, "scan-matching"},
    {FilterKind::kGridFastSlam, "grid-fastslam"}};
constexpr std::pair<EkfUpdate, const char*> kEkfUpdateNames[] = {
    {EkfUpdate::kJoint, "joint"}, {EkfUpdate::kSequential, "sequential"}, {EkfUpdate::kIterated, "iterated"}};
// The iterated update converges in two or three linearisations except at a loop closure after a
// long drift, where it may take several; beyond ten it would only creep.
constexpr int kIteratedUpdateLinearisations = 10;
// The unscented, information and junction tree estimators are chosen as filters of their own ("ukf",
// "eif", "seif", "eseif", "tjtf"), not as EKF variants.
constexpr std::pair<EkfVariant, const char*> kEkfVariantNames[] = {{EkfVariant::kFull, "full"},
                                                                   {EkfVariant::kCompressed, "compressed"},
                                                                   {EkfVariant::kFirstEstimates, "fej"},
                                                                   {EkfVariant::kInvariant, "invariant"}};
constexpr std::pair<UkfNoise, const char*> kUkfNoiseNames[] = {{UkfNoise::kAugmented, "augmented"},
                                                                {UkfNoise::kAdditive, "additive"}};
constexpr std::pair<CovarianceRecovery, const char*> kCovarianceRecoveryNames[] = {
    {CovarianceRecovery::kLocal, "local"}, {CovarianceRecovery::kExact, "exact"}};
constexpr std::pair<LandmarkInit, const char*> kLandmarkInitNames[] = {
    {LandmarkInit::kAuto, "auto"},
    {LandmarkInit::kImmediate, "immediate"},
    {LandmarkInit::kDelayed, "delayed"},
    {LandmarkInit::kRing, "ring"},
    {LandmarkInit::kInverseDistance, "inverse-distance"}};

// The delayed start's settings, run.json's settings.delayed_init. Their ranges are
// validate(DelayedInitialisationOptions)'s, checked with the rest of the filter's settings.
using Delayed = DelayedInitialisationOptions;
const OptionKey<Delayed> kDelayedInitKeys[] = {
    {"min_views", IntegerOption<Delayed, int>{[](Delayed& o) -> int& { return o.min_views; }}},
    {"max_views", IntegerOption<Delayed, int>{[](Delayed& o) -> int& { return o.max_views; }}},
    {"max_std_m", RealOption<Delayed>{[](Delayed& o) -> double& { return o.max_std_m; }, option_ranges::kFinite}},
    {"window_s", RealOption<Delayed>{[](Delayed& o) -> double& { return o.window_s; }, option_ranges::kFinite}},
    {"gate_probability",
     RealOption<Delayed>{[](Delayed& o) -> double& { return o.gate_probability; }, option_ranges::kFinite}},
};

void read_delayed_init(const nlohmann::json& json, const std::string& source, Delayed& options) {
  option_detail::read_keys<Delayed>(json, source, "'delayed_init'", kDelayedInitKeys, options);
}

// The grid filters' settings, run.json's settings.grid.
using Grid = GridSlamOptions;
const OptionKey<Grid> kGridKeys[] = {
    {"resolution_m", RealOption<Grid>{[](Grid& o) -> double& { return o.grid.resolution; }, option_ranges::kFinite}},
    {"range_cutoff_m", RealOption<Grid>{[](Grid& o) -> double& { return o.grid.range_cutoff; }, option_ranges::kFinite}},
    {"max_cells", RealOption<Grid>{[](Grid& o) -> double& { return o.grid.max_cells; }, option_ranges::kFinite}},
    {"match_sigma_m", RealOption<Grid>{[](Grid& o) -> double& { return o.matcher.sigma; }, option_ranges::kFinite}},
    {"match_search_cells", IntegerOption<Grid, int>{[](Grid& o) -> int& { return o.matcher.search_cells; }}},
    {"match_beam_stride", IntegerOption<Grid, int>{[](Grid& o) -> int& { return o.matcher.beam_stride; }}},
    {"match_max_range_m",
     RealOption<Grid>{[](Grid& o) -> double& { return o.matcher.max_range; }, option_ranges::kFinite}},
    {"likelihood_temperature",
     RealOption<Grid>{[](Grid& o) -> double& { return o.likelihood_temperature; }, option_ranges::kFinite}},
    {"weight_temperature",
     RealOption<Grid>{[](Grid& o) -> double& { return o.weight_temperature; }, option_ranges::kFinite}},
    {"min_matched_fraction",
     RealOption<Grid>{[](Grid& o) -> double& { return o.min_matched_fraction; }, option_ranges::kFinite}},
    {"proposal_spread_m",
     RealOption<Grid>{[](Grid& o) -> double& { return o.proposal_spread_m; }, option_ranges::kFinite}},
    {"proposal_sample_fraction",
     RealOption<Grid>{[](Grid& o) -> double& { return o.proposal_sample_fraction; }, option_ranges::kFinite}},
    {"proposal_spread_deg", RealOption<Grid>{[](Grid& o) -> double& { return o.proposal_spread_rad; },
                                              option_ranges::kFinite, Unit::kDegrees}},
    {"update_distance_m",
     RealOption<Grid>{[](Grid& o) -> double& { return o.update_distance; }, option_ranges::kFinite}},
    {"update_rotation_deg", RealOption<Grid>{[](Grid& o) -> double& { return o.update_rotation; },
                                              option_ranges::kFinite, Unit::kDegrees}},
};

void read_grid_settings(const nlohmann::json& json, const std::string& source, Grid& options) {
  option_detail::read_keys<Grid>(json, source, "'grid'", kGridKeys, options);
}

bool is_grid_filter(FilterKind kind) { return kind == FilterKind::kScanMatching || kind == FilterKind::kGridFastSlam; }

// The range calibration's prior, run.json's settings.range_calibration (null: not estimated).
using Calibration = RangeCalibrationPrior;
const OptionKey<Calibration> kRangeCalibrationKeys[] = {
    {"offset_m", RealOption<Calibration>{[](Calibration& o) -> double& { return o.offset_m; }, option_ranges::kFinite}},
    {"offset_std_m",
     RealOption<Calibration>{[](Calibration& o) -> double& { return o.offset_std_m; }, option_ranges::kFinite}},
    {"scale_error",
     RealOption<Calibration>{[](Calibration& o) -> double& { return o.scale_error; }, option_ranges::kFinite}},
    {"scale_error_std",
     RealOption<Calibration>{[](Calibration& o) -> double& { return o.scale_error_std; }, option_ranges::kFinite}},
};

void read_range_calibration(const nlohmann::json& json, const std::string& source,
                            std::optional<Calibration>& prior) {
  if (json.is_null()) {
    prior.reset();
    return;
  }
  if (!prior) prior.emplace();
  option_detail::read_keys<Calibration>(json, source, "'range_calibration'", kRangeCalibrationKeys, *prior);
}

template <typename Enum, std::size_t N>
Enum parse_name(const std::pair<Enum, const char*> (&names)[N], const std::string& name, const char* what) {
  const auto match = std::find_if(std::begin(names), std::end(names), [&](const auto& n) { return name == n.second; });
  if (match != std::end(names)) return match->first;
  std::vector<std::string> accepted;
  for (const auto& n : names) accepted.emplace_back(n.second);
  throw std::invalid_argument(unknown_name_message(what, name, accepted));
}

template <typename Enum, std::size_t N>
std::string name_of(const std::pair<Enum, const char*> (&names)[N], Enum value) {
  return std::find_if(std::begin(names), std::end(names), [&](const auto& n) { return n.first == value; })->second;
}

std::optional<LandmarkInitialisation> landmark_initialisation(LandmarkInit init) {
  switch (init) {
    case LandmarkInit::kImmediate: return LandmarkInitialisation::kImmediate;
    case LandmarkInit::kDelayed: return LandmarkInitialisation::kDelayed;
    case LandmarkInit::kRing: return LandmarkInitialisation::kRing;
    case LandmarkInit::kInverseDistance: return LandmarkInitialisation::kInverseDistance;
    case LandmarkInit::kAuto: break;
  }
  return std::nullopt;
}

// The filters EkfSlam runs: a joint Gaussian over the vehicle and the map, in covariance or
// information form.
bool is_gaussian_estimator(FilterKind kind) {
  return kind == FilterKind::kEkf || kind == FilterKind::kUkf || kind == FilterKind::kEif ||
         kind == FilterKind::kSeif || kind == FilterKind::kEseif || kind == FilterKind::kTjtf;
}

// The filters in information form that take the EKF's linearisation settings (first estimates, the
// iterated update).
bool is_information_filter(FilterKind kind) {
  return kind == FilterKind::kEif || kind == FilterKind::kSeif || kind == FilterKind::kEseif;
}

// A sparse information filter's settings, valid, and left at their defaults by every other filter.
void require_sparse_information_settings(const FilterConfig& config, FilterKind kind,
                                         const SparseInformationOptions& options,
                                         const SparseInformationOptions& defaults) {
  const std::string prefix = to_string(kind);
  validate(options, prefix);
  if (config.filter != kind &&
      (options.active_landmarks != defaults.active_landmarks || options.recovery_sweeps != defaults.recovery_sweeps ||
       options.covariance != defaults.covariance))
    throw std::invalid_argument(fmt::format("{0}_active_landmarks, {0}_recovery_sweeps and {0}_covariance apply to "
                                            "the filter '{0}', not '{1}'",
                                            prefix, to_string(config.filter)));
}

}  // namespace

FilterKind parse_filter_kind(const std::string& name) { return parse_name(kFilterNames, name, "filter"); }
std::string to_string(FilterKind kind) { return name_of(kFilterNames, kind); }
EkfUpdate parse_ekf_update(const std::string& name) { return parse_name(kEkfUpdateNames, name, "EKF update"); }
std::string to_string(EkfUpdate update) { return name_of(kEkfUpdateNames, update); }
EkfVariant parse_ekf_variant(const std::string& name) { return parse_name(kEkfVariantNames, name, "EKF variant"); }
std::string to_string(EkfVariant variant) { return name_of(kEkfVariantNames, variant); }
UkfNoise parse_ukf_noise(const std::string& name) { return parse_name(kUkfNoiseNames, name, "UKF noise"); }
std::string to_string(UkfNoise noise) { return name_of(kUkfNoiseNames, noise); }
CovarianceRecovery parse_covariance_recovery(const std::string& name) {
  return parse_name(kCovarianceRecoveryNames, name, "covariance recovery");
}
std::string to_string(CovarianceRecovery recovery) { return name_of(kCovarianceRecoveryNames, recovery); }
LandmarkInit parse_landmark_init(const std::string& name) {
  return parse_name(kLandmarkInitNames, name, "landmark initialisation");
}
std::string to_string(LandmarkInit init) { return name_of(kLandmarkInitNames, init); }

std::vector<std::string> filter_names() {
  std::vector<std::string> names;
  for (const auto& n : kFilterNames) names.emplace_back(n.second);
  return names;
}

void validate(const FilterConfig& config) {
  if (config.particles < 1 || config.particles > FastSlamConfig::kMaxParticles)
    throw std::invalid_argument(fmt::format("particles must be an integer from 1 to {}, found {}",
                                            FastSlamConfig::kMaxParticles, config.particles));
  if (!(config.pose_sample_fraction > 0.0 && config.pose_sample_fraction <= 1.0))
    throw std::invalid_argument(
        fmt::format("pose_sample_fraction must lie in (0, 1], found {}", config.pose_sample_fraction));
  if (config.threads > FastSlamConfig::kMaxThreads)
    throw std::invalid_argument(fmt::format("threads must be from 0 (all cores) to {}, found {}",
                                            FastSlamConfig::kMaxThreads, config.threads));
  if (config.ekf_variant == EkfVariant::kUnscented || config.ekf_variant == EkfVariant::kInformation ||
      config.ekf_variant == EkfVariant::kSparseInformation ||
      config.ekf_variant == EkfVariant::kExactlySparseInformation ||
      config.ekf_variant == EkfVariant::kThinJunctionTree)
    throw std::invalid_argument("the unscented, information and junction tree estimators are the filters 'ukf', "
                                "'eif', 'seif', 'eseif' and 'tjtf', not EKF variants");
  if (is_gaussian_estimator(config.filter) && config.filter != FilterKind::kEkf &&
      config.ekf_variant != EkfVariant::kFull &&
      !(is_information_filter(config.filter) && config.ekf_variant == EkfVariant::kFirstEstimates))
    throw std::invalid_argument(fmt::format("EKF variant '{}' applies to the filter 'ekf'{}, not '{}'",
                                            to_string(config.ekf_variant),
                                            config.ekf_variant == EkfVariant::kFirstEstimates
                                                ? " and the information filters 'eif', 'seif' and 'eseif'"
                                                : "",
                                            to_string(config.filter)));
  if (config.ekf_update == EkfUpdate::kSequential && config.filter == FilterKind::kEseif)
    throw std::invalid_argument("EKF update 'sequential' does not apply to the filter 'eseif': a relocation needs the "
                                "scan's observations together");
  if (config.ekf_update == EkfUpdate::kIterated && !is_information_filter(config.filter) &&
      (config.filter != FilterKind::kEkf || config.ekf_variant == EkfVariant::kCompressed))
    throw std::invalid_argument("EKF update 'iterated' applies to the filter 'ekf' with the variant full, fej or "
                                "invariant, and to 'eif', 'seif' and 'eseif'");
  validate(config.association);
  require_sparse_information_settings(config, FilterKind::kSeif, config.seif, SeifOptions{});
  require_sparse_information_settings(config, FilterKind::kEseif, config.eseif, EseifOptions{});
  validate(config.tjtf);
  if (config.filter != FilterKind::kTjtf && config.tjtf.max_clique_landmarks != TjtfOptions{}.max_clique_landmarks)
    throw std::invalid_argument(
        fmt::format("tjtf_max_clique_landmarks applies to the filter 'tjtf', not '{}'", to_string(config.filter)));
  validate(config.grid);
  if (!is_grid_filter(config.filter) &&
      options_to_json<Grid>(config.grid, kGridKeys) != options_to_json<Grid>(GridSlamOptions{}, kGridKeys))
    throw std::invalid_argument(fmt::format("the grid settings apply to the filters 'scan-matching' and "
                                            "'grid-fastslam', not '{}'",
                                            to_string(config.filter)));
  validate(config.delayed_init);
  validate(config.inverse_distance);
  if (config.landmark_init == LandmarkInit::kInverseDistance &&
      !(config.filter == FilterKind::kEkf &&
        (config.ekf_variant == EkfVariant::kFull || config.ekf_variant == EkfVariant::kFirstEstimates)))
    throw std::invalid_argument("the inverse-distance start is kept by the filter 'ekf' with the variant full or fej");
  if (config.landmark_init != LandmarkInit::kInverseDistance &&
      (config.inverse_distance.min_distance_m != InverseDistanceOptions{}.min_distance_m ||
       config.inverse_distance.prior_distance_m != InverseDistanceOptions{}.prior_distance_m))
    throw std::invalid_argument(fmt::format("inverse_distance_min_m and inverse_distance_prior_m apply to the landmark "
                                            "start 'inverse-distance', not '{}'",
                                            to_string(config.landmark_init)));
  validate(config.likelihood);
  if (!config.likelihood.robust() && config.likelihood.dof != MeasurementLikelihood{}.dof)
    throw std::invalid_argument(fmt::format(
        "likelihood_dof ({}) applies to the likelihoods 'student-t' and 'student-t-long', not 'gaussian'",
        config.likelihood.dof));
  if (const std::optional<Calibration>& c = config.range_calibration) {
    if (!(c->offset_std_m > 0.0 && c->offset_std_m <= 1e4))
      throw std::invalid_argument(
          fmt::format("range_calibration.offset_std_m must be > 0 and <= 10000, found {}", c->offset_std_m));
    if (!(c->scale_error > -0.5 && c->scale_error < 0.5))
      throw std::invalid_argument(
          fmt::format("range_calibration.scale_error must be > -0.5 and < 0.5, found {}", c->scale_error));
    if (!(c->scale_error_std > 0.0 && c->scale_error_std <= 1.0))
      throw std::invalid_argument(
          fmt::format("range_calibration.scale_error_std must be > 0 and <= 1, found {}", c->scale_error_std));
    if (!(config.filter == FilterKind::kEkf && config.ekf_variant != EkfVariant::kCompressed) &&
        config.filter != FilterKind::kFastSlam2)
      throw std::invalid_argument("a range calibration is estimated by the filter 'ekf' with the variant full, fej or "
                                  "invariant, or by 'fastslam2'");
    if (config.association.method != AssociationMethod::kKnown)
      throw std::invalid_argument("a range calibration is estimated with association 'known': nn and jcbb predict "
                                  "measurements without it");
    if (config.landmark_init == LandmarkInit::kRing)
      throw std::invalid_argument("the ring landmark start does not carry a range calibration's correlations; with "
                                  "--range-calibration use the delayed start");
  }
}

std::unique_ptr<SlamFilter> make_filter(const FilterConfig& config, const Dataset& dataset) {
  validate(config);
  if (!is_grid_filter(config.filter) && !dataset.observation)
    throw InputError(dataset.spec, 0,
                     fmt::format("this dataset holds laser scans and no landmark observations, which the {} filter "
                                 "maps with: expected --filter scan-matching or grid-fastslam",
                                 to_string(config.filter)));
  switch (config.filter) {
    case FilterKind::kEkf:
    case FilterKind::kUkf:
    case FilterKind::kEif:
    case FilterKind::kSeif:
    case FilterKind::kEseif:
    case FilterKind::kTjtf: {
      EkfSlamOptions options;
      options.initial_pose = dataset.initial_pose;
      options.association = config.association;
      options.sensor = dataset.sensor;
      options.variant = config.filter == FilterKind::kUkf     ? EkfVariant::kUnscented
                        : config.filter == FilterKind::kEif   ? EkfVariant::kInformation
                        : config.filter == FilterKind::kSeif  ? EkfVariant::kSparseInformation
                        : config.filter == FilterKind::kEseif ? EkfVariant::kExactlySparseInformation
                        : config.filter == FilterKind::kTjtf  ? EkfVariant::kThinJunctionTree
                                                              : config.ekf_variant;
      options.seif = config.seif;
      options.eseif = config.eseif;
      options.tjtf = config.tjtf;
      options.joint_scan_update = config.ekf_update != EkfUpdate::kSequential;
      if (config.ekf_update == EkfUpdate::kIterated) options.update_iterations = kIteratedUpdateLinearisations;
      if (is_information_filter(config.filter) && config.ekf_variant == EkfVariant::kFirstEstimates)
        options.information_linearisation = Linearisation::kFirstEstimates;
      options.threads = config.threads;
      options.ukf_noise = config.ukf_noise;
      options.initialisation = landmark_initialisation(config.landmark_init);
      options.delayed_initialisation = config.delayed_init;
      options.inverse_distance = config.inverse_distance;
      options.range_calibration = config.range_calibration;
      options.likelihood = config.likelihood;
      return std::make_unique<EkfSlam>(dataset.motion, dataset.observation, options);
    }
    case FilterKind::kFastSlam1:
    case FilterKind::kFastSlam2: {
      FastSlamConfig fs;
      fs.version = config.filter == FilterKind::kFastSlam1 ? 1 : 2;
      fs.particles = config.particles;
      fs.pose_sample_fraction = config.pose_sample_fraction;
      fs.resample = config.resample;
      fs.policy = config.resample_when;
      fs.association = config.association;
      fs.seed = config.seed;
      fs.threads = config.threads;
      fs.initial_pose = dataset.initial_pose;
      fs.sensor = dataset.sensor;
      fs.initialisation = landmark_initialisation(config.landmark_init);
      fs.delayed_initialisation = config.delayed_init;
      fs.range_calibration = config.range_calibration;
      fs.likelihood = config.likelihood;
      return std::make_unique<FastSlam>(dataset.motion, dataset.observation, fs);
    }
    case FilterKind::kScanMatching:
      return std::make_unique<ScanMatchingFilter>(dataset.motion, dataset.initial_pose, config.grid);
    case FilterKind::kGridFastSlam: {
      GridFastSlamConfig grid;
      grid.slam = config.grid;
      grid.particles = config.particles;
      grid.seed = config.seed;
      grid.resample = config.resample;
      grid.resample_when = config.resample_when;
      grid.threads = config.threads;
      return std::make_unique<GridFastSlam>(dataset.motion, dataset.initial_pose, grid);
    }
  }
  throw std::invalid_argument("make_filter: unknown filter kind");
}

nlohmann::json to_json(const FilterConfig& config) {
  return {{"filter", to_string(config.filter)},
          {"seed", config.seed},
          {"association", to_json(config.association)},
          {"ekf_update", to_string(config.ekf_update)},
          {"ekf_variant", to_string(config.ekf_variant)},
          {"ukf_noise", to_string(config.ukf_noise)},
          {"seif_active_landmarks", config.seif.active_landmarks},
          {"seif_recovery_sweeps", config.seif.recovery_sweeps},
          {"seif_covariance", to_string(config.seif.covariance)},
          {"eseif_active_landmarks", config.eseif.active_landmarks},
          {"eseif_recovery_sweeps", config.eseif.recovery_sweeps},
          {"eseif_covariance", to_string(config.eseif.covariance)},
          {"tjtf_max_clique_landmarks", config.tjtf.max_clique_landmarks},
          {"landmark_init", to_string(config.landmark_init)},
          {"delayed_init", options_to_json<Delayed>(config.delayed_init, kDelayedInitKeys)},
          {"inverse_distance_min_m", config.inverse_distance.min_distance_m},
          {"inverse_distance_prior_m", config.inverse_distance.prior_distance_m},
          {"range_calibration", config.range_calibration
                                    ? options_to_json<Calibration>(*config.range_calibration, kRangeCalibrationKeys)
                                    : nlohmann::json(nullptr)},
          {"likelihood", to_string(config.likelihood.kind)},
          {"likelihood_dof", config.likelihood.dof},
          {"grid", options_to_json<Grid>(config.grid, kGridKeys)},
          {"particles", config.particles},
          {"pose_sample_fraction", config.pose_sample_fraction},
          {"resample", to_string(config.resample)},
          {"resample_when", to_string(config.resample_when)},
          {"threads", config.threads}};
}

FilterConfig filter_config_from_json(const nlohmann::json& json, const std::string& source) {
  FilterConfig config;
  read_filter_settings(json, source, config);
  try {
    validate(config);
  } catch (const std::invalid_argument& e) {
    throw InputError(source, 0, e.what());
  }
  return config;
}

void read_filter_settings(const nlohmann::json& json, const std::string& source, FilterConfig& config) {
  if (!json.is_object()) throw InputError(source, 0, "expected the filter settings as a JSON object");
  // Named variables, not a structured binding: clang 14 cannot capture a binding in the lambdas below.
  for (const auto& item : json.items()) {
    const std::string& key = item.key();
    const nlohmann::json& value = item.value();
    const auto name = [&] {
      if (!value.is_string()) throw InputError(source, 0, fmt::format("'{}' must be a name, found {}", key, value.dump()));
      return value.get<std::string>();
    };
    const auto integer = [&](auto& field) {
      using Int = std::remove_reference_t<decltype(field)>;
      const bool fits = value.is_number_unsigned() ? std::in_range<Int>(value.get<std::uint64_t>())
                                                   : value.is_number_integer() && std::in_range<Int>(value.get<std::int64_t>());
      if (!fits) throw InputError(source, 0, fmt::format("'{}' must be an integer in range, found {}", key, value.dump()));
      field = value.is_number_unsigned() ? static_cast<Int>(value.get<std::uint64_t>())
                                         : static_cast<Int>(value.get<std::int64_t>());
    };
    try {
      if (key == "filter")
        config.filter = parse_filter_kind(name());
      else if (key == "seed")
        integer(config.seed);
      else if (key == "association")
        read_association_settings(value, source, config.association);
      else if (key == "ekf_update")
        config.ekf_update = parse_ekf_update(name());
      else if (key == "ekf_variant")
        config.ekf_variant = parse_ekf_variant(name());
      else if (key == "ukf_noise")
        config.ukf_noise = parse_ukf_noise(name());
      else if (key == "seif_active_landmarks")
        integer(config.seif.active_landmarks);
      else if (key == "seif_recovery_sweeps")
        integer(config.seif.recovery_sweeps);
      else if (key == "seif_covariance")
        config.seif.covariance = parse_covariance_recovery(name());
      else if (key == "eseif_active_landmarks")
        integer(config.eseif.active_landmarks);
      else if (key == "eseif_recovery_sweeps")
        integer(config.eseif.recovery_sweeps);
      else if (key == "eseif_covariance")
        config.eseif.covariance = parse_covariance_recovery(name());
      else if (key == "tjtf_max_clique_landmarks")
        integer(config.tjtf.max_clique_landmarks);
      else if (key == "landmark_init")
        config.landmark_init = parse_landmark_init(name());
      else if (key == "delayed_init")
        read_delayed_init(value, source, config.delayed_init);
      else if (key == "grid")
        read_grid_settings(value, source, config.grid);
      else if (key == "inverse_distance_min_m") {
        if (!value.is_number())
          throw InputError(source, 0, fmt::format("'{}' must be a number, found {}", key, value.dump()));
        config.inverse_distance.min_distance_m = value.get<double>();
      } else if (key == "inverse_distance_prior_m") {
        if (!value.is_number())
          throw InputError(source, 0, fmt::format("'{}' must be a number, found {}", key, value.dump()));
        config.inverse_distance.prior_distance_m = value.get<double>();
      } else if (key == "range_calibration")
        read_range_calibration(value, source, config.range_calibration);
      else if (key == "likelihood")
        config.likelihood.kind = parse_likelihood_kind(name());
      else if (key == "likelihood_dof") {
        if (!value.is_number())
          throw InputError(source, 0, fmt::format("'{}' must be a number, found {}", key, value.dump()));
        config.likelihood.dof = value.get<double>();
      } else if (key == "particles")
        integer(config.particles);
      else if (key == "pose_sample_fraction") {
        if (!value.is_number())
          throw InputError(source, 0, fmt::format("'{}' must be a number, found {}", key, value.dump()));
        config.pose_sample_fraction = value.get<double>();
      } else if (key == "resample")
        config.resample = parse_resample_method(name());
      else if (key == "resample_when")
        config.resample_when = parse_resample_policy(name());
      else if (key == "threads")
        integer(config.threads);
      else {
        const std::vector<std::string> keys = {"filter",
                                               "seed",
                                               "association",
                                               "ekf_update",
                                               "ekf_variant",
                                               "ukf_noise",
                                               "seif_active_landmarks",
                                               "seif_recovery_sweeps",
                                               "seif_covariance",
                                               "eseif_active_landmarks",
                                               "eseif_recovery_sweeps",
                                               "eseif_covariance",
                                               "tjtf_max_clique_landmarks",
                                               "landmark_init",
                                               "delayed_init",
                                               "inverse_distance_min_m",
                                               "inverse_distance_prior_m",
                                               "range_calibration",
                                               "likelihood",
                                               "likelihood_dof",
                                               "grid",
                                               "particles",
                                               "pose_sample_fraction",
                                               "resample",
                                               "resample_when",
                                               "threads"};
        throw InputError(source, 0,
                         fmt::format("unknown key '{}' in the filter settings{}; expected one of: {}", key,
                                     did_you_mean(key, keys), fmt::join(keys, ", ")));
      }
    } catch (const std::invalid_argument& e) {
      throw InputError(source, 0, e.what());
    }
  }
}

}  // namespace slamkit
