#include "slamkit/filters/ekf_slam.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "slamkit/core/chi_square.hpp"
#include "slamkit/eval/metrics.hpp"
#include "slamkit/filters/compressed_joint_gaussian.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/filters/extended_information_filter.hpp"
#include "slamkit/filters/unscented_joint_gaussian.hpp"

namespace slamkit {

namespace {

std::unique_ptr<EkfEstimator> make_estimator(std::shared_ptr<const MotionModel> motion,
                                             std::shared_ptr<const ObservationModel> observation,
                                             const EkfSlamOptions& options) {
  const InformationLinearisation information_linearisation{options.information_linearisation,
                                                           options.update_iterations};
  switch (options.variant) {
    case EkfVariant::kCompressed:
      return std::make_unique<CompressedJointGaussian>(std::move(motion), std::move(observation),
                                                       options.sensor.max_range, options.local_area_side,
                                                       options.initial_pose, options.initial_covariance);
    case EkfVariant::kUnscented:
      return std::make_unique<UnscentedJointGaussian>(std::move(motion), std::move(observation),
                                                      options.initial_pose, options.initial_covariance,
                                                      options.ukf_noise);
    case EkfVariant::kInformation:
      return std::make_unique<ExtendedInformationFilter>(std::move(motion), std::move(observation),
                                                         options.initial_pose, options.initial_covariance,
                                                         information_linearisation);
    case EkfVariant::kSparseInformation:
      return std::make_unique<SparseExtendedInformationFilter>(std::move(motion), std::move(observation),
                                                               options.initial_pose, options.initial_covariance,
                                                               options.seif, information_linearisation);
    case EkfVariant::kExactlySparseInformation:
      return std::make_unique<ExactlySparseInformationFilter>(std::move(motion), std::move(observation),
                                                              options.initial_pose, options.initial_covariance,
                                                              options.eseif, information_linearisation);
    case EkfVariant::kThinJunctionTree:
      return std::make_unique<ThinJunctionTreeFilter>(std::move(motion), std::move(observation), options.initial_pose,
                                                      options.initial_covariance, options.tjtf);
    case EkfVariant::kFirstEstimates:
    case EkfVariant::kInvariant:
    case EkfVariant::kFull:
      break;
  }
  const Linearisation linearisation = options.variant == EkfVariant::kFirstEstimates ? Linearisation::kFirstEstimates
                                      : options.variant == EkfVariant::kInvariant   ? Linearisation::kInvariant
                                                                                    : Linearisation::kStandard;
  return std::make_unique<JointGaussian>(std::move(motion), std::move(observation), options.initial_pose,
                                         options.initial_covariance, linearisation, options.update_iterations);
}

std::unique_ptr<EkfEstimator> with_range_calibration(std::unique_ptr<EkfEstimator> estimator,
                                                     const EkfSlamOptions& options) {
  if (options.range_calibration) estimator->estimate_range_calibration(*options.range_calibration);
  return estimator;
}

}  // namespace

EkfSlam::EkfSlam(std::shared_ptr<const MotionModel> motion, std::shared_ptr<const ObservationModel> observation,
                 const EkfSlamOptions& options)
    : EkfSlam(with_range_calibration(make_estimator(std::move(motion), std::move(observation), options), options),
              {}, options) {
  estimator_->use_threads(options.threads);
}

EkfSlam::EkfSlam(std::unique_ptr<EkfEstimator> estimator, std::span<const int> ids, const EkfSlamOptions& options)
    : estimator_(estimator ? std::move(estimator) : throw std::invalid_argument("EkfSlam needs an estimator")),
      association_((validate(options.association), options.association)),
      gates_(Gates::from(options.association, estimator_->observation_model().dim())),
      gate_known_(options.association.gate_known.value_or(true)),
      likelihood_((validate(options.likelihood), options.likelihood)),
      association_view_((validate(options.sensor), association_view(options.sensor, options.association))),
      clutter_density_(clutter_density(options.association, options.sensor, estimator_->observation_model())),
      existence_rule_(options.association, options.sensor),
      pending_(options.association, options.sensor, estimator_->observation_model()),
      // Cells of a third of the sensor range: a query touches a few dozen cells at most.
      grid_(std::max(5.0, options.sensor.max_range / 3.0)),
      relocalise_(options.association.method != AssociationMethod::kKnown &&
                  options.association.relocalise_min_pairs >= 2),
      // The copies are placed by inverting a measurement.
      recover_known_(options.association.method == AssociationMethod::kKnown && gate_known_ &&
                     options.association.relocalise_min_pairs >= 2 && estimator_->observation_model().invertible()),
      joint_scan_update_(options.joint_scan_update),
      name_(options.variant == EkfVariant::kUnscented                  ? "ukf"
            : options.variant == EkfVariant::kInformation              ? "eif"
            : options.variant == EkfVariant::kSparseInformation        ? "seif"
            : options.variant == EkfVariant::kExactlySparseInformation ? "eseif"
            : options.variant == EkfVariant::kThinJunctionTree         ? "tjtf"
                                                                       : "ekf") {
  require_searchable(association_, estimator_->observation_model());
  if (estimator_->calibrates_ranges() && association_.method != AssociationMethod::kKnown)
    throw std::invalid_argument("a range calibration is estimated with association 'known': nn and jcbb predict "
                                "measurements without it");
  const DelayedInitialisationOptions delayed =
      expecting_outliers_of(options.delayed_initialisation, likelihood_, estimator_->observation_model());
  reach_ = options.sensor.max_range;
  if (options.initialisation == LandmarkInitialisation::kInverseDistance) {
    if (!estimator_->keeps_inverse_distance())
      throw std::invalid_argument("the inverse-distance start is kept by the filter 'ekf' with the variant full or fej");
    require_bearing_only(estimator_->observation_model(), "the inverse-distance start");
    validate(options.inverse_distance);
    inverse_distance_ = options.inverse_distance;
  } else {
    initialiser_ = make_landmark_initialiser(options.initialisation, estimator_->shared_observation_model(),
                                             association_.method == AssociationMethod::kKnown,
                                             estimator_->calibrates_ranges(), delayed, options.ring_initialisation);
  }
  if (ids.size() != estimator_->num_landmarks())
    throw std::invalid_argument("EkfSlam: one id per landmark of the estimator");
  for (const int id : ids) {
    if (id == kUnknownId || find_landmark(id) >= 0)
      throw std::invalid_argument("EkfSlam: landmark id " + std::to_string(id) + " is unknown or repeated");
    register_landmark(id, existence_rule_.given());
    next_id_ = std::max(next_id_, id + 1);
  }
  first_started_id_ = next_id_;
  dead_reckoning_.pose = estimator_->pose();
}

std::vector<Landmark> EkfSlam::landmarks() const {
  std::vector<Vector2> means;
  std::vector<Matrix2> covariances;
  estimator_->landmark_marginals(means, covariances);
  std::vector<Landmark> out;
  out.reserve(ids_.size());
  for (std::size_t i = 0; i < ids_.size(); ++i)
    if (existence_rule_.confirmed(existence_[i]) && !estimator_->at_inverse_distance(i))
      out.push_back(Landmark{ids_[i], means[i], covariances[i]});
  return out;
}

std::vector<LandmarkHypothesis> EkfSlam::landmark_hypotheses() const {
  if (initialiser_) return hypotheses_at(*initialiser_, dead_reckoning_, estimator_->pose());
  std::vector<LandmarkHypothesis> out;
  if (!inverse_distance_) return out;
  // A landmark at inverse distance is not yet a point of the map; where its distance is within the
  // sensor's reach, the Gaussian over the point it stands for shows where along the ray it may be.
  const Vector2 sensor = estimator_->observation_model().sensor_position(estimator_->pose());
  for (std::size_t i = 0; i < ids_.size(); ++i) {
    if (!estimator_->at_inverse_distance(i)) continue;
    const Vector2 position = estimator_->landmark_position(i);
    if ((position - sensor).norm() <= reach_)
      out.push_back({Landmark{ids_[i], position, estimator_->landmark_covariance(i)}, 1.0});
  }
  return out;
}

double EkfSlam::memory_estimate(std::size_t landmarks) {
  // The covariance lives in a square buffer (of which updates use the lower triangle).
  const double n = 3.0 + 2.0 * static_cast<double>(landmarks);
  return n * n * static_cast<double>(sizeof(double));
}

std::map<std::string, double> EkfSlam::statistics() const {
  std::map<std::string, double> s = {{"discarded_observations", static_cast<double>(discarded_)},
                                     {"landmarks_removed", static_cast<double>(removed_)},
                                     {"landmarks_in_state", static_cast<double>(ids_.size())},
                                     {"landmarks_provisional", static_cast<double>(provisional())}};
  estimator_->add_statistics(s);
  if (association_.method == AssociationMethod::kKnown && gate_known_) gate_tally_.add_statistics(s);
  if (recover_known_) s["known_id_recoveries"] = static_cast<double>(known_recoveries_);
  if (inverse_distance_) s["inverse_distance_restarts"] = static_cast<double>(inverse_distance_restarts_);
  if (estimator_->calibrates_ranges()) {
    const RangeCorrection c = estimator_->range_correction();
    const Matrix2 covariance = estimator_->range_correction_covariance();
    s["range_offset_m"] = c.offset_m;
    s["range_offset_std_m"] = std::sqrt(covariance(0, 0));
    s["range_scale_error"] = c.scale_error;
    s["range_scale_error_std"] = std::sqrt(covariance(1, 1));
  }
  if (initialiser_) {
    s["observations_pending"] = static_cast<double>(observations_waiting_);
    s["landmarks_pending"] = static_cast<double>(initialiser_->waiting());
  }
  if (association_.method != AssociationMethod::kKnown)
    s["association_pairs_evaluated"] = static_cast<double>(association_stats_.candidate_pairs);
  if (association_.method != AssociationMethod::kKnown && pending_.active()) {
    s["observations_pending"] = static_cast<double>(pending_observations_);
    s["landmarks_pending"] = static_cast<double>(pending_.size());
  }
  if (relocalise_) {
    s["relocalisations"] = static_cast<double>(relocalisations_);
    s["landmarks_fused"] = static_cast<double>(landmarks_fused_);
    s["map_match_pairs_tested"] = static_cast<double>(map_match_stats_.pairs_tested);
  }
  if (association_.method == AssociationMethod::kJcbb) {
    s["jcbb_nodes"] = static_cast<double>(association_stats_.jcbb_nodes);
    s["jcbb_budget_exhausted"] = association_stats_.jcbb_budget_exhausted ? 1.0 : 0.0;
  }
  return s;
}

std::size_t EkfSlam::provisional() const {
  return static_cast<std::size_t>(std::count_if(existence_.begin(), existence_.end(),
                                                [&](const auto& e) { return !existence_rule_.confirmed(e); }));
}

long EkfSlam::find_landmark(int id) const {
  const auto it = index_of_id_.find(id);
  return it == index_of_id_.end() ? -1 : static_cast<long>(it->second);
}

void EkfSlam::predict(const ControlEvent& control) {
  if (initialiser_) dead_reckoning_.advance(estimator_->motion_model(), control.u, control.dt);
  estimator_->predict(control.u, control.dt);
}

void EkfSlam::add_landmark(const Measurement& z, int id) {
  estimator_->add_landmark(z);
  register_landmark(id, association_.method == AssociationMethod::kKnown ? existence_rule_.given()
                                                                         : existence_rule_.first_observed());
}

void EkfSlam::register_landmark(int id, const LandmarkExistence& existence) {
  const std::size_t index = ids_.size();
  ids_.push_back(id);
  if (id != kUnknownId) index_of_id_[id] = index;
  existence_.push_back(existence);
  started_.push_back(now_);
  last_seen_.push_back(now_);
  binned_.push_back(grid_.cell_of(estimator_->landmark_position(index)));
  grid_.insert(binned_.back(), static_cast<std::uint32_t>(index));
}

void EkfSlam::remove_landmark(std::size_t index) {
  estimator_->remove_landmark(index);
  const int id = ids_[index];
  ids_.erase(ids_.begin() + static_cast<std::ptrdiff_t>(index));
  existence_.erase(existence_.begin() + static_cast<std::ptrdiff_t>(index));
  started_.erase(started_.begin() + static_cast<std::ptrdiff_t>(index));
  last_seen_.erase(last_seen_.begin() + static_cast<std::ptrdiff_t>(index));
  if (id != kUnknownId) index_of_id_.erase(id);
  for (auto& [key, i] : index_of_id_)
    if (i > index) --i;
  rebuild_grid();
}

void EkfSlam::rebuild_grid() {
  grid_.clear();
  binned_.resize(ids_.size());
  for (std::size_t i = 0; i < ids_.size(); ++i) {
    binned_[i] = grid_.cell_of(estimator_->landmark_position(i));
    grid_.insert(binned_[i], static_cast<std::uint32_t>(i));
  }
}

void EkfSlam::rebin(std::size_t index) {
  const LandmarkGrid::Cell cell = grid_.cell_of(estimator_->landmark_position(index));
  if (cell == binned_[index]) return;
  grid_.erase(binned_[index], static_cast<std::uint32_t>(index));
  grid_.insert(cell, static_cast<std::uint32_t>(index));
  binned_[index] = cell;
}

void EkfSlam::update(const ScanEvent& scan) {
  last_associations_.assign(scan.observations.size(), AssociationRecord{});
  now_ = scan.t;
  ++scans_;
  if (first_scan_) {
    // The start pose is known relative to the map (a map given to the constructor included), so the
    // vehicle starts anchored to it.
    first_scan_ = false;
    anchored_until_ = now_ + association_.relocalise_window_s;
  }
  estimator_->begin_scan();
  if (association_.method == AssociationMethod::kKnown)
    update_known(scan);
  else
    update_unknown(scan);
}

double EkfSlam::innovation_distance(std::size_t index, const Measurement& z) const {
  Measurement zhat;
  MeasurementCovariance s;
  estimator_->innovation(index, zhat, s);
  const ObservationModel& model = estimator_->observation_model();
  return with_measurement_dim(model.dim(), [&]<int D>(std::integral_constant<int, D>) {
    const MeasurementVector<D> nu = model.residual(z, zhat);
    return nu.dot(MeasurementSquare<D>(s).ldlt().solve(nu));
  });
}

LandmarkObservation EkfSlam::weighed(std::size_t index, const Measurement& z, std::optional<double> distance) const {
  if (!likelihood_.robust()) return {index, z};
  const double m2 = distance ? *distance : innovation_distance(index, z);
  return {index, z, likelihood_.noise_inflation(m2, estimator_->observation_model().dim())};
}

void EkfSlam::update_known(const ScanEvent& scan) {
  new_observations_.clear();
  rejected_.clear();
  restarts_.clear();
  std::size_t judged = 0, rejected = 0;
  auto apply = [&](std::size_t k, std::size_t index) {
    if (estimator_->beyond_linear_reach(index)) {
      restarts_.push_back(k);
      return;
    }
    std::optional<double> distance;
    if (gate_known_) {
      ++judged;
      distance = innovation_distance(index, scan.observations[k].z);
      if (!(*distance <= gates_.new_landmark)) {
        ++rejected;
        if (estimator_->at_inverse_distance(index))
          restarts_.push_back(k);
        else if (recover_known_)
          rejected_.push_back(k);  // discarded; recover_known keeps a copy
        else
          ++discarded_;
        return;
      }
      // A landmark the gate accepts again has no use for a copy: one misread earlier must not pair
      // with another outlier later.
      if (!copies_.empty()) copies_.erase(ids_[index]);
    }
    const LandmarkObservation observation = weighed(index, scan.observations[k].z, distance);
    if (joint_scan_update_) {
      batch_.push_back(observation);
      last_associations_[k] = {AssociationDecision::kUpdate, ids_[index]};
      existence_rule_.observed(existence_[index]);
    } else if (estimator_->update_landmark(observation)) {
      last_associations_[k] = {AssociationDecision::kUpdate, ids_[index]};
      existence_rule_.observed(existence_[index]);
    } else {
      ++discarded_;
    }
  };
  batch_.clear();
  if (gate_known_) {
    candidates_.clear();
    for (const Observation& obs : scan.observations)
      if (const long index = obs.id == kUnknownId ? -1 : find_landmark(obs.id); index >= 0)
        candidates_.push_back(static_cast<std::size_t>(index));
    estimator_->prepare_covariances(candidates_);
  }
  for (std::size_t k = 0; k < scan.observations.size(); ++k) {
    const Observation& obs = scan.observations[k];
    if (obs.id == kUnknownId) {
      ++discarded_;  // a detection without identity (e.g. clutter) cannot be placed by its id
      continue;
    }
    const long index = find_landmark(obs.id);
    if (index >= 0)
      apply(k, static_cast<std::size_t>(index));
    else
      new_observations_.push_back(k);
  }
  apply_joint_batch();
  // A landmark at inverse distance starts again from this bearing where the bearing is beyond its
  // linear reach (seen again from far off its origin before its distance is known: one update
  // would place it by a linearisation that stands for none of the distances it allows), or where
  // the gate rejects the bearing (it went astray while its distance was still a guess: an update
  // linearised at a rho far from the truth can pin rho down at a wrong value, and the gate then
  // rejects every later bearing). It is not yet a point of the map.
  for (const std::size_t k : restarts_) {
    const long index = find_landmark(scan.observations[k].id);
    if (index >= 0) {  // not when seen twice in the scan
      remove_landmark(static_cast<std::size_t>(index));
      ++inverse_distance_restarts_;
    }
    new_observations_.push_back(k);
  }
  // New landmarks are added after the scan's updates, so they start from the best pose estimate.
  for (const std::size_t k : new_observations_) {
    const Observation& obs = scan.observations[k];
    const long index = find_landmark(obs.id);
    if (index >= 0) {
      apply(k, static_cast<std::size_t>(index));  // seen twice in one scan
    } else if (inverse_distance_) {
      estimator_->add_inverse_distance_landmark(obs.z, *inverse_distance_);
      register_landmark(obs.id, existence_rule_.given());
      last_associations_[k] = {AssociationDecision::kNew, obs.id};
    } else if (!initialiser_) {
      add_landmark(obs.z, obs.id);
      last_associations_[k] = {AssociationDecision::kNew, obs.id};
    } else if (const std::optional<InitialLandmark> placed =
                   initialiser_->offer(obs.id, dead_reckoning_.pose, dead_reckoning_.covariance, obs.z, now_,
                                       estimator_->range_correction())) {
      estimator_->add_landmark(dead_reckoning_.carried_to(estimator_->pose(), *placed));
      register_landmark(obs.id, existence_rule_.given());
      last_associations_[k] = {AssociationDecision::kNew, obs.id};
    } else {
      ++observations_waiting_;
      last_associations_[k] = {AssociationDecision::kPending, obs.id};
    }
  }
  apply_joint_batch();
  if (recover_known_) {
    if (!recent_verdicts_.empty() && recent_verdicts_.back().t == now_) {
      recent_verdicts_.back().judged += judged;  // scans at one time are one entry
      recent_verdicts_.back().rejected += rejected;
    } else {
      recent_verdicts_.push_back({now_, judged, rejected});
    }
    recover_known(scan);
  }
  gate_tally_.add_scan(scan.t, judged, rejected);
}

void EkfSlam::recover_known(const ScanEvent& scan) {
  const ObservationModel& model = estimator_->observation_model();
  const Pose2 xv = estimator_->pose();
  for (const std::size_t k : rejected_) {
    const Observation& obs = scan.observations[k];
    Measurement distance = obs.z;
    if (estimator_->calibrates_ranges())
      distance[model.rows().range] = estimator_->range_correction().distance(obs.z[model.rows().range]);
    const InitialLandmark placed = *inverted_landmark(model, xv, distance);
    ++discarded_;
    // The latest observation places the copy: the one nearest in time to the others'. Its error
    // from the pose is what the rigid motion is fitted to, so the fit's residuals carry only the
    // measurement's.
    copies_[obs.id] = {static_cast<std::size_t>(find_landmark(obs.id)), placed.mean, placed.covariance, now_};
  }
  // A copy not seen again for the window is forgotten: most likely a single outlier.
  const double forget_before = now_ - association_.relocalise_window_s;
  std::erase_if(copies_, [&](const auto& entry) { return entry.second.seen < forget_before; });
  // Dropped from the front of a vector: a window holds a few hundred scans at most, and once its
  // capacity has grown to one window nothing is allocated again.
  const auto expired = std::find_if(recent_verdicts_.begin(), recent_verdicts_.end(),
                                    [&](const GateVerdicts& v) { return v.t >= forget_before; });
  recent_verdicts_.erase(recent_verdicts_.begin(), expired);
  if (copies_.size() < association_.relocalise_min_pairs) return;
  // A filter that still accepts most of what it sees is steered by that; only one whose gate rejects
  // most observations over the window has lost itself.
  std::size_t judged = 0, rejected = 0;
  for (const GateVerdicts& v : recent_verdicts_) {
    judged += v.judged;
    rejected += v.rejected;
  }
  if (2 * rejected <= judged) return;
  const std::optional<Matrix3> missing_noise = drift_the_copies_show();
  if (!missing_noise) return;
  // Once the pose admits its drift, the originals pass the gate again and correct it.
  estimator_->inflate_pose(*missing_noise);
  copies_.clear();
  ++known_recoveries_;
}

std::optional<Matrix3> EkfSlam::drift_the_copies_show() {
  // The rigid motion that best carries the copies onto their originals, and the residuals against the
  // copy's and the original's covariances.
  copy_positions_.clear();
  original_positions_.clear();
  for (const auto& [id, copy] : copies_) {
    copy_positions_.push_back(copy.position);
    original_positions_.push_back(estimator_->landmark_position(copy.original));
  }
  const eval::Se2Transform motion = eval::align_se2(copy_positions_, original_positions_);
  Matrix2 r;
  r << std::cos(motion.theta), -std::sin(motion.theta), std::sin(motion.theta), std::cos(motion.theta);
  double d2 = 0.0;
  for (const auto& [id, copy] : copies_) {
    const Vector2 residual = estimator_->landmark_position(copy.original) - motion.apply(copy.position);
    const Matrix2 covariance = r * copy.covariance * r.transpose() + estimator_->landmark_covariance(copy.original);
    d2 += residual.dot(covariance.ldlt().solve(residual));
  }
  const double k = static_cast<double>(copies_.size());
  // 2 coordinates per copy, less the rigid motion's 3 (written so that a NaN fails).
  if (!(d2 <= eval::chi_square_quantile(association_.accept_probability, 2.0 * k - 3.0))) return std::nullopt;
  // Where the same motion carries the vehicle: its error. Only one the filter's pose covariance does
  // not admit (beyond its new-landmark gate, 3 dof) says the filter is lost; a smaller one is the
  // gate's own business.
  const Pose2 xv = estimator_->pose();
  const Vector2 shift = motion.apply(Vector2(xv.head<2>())) - xv.head<2>();
  const Eigen::Vector3d error(shift.x(), shift.y(), motion.theta);
  const double admitted = error.dot(estimator_->pose_covariance().ldlt().solve(error));
  if (!(admitted > eval::chi_square_quantile(association_.new_landmark_probability, 3.0))) return std::nullopt;
  // Taken as one standard deviation of the process noise the filter lacked.
  return error.cwiseAbs2().asDiagonal().toDenseMatrix();
}

void EkfSlam::apply_joint_batch() {
  if (batch_.empty()) return;
  // A joint innovation covariance that is not positive definite: fall back to one at a time.
  if (!estimator_->update_landmarks(batch_))
    for (const LandmarkObservation& o : batch_) estimator_->update_landmark(o);
  batch_.clear();
}

void EkfSlam::find_candidates(const SensorView& view) {
  candidates_.clear();
  if (ids_.empty()) return;
  const Pose2 xv = estimator_->pose();
  // The grid bins landmarks where they were last re-binned; one extra cell covers the drift since.
  grid_.query(xv.head<2>(), view.reach() + grid_.cell_size(), nearby_);
  const ObservationModel& model = estimator_->observation_model();
  for (const std::uint32_t j : nearby_)
    if (!held_back(j) && view.contains(model, xv, estimator_->landmark_position(j))) candidates_.push_back(j);
  std::sort(candidates_.begin(), candidates_.end());
}

const std::vector<Pairing>& EkfSlam::associate_scan(const ScanEvent& scan) {
  find_candidates(association_view_);
  estimator_->prepare_covariances(candidates_);
  associate(scan.observations, candidates_, *estimator_, estimator_->observation_model(), association_,
            association_workspace_, pairings_, &association_stats_, clutter_density_);
  return pairings_;
}

void EkfSlam::update_unknown(const ScanEvent& scan) {
  const std::vector<Pairing>& pairings = associate_scan(scan);

  const Vector2 position_before = estimator_->pose().head<2>();
  seen_.assign(ids_.size(), false);
  batch_.clear();
  for (std::size_t k = 0; k < pairings.size(); ++k) {
    if (pairings[k].decision != AssociationDecision::kUpdate) continue;
    const std::size_t index = pairings[k].landmark;
    const LandmarkObservation observation = weighed(index, scan.observations[k].z);
    if (joint_scan_update_)
      batch_.push_back(observation);
    else if (!estimator_->update_landmark(observation))
      continue;
    last_associations_[k] = {AssociationDecision::kUpdate, ids_[index]};
    seen_[index] = true;
    const bool was_confirmed = existence_rule_.confirmed(existence_[index]);
    existence_rule_.observed(existence_[index]);
    if (relocalise_) {
      const double window = association_.relocalise_window_s;
      // Recognised directly while anchored: the old map around the vehicle is still verified.
      if (last_seen_[index] < now_ - window) anchored_until_ = now_ + window;
      if (!was_confirmed && existence_rule_.confirmed(existence_[index]) && started_[index] >= now_ - window)
        recent_confirmed_ = true;
    }
    last_seen_[index] = now_;
  }
  apply_joint_batch();
  pending_.begin_scan(now_, estimator_->pose());
  for (std::size_t k = 0; k < pairings.size(); ++k) {
    if (pairings[k].decision == AssociationDecision::kNew) {
      const int detections =
          pending_.offer(scan.observations[k].z, estimator_->observation_model(),
                         static_cast<std::size_t>(next_id_ - first_started_id_), scans_);
      if (detections == 0) {
        ++pending_observations_;
        continue;
      }
      const int id = next_id_++;
      add_landmark(scan.observations[k].z, id);
      for (int d = 1; d < detections; ++d) existence_rule_.observed(existence_.back());
      last_associations_[k] = {AssociationDecision::kNew, id};
    } else if (last_associations_[k].decision == AssociationDecision::kDiscard) {
      ++discarded_;
    }
  }

  // Keep the grid honest: the landmarks just updated moved the most; a large vehicle correction
  // (a loop closure) moved the whole map, so then the grid is rebuilt.
  for (const std::size_t j : candidates_) rebin(j);
  drift_since_rebuild_ += (estimator_->pose().head<2>() - position_before).norm();
  if (drift_since_rebuild_ > 0.5 * grid_.cell_size()) {
    rebuild_grid();
    drift_since_rebuild_ = 0.0;
  }
  manage_map();
  pending_.end_scan(estimator_->observation_model(), existence_rule_.detection_view());
  // A fusion moves the vehicle and the map, which may bring further duplicates into the gate.
  if (recent_confirmed_)
    while (relocalise()) {
    }
  recent_confirmed_ = false;
}

bool EkfSlam::held_back(std::size_t index) const {
  return relocalise_ && now_ > anchored_until_ && last_seen_[index] < now_ - association_.relocalise_window_s &&
         existence_rule_.confirmed(existence_[index]);
}

bool EkfSlam::relocalise() {
  const double window_start = now_ - association_.relocalise_window_s;
  recent_.clear();
  old_.clear();
  for (std::size_t j = 0; j < ids_.size(); ++j) {
    if (!existence_rule_.confirmed(existence_[j])) continue;
    if (started_[j] >= window_start)
      recent_.push_back(j);
    else if (last_seen_[j] < window_start)
      old_.push_back(j);
  }
  if (recent_.size() < association_.relocalise_min_pairs || old_.empty()) return false;
  const std::vector<LandmarkPair>& pairs = map_matcher_.match(
      recent_, old_, *estimator_, association_.accept_probability, association_.jcbb_max_nodes, &map_match_stats_);
  if (pairs.size() < association_.relocalise_min_pairs || !estimator_->fuse_landmarks(pairs)) return false;
  for (const LandmarkPair& p : pairs) {
    existence_rule_.observed(existence_[p.original]);
    last_seen_[p.original] = now_;
  }
  // Highest index first, so the indices still to remove stay valid.
  fused_pairs_.assign(pairs.begin(), pairs.end());
  std::sort(fused_pairs_.begin(), fused_pairs_.end(),
            [](const LandmarkPair& a, const LandmarkPair& b) { return a.duplicate > b.duplicate; });
  for (const LandmarkPair& p : fused_pairs_) remove_landmark(p.duplicate);
  anchored_until_ = now_ + association_.relocalise_window_s;
  ++relocalisations_;
  landmarks_fused_ += fused_pairs_.size();
  return true;
}

void EkfSlam::manage_map() {
  find_candidates(association_view_);
  doomed_.clear();
  const Pose2 xv = estimator_->pose();
  const ObservationModel& model = estimator_->observation_model();
  for (const std::size_t j : candidates_) {
    if (j >= seen_.size() || seen_[j]) continue;  // added this scan, or seen
    const bool expected = existence_rule_.detection_view().contains(model, xv, estimator_->landmark_position(j));
    if (expected ? existence_rule_.missed(existence_[j]) : existence_rule_.unseen_nearby(existence_[j]))
      doomed_.push_back(j);
  }
  // Highest index first, so the indices still to remove stay valid.
  for (auto it = doomed_.rbegin(); it != doomed_.rend(); ++it) {
    remove_landmark(*it);
    ++removed_;
  }
}

}  // namespace slamkit
