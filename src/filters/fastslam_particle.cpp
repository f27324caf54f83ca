// One particle's scan in FastSLAM 1.0 and 2.0: association (or the known identities and their
// outlier gate), the proposal of eq. (18), the landmark updates, the weight (eqs. 15 and 17) and the
// misses of the existence rule. The filter around it is in fastslam.cpp.
#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <numeric>

#include "fastslam_impl.hpp"
#include "slamkit/core/angles.hpp"
#include "slamkit/core/chi_square.hpp"

namespace slamkit {

using namespace fastslam_detail;

namespace {

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

/// A predicted measurement read through a range calibration c = (offset b, scale error s): its range
/// row, a distance d, becomes (1 + s) d + b, that row's Jacobians scale with it, and hc, the
/// Jacobian in c, is (1, d) there.
template <int D>
void read_through(const Vector2& c, int row, MeasurementVector<D>& zhat, PoseRows<D>& hx, LandmarkRows<D>& hm,
                  CalibrationRows<D>& hc) {
  hc.setZero();
  hc(row, 0) = 1.0;
  hc(row, 1) = zhat[row];
  zhat[row] = RangeCorrection{c[0], c[1]}.range(zhat[row]);
  hx.row(row) *= 1.0 + c[1];
  hm.row(row) *= 1.0 + c[1];
}

}  // namespace

Vector2 FastSlam::Impl::mean_at(const Particle& p, std::uint32_t index, const Vector2& c) const {
  const CalibrationLink& link = p.links[index];
  return p.map[index].mean + link.gain * (c - link.at);
}

template <int D>
MeasurementVector<D> FastSlam::Impl::predict_given(const Particle& p, std::uint32_t index, const Pose2& x,
                                                   const Vector2& c, PoseRows<D>& hx, LandmarkRows<D>& hm,
                                                   CalibrationRows<D>& hc) const {
  const MeasurementKernels<D>& k = kernels.get<D>();
  const Vector2 m = mean_at(p, index, c);
  k.jacobians(x, m, hx, hm);
  MeasurementVector<D> zhat = k.predict(x, m);
  read_through(c, range_row, zhat, hx, hm, hc);
  return zhat;
}

template <int D>
MeasurementSquare<D> FastSlam::Impl::innovation_covariance(const Particle& p, const LandmarkGaussian& lm,
                                                           PoseRows<D>& hx, LandmarkRows<D>& hm) const {
  // At the pose as predicted: for FastSLAM 2.0 its covariance enters S, as the proposal's
  // uncertainty should when judging whether an observation fits a landmark.
  const MeasurementKernels<D>& k = kernels.get<D>();
  k.jacobians(p.pose, lm.mean, hx, hm);
  MeasurementSquare<D> cov = hm * lm.covariance * hm.transpose() + k.r;
  if (config.version == 2) cov += hx * p.pose_cov * hx.transpose();
  return cov;
}

template <int D>
bool FastSlam::Impl::beyond_gate(const Particle& p, std::uint32_t index, const MeasurementVector<D>& z,
                                 Slot& s) const {
  const MeasurementKernels<D>& k = kernels.get<D>();
  PoseRows<D> hx;
  LandmarkRows<D> hm;
  MeasurementSquare<D> cov;
  MeasurementVector<D> zhat;
  const LandmarkGaussian& lm = p.map[index];
  if (calibrating()) {
    // The landmark given the calibration, and the calibration's own uncertainty through both.
    CalibrationRows<D> hc;
    zhat = predict_given<D>(p, index, p.pose, p.calibration, hx, hm, hc);
    const CalibrationRows<D> hc_total = hc + hm * p.links[index].gain;
    cov = hm * lm.covariance * hm.transpose() + k.r + hx * p.pose_cov * hx.transpose() +
          hc_total * p.calibration_cov * hc_total.transpose();
  } else {
    cov = innovation_covariance<D>(p, lm, hx, hm);
    zhat = k.predict(p.pose, lm.mean);
  }
  MeasurementSquare<D> inverse;
  double log_det = 0.0;
  if (!invert_spd(symmetric(cov), inverse, log_det)) return false;
  const MeasurementVector<D> nu = k.residual(z, zhat);
  ++s.gate_judged;
  const bool beyond = nu.dot(inverse * nu) > gates.new_landmark;
  s.gate_rejected += beyond ? 1 : 0;
  return beyond;
}

template <int D>
void FastSlam::Impl::reject_known_outliers(const Particle& p, Slot& s, const ScanEvent& scan) const {
  for (std::size_t k = 0; k < s.pairings.size(); ++k) {
    const Pairing& pairing = s.pairings[k];
    if (pairing.decision == AssociationDecision::kUpdate && pairing.index < p.map.size() &&
        beyond_gate<D>(p, pairing.index, scan.observations[k].z, s))
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
    const Vector2 zhat = measurements.predict(p.pose, lm.mean);
    if (!association_view.contains_polar(zhat[0], zhat[1])) continue;
    Matrix23 hx;
    Matrix2 hm;
    Matrix2 inverse;
    double log_det = 0.0;
    if (invert_spd(symmetric(innovation_covariance<2>(p, lm, hx, hm)), inverse, log_det))
      s.candidates.push_back({index, zhat, inverse, kLog2Pi + 0.5 * log_det});
  }

  s.pairs.clear();
  make_room(s.pairs, n_obs * s.candidates.size());
  make_room(s.min_d2, n_obs);
  s.min_d2.assign(n_obs, std::numeric_limits<double>::infinity());
  const bool weigh_clutter = config.association.min_pairing_probability > 0.0;
  make_room(s.explained, n_obs);
  s.explained.assign(n_obs, clutter_density);
  for (std::size_t k = 0; k < n_obs; ++k) {
    if (!valid[k]) continue;
    const Vector2 z = scan.observations[k].z;
    for (std::size_t c = 0; c < s.candidates.size(); ++c) {
      const Vector2 nu = measurements.residual(z, s.candidates[c].zhat);
      const double d2 = nu.dot(s.candidates[c].s_inverse * nu);
      s.min_d2[k] = std::min(s.min_d2[k], d2);
      if (weigh_clutter) s.explained[k] += std::exp(-0.5 * d2 - s.candidates[c].log_normaliser);
      if (d2 < gates.accept) s.pairs.emplace_back(d2, static_cast<std::uint32_t>(k), static_cast<std::uint32_t>(c));
    }
  }
  // A pairing that another candidate or clutter explains about as well is not made (see
  // AssociationConfig::min_pairing_probability).
  if (weigh_clutter)
    std::erase_if(s.pairs, [&](const auto& pair) {
      const auto& [d2, k, c] = pair;
      return std::exp(-0.5 * d2 - s.candidates[c].log_normaliser) <
             config.association.min_pairing_probability * s.explained[k];
    });
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

template <int D>
double FastSlam::Impl::update_landmark(LandmarkGaussian& lm, const Particle& p, const MeasurementVector<D>& z) const {
  const MeasurementKernels<D>& k = kernels.get<D>();
  PoseRows<D> hx;
  LandmarkRows<D> hm;
  k.jacobians(p.pose, lm.mean, hx, hm);
  const MeasurementVector<D> nu = k.residual(z, k.predict(p.pose, lm.mean));
  const Eigen::Matrix<double, 2, D> pht = lm.covariance * hm.transpose();
  MeasurementSquare<D> s_inverse;
  double log_det = 0.0;
  // The pose's own uncertainty adds to the measurement's: a landmark seen from an uncertain pose learns
  // less from it.
  const MeasurementSquare<D> r_eff = k.r + hx * p.pose_cov * hx.transpose();
  if (!nu.allFinite() || !invert_spd(symmetric(hm * pht + r_eff), s_inverse, log_det)) return kMinusInf;
  const Eigen::Matrix<double, 2, D> gain = pht * s_inverse;
  lm.mean += gain * nu;
  // Joseph form: stays symmetric positive definite however the gain is rounded.
  const Matrix2 ikh = Matrix2::Identity() - gain * hm;
  lm.covariance = symmetric(ikh * lm.covariance * ikh.transpose() + gain * r_eff * gain.transpose());
  existence.observed(lm.existence);
  lm.last_seen = static_cast<std::uint32_t>(scans - 1);
  return -0.5 * nu.dot(s_inverse * nu) - kLogGaussianConstant<D> - 0.5 * log_det;
}

template <int D>
double FastSlam::Impl::update_calibrated(Particle& p, std::uint32_t index, const MeasurementVector<D>& z) const {
  const MeasurementKernels<D>& k = kernels.get<D>();
  LandmarkGaussian& lm = p.map.mutate(index);
  CalibrationLink& link = p.links.mutate(index);
  // The joint Gaussian of the calibration and the landmark, from the calibration's and the
  // landmark's given it.
  Eigen::Vector4d mean;
  mean << p.calibration, mean_at(p, index, p.calibration);
  Eigen::Matrix4d sigma;
  const Matrix2 cross = link.gain * p.calibration_cov;
  sigma << p.calibration_cov, cross.transpose(), cross, lm.covariance + cross * link.gain.transpose();
  PoseRows<D> hx;
  LandmarkRows<D> hm;
  CalibrationRows<D> hc;
  const MeasurementVector<D> nu = k.residual(z, predict_given<D>(p, index, p.pose, p.calibration, hx, hm, hc));
  Eigen::Matrix<double, D, 4> h;
  h << hc, hm;
  const MeasurementSquare<D> r_eff = k.r + hx * p.pose_cov * hx.transpose();
  const Eigen::Matrix<double, 4, D> pht = sigma * h.transpose();
  MeasurementSquare<D> s_inverse;
  double log_det = 0.0;
  if (!nu.allFinite() || !invert_spd(symmetric(h * pht + r_eff), s_inverse, log_det)) return kMinusInf;
  const Eigen::Matrix<double, 4, D> gain = pht * s_inverse;
  mean += gain * nu;
  const Eigen::Matrix4d ikh = Eigen::Matrix4d::Identity() - gain * h;
  sigma = symmetric(ikh * sigma * ikh.transpose() + gain * r_eff * gain.transpose());
  // Back to the calibration's Gaussian and the landmark's given it (the other landmarks' given it
  // have not changed: given the calibration and the path they are independent of this observation).
  const Matrix2 calibration_cov = sigma.topLeftCorner<2, 2>();
  const Eigen::LLT<Matrix2> llt(calibration_cov);
  if (llt.info() != Eigen::Success) return kMinusInf;
  const Matrix2 moves = llt.solve(Matrix2(sigma.topRightCorner<2, 2>())).transpose();  // Sigma_mc Sigma_cc^-1
  if (!mean.allFinite() || !moves.allFinite()) return kMinusInf;
  p.calibration = mean.head<2>();
  p.calibration_cov = calibration_cov;
  link.gain = moves;
  link.at = p.calibration;
  lm.mean = mean.tail<2>();
  lm.covariance = symmetric(Matrix2(sigma.bottomRightCorner<2, 2>() - link.gain * sigma.topRightCorner<2, 2>()));
  existence.observed(lm.existence);
  lm.last_seen = static_cast<std::uint32_t>(scans - 1);
  return -0.5 * nu.dot(s_inverse * nu) - kLogGaussianConstant<D> - 0.5 * log_det;
}

template <int D>
LandmarkGaussian FastSlam::Impl::new_landmark(const Pose2& x, const Matrix3& x_cov, const MeasurementVector<D>& z,
                                              int id) const {
  const MeasurementKernels<D>& k = kernels.get<D>();
  Matrix23 gx;
  Eigen::Matrix<double, 2, D> gz;
  k.inverse_jacobians(x, z, gx, gz);
  LandmarkGaussian lm;
  lm.mean = k.inverse(x, z);
  lm.covariance = symmetric(gz * k.r * gz.transpose() + gx * x_cov * gx.transpose());
  lm.id = id;
  lm.started = lm.last_seen = static_cast<std::uint32_t>(scans - 1);
  lm.existence = known() ? existence.given() : existence.first_observed();
  return lm;
}

void FastSlam::Impl::start_placed(Particle& p, const InitialLandmark& placed, int id) const {
  const InitialLandmark here = dead_reckoning.carried_to(p.pose, placed);
  LandmarkGaussian lm;
  lm.mean = here.mean;
  lm.covariance = symmetric(here.covariance + here.gx * p.pose_cov * here.gx.transpose());
  lm.id = id;
  lm.started = lm.last_seen = static_cast<std::uint32_t>(scans - 1);
  lm.existence = existence.given();  // the initialisers gather observations by identity
  p.map.push_back(lm);
  if (!calibrating()) return;
  // Shorter ranges (a larger offset or scale) draw the landmark in: dm/d(b, s) = -(gains) / (1 + s).
  CalibrationLink link;
  link.gain << here.range_gain, here.range_scale_gain;
  link.gain /= -(1.0 + placement_calibration[1]);
  link.at = placement_calibration;
  p.links.push_back(link);
}

template <int D, int N>
double FastSlam::Impl::propose(Particle& p, Slot& s, const ScanEvent& scan, std::size_t old_size) const {
  using StateVector = Eigen::Matrix<double, N, 1>;
  using StateSquare = Eigen::Matrix<double, N, N>;
  const MeasurementKernels<D>& kernel = kernels.get<D>();
  // The vehicle (and the calibration, independent of it until this scan's observations tie them).
  StateVector mu;
  StateSquare sigma = StateSquare::Zero();
  mu.template head<3>() = p.pose;
  sigma.template topLeftCorner<3, 3>() = p.pose_cov;
  if constexpr (N == 5) {
    mu.template tail<2>() = p.calibration;
    sigma.template bottomRightCorner<2, 2>() = p.calibration_cov;
  }
  double log_likelihood = 0.0;
  for (std::size_t k = 0; k < s.pairings.size(); ++k) {
    if (s.pairings[k].decision != AssociationDecision::kUpdate || s.pairings[k].index >= old_size) continue;
    const std::uint32_t index = s.pairings[k].index;
    const LandmarkGaussian& lm = p.map[index];
    const Pose2 x = mu.template head<3>();
    PoseRows<D> hx;
    LandmarkRows<D> hm;
    Eigen::Matrix<double, D, N> h;
    MeasurementVector<D> zhat;
    if constexpr (N == 5) {
      // The landmark given the calibration moves with it: the calibration's columns gain Hm dm/dc.
      CalibrationRows<D> hc;
      zhat = predict_given<D>(p, index, x, mu.template tail<2>(), hx, hm, hc);
      h << hx, hc + hm * p.links[index].gain;
    } else {
      kernel.jacobians(x, lm.mean, hx, hm);
      zhat = kernel.predict(x, lm.mean);
      h = hx;
    }
    const MeasurementVector<D> nu = kernel.residual(scan.observations[k].z, zhat);
    const MeasurementSquare<D> z_cov = hm * lm.covariance * hm.transpose() + kernel.r;
    const Eigen::Matrix<double, N, D> sht = sigma * h.transpose();
    MeasurementSquare<D> s_inverse;
    double log_det = 0.0;
    if (!nu.allFinite() || !invert_spd(symmetric(h * sht + z_cov), s_inverse, log_det)) {
      log_likelihood = kMinusInf;
      continue;
    }
    log_likelihood += -0.5 * nu.dot(s_inverse * nu) - kLogGaussianConstant<D> - 0.5 * log_det;
    const Eigen::Matrix<double, N, D> gain = sht * s_inverse;
    mu += gain * nu;
    mu[2] = wrap_angle(mu[2]);
    const StateSquare ikh = StateSquare::Identity() - gain * h;
    sigma = symmetric(ikh * sigma * ikh.transpose() + gain * z_cov * gain.transpose());
  }
  // Only a share of the proposal is sampled; the particle carries the rest as its pose's Gaussian,
  // which the next proposal, the gates, the weights and the landmark updates account for (see
  // FastSlamConfig::pose_sample_fraction).
  const double fraction = config.pose_sample_fraction;
  const Pose2 mean = mu.template head<3>();
  const Matrix3 pose_sigma = sigma.template topLeftCorner<3, 3>();
  p.pose = sample_gaussian(mean, fraction * pose_sigma, s.rng);
  p.pose_cov = (1.0 - fraction) * pose_sigma;
  // The calibration's part of the proposal is not kept: the landmark updates at the drawn pose
  // refine the calibration with these observations (once).
  if (!p.path.empty()) p.path.replace_newest(p.pose);
  return log_likelihood;
}

template <int D>
void FastSlam::Impl::update_particle(std::size_t i, const ScanEvent& scan) {
  Particle& p = particles[i];
  Slot& s = slots[i];
  const std::size_t n_obs = scan.observations.size();
  if (known()) {
    // Every particle starts from the common plan; the outlier gate is each particle's own.
    make_room(s.pairings, n_obs);
    s.pairings = known_plan;
    s.gate_judged = s.gate_rejected = 0;
    if (gate_known) reject_known_outliers<D>(p, s, scan);
  }  // else associate() has run for every particle (FastSlam::update)
  s.grid_entries.clear();
  make_room(s.grid_entries, n_obs);
  s.confirmed_now.clear();
  make_room(s.confirmed_now, n_obs);
  // A landmark update at the particle's final pose; a landmark leaving its grid cell is listed in
  // the new one.
  auto update_at = [&](std::uint32_t index, const MeasurementVector<D>& z) {
    if (calibrating()) return update_calibrated<D>(p, index, z);
    LandmarkGaussian& lm = p.map.mutate(index);
    if (known()) return update_landmark<D>(lm, p, z);
    const LandmarkGrid::Cell before = grid.cell_of(lm.mean);
    const bool was_confirmed = existence.confirmed(lm.existence);
    const double ll = update_landmark<D>(lm, p, z);
    if (!was_confirmed && existence.confirmed(lm.existence) && lm.started >= window_start)
      s.confirmed_now.push_back(index);
    if (grid.cell_of(lm.mean) != before) s.grid_entries.emplace_back(lm.mean, index);
    return ll;
  };
  std::vector<Pairing>& pairings = s.pairings;
  const std::size_t old_size = p.map.size();
  auto is_old_update = [&](std::size_t k) {
    return pairings[k].decision == AssociationDecision::kUpdate && pairings[k].index < old_size;
  };
  double log_likelihood = 0.0;
  if (config.version == 2)
    log_likelihood = calibrating() ? propose<D, 5>(p, s, scan, old_size) : propose<D, 3>(p, s, scan, old_size);

  // Landmark updates at the particle's final pose; for FastSLAM 1.0 they also give the weight.
  for (std::size_t k = 0; k < n_obs; ++k) {
    if (!is_old_update(k)) continue;
    if (relocalising() && p.map[pairings[k].index].last_seen < window_start) anchor_at(p, p.map[pairings[k].index]);
    const double ll = update_at(pairings[k].index, scan.observations[k].z);
    if (config.version == 1) log_likelihood += ll;
  }
  // New landmarks, and repeated observations of landmarks started in this scan, in scan order.
  for (std::size_t k = 0; k < n_obs; ++k) {
    Pairing& pairing = pairings[k];
    const MeasurementVector<D> z = scan.observations[k].z;
    // A landmark started in this scan and seen again in it meets the outlier gate only now.
    if (known() && gate_known && pairing.decision == AssociationDecision::kUpdate && !is_old_update(k) &&
        beyond_gate<D>(p, pairing.index, z, s))
      pairing = Pairing{};
    if (pairing.decision == AssociationDecision::kNew) {
      const int id = known() ? scan.observations[k].id : kUnknownId;
      if (initialiser)
        start_placed(p, placements[k], id);
      else
        p.map.push_back(new_landmark<D>(p.pose, p.pose_cov, z, id));
      if (pending.active())
        for (int d = 1; d < start_detections[k]; ++d) existence.observed(p.map.mutate(pairing.index).existence);
      if (!known()) s.grid_entries.emplace_back(p.map[pairing.index].mean, pairing.index);
      log_likelihood += log_p0;
    } else if (pairing.decision == AssociationDecision::kDiscard ||
               pairing.decision == AssociationDecision::kPending) {
      log_likelihood += log_p0;
    } else if (!is_old_update(k)) {
      log_likelihood += update_at(pairing.index, z);
    }
  }
  s.relocalised = false;
  if (relocalising() && (!s.confirmed_now.empty() || old_size < p.map.size()))
    relocalise(p, s, static_cast<std::uint32_t>(old_size));
  if (!known()) count_misses(p, s);
  s.log_likelihood = log_likelihood;
}

template void FastSlam::Impl::update_particle<1>(std::size_t, const ScanEvent&);
template void FastSlam::Impl::update_particle<2>(std::size_t, const ScanEvent&);
template void FastSlam::Impl::update_particle<3>(std::size_t, const ScanEvent&);

Matrix2 FastSlam::Impl::drift_in_measurement(const Particle& p, const LandmarkGaussian& lm, Matrix2& hm) const {
  Matrix23 hx;
  measurements.jacobians(p.pose, lm.mean, hx, hm);
  return hx * drift_of(p, lm.last_seen) * hx.transpose();
}

Matrix3 FastSlam::Impl::drift_of(const Particle& p, std::uint32_t seen) const {
  const Vector2 position = p.pose.head<2>();
  const Matrix3 direct = drift_between(drift_at_scan[seen], drift, position);
  if (!p.anchor || p.anchor->scan <= seen) return direct;
  // A relocalisation between: the anchor ties the pose to the map the jump went to, not to `seen`.
  if (p.relocalised_at && seen < *p.relocalised_at && *p.relocalised_at <= p.anchor->scan) return direct;
  // The anchor's error reaches the pose now through the same lever arm as the drift's terms.
  Matrix3 lever = Matrix3::Identity();
  lever.topRightCorner<2, 1>() = Vector2(p.anchor->position.y() - position.y(), position.x() - p.anchor->position.x());
  const Matrix3 via_anchor = symmetric(lever * p.anchor->covariance * lever.transpose()) +
                             drift_between(drift_at_scan[p.anchor->scan], drift, position);
  return via_anchor.topLeftCorner<2, 2>().trace() < direct.topLeftCorner<2, 2>().trace() ? via_anchor : direct;
}

void FastSlam::Impl::anchor_at(Particle& p, const LandmarkGaussian& lm) const {
  const Matrix3 prior = drift_of(p, lm.last_seen);
  Matrix23 hx;
  Matrix2 hm;
  measurements.jacobians(p.pose, lm.mean, hx, hm);
  const Eigen::Matrix<double, 3, 2> pht = prior * hx.transpose();
  Matrix2 s_inverse;
  double log_det = 0.0;
  if (!invert_spd(symmetric(hx * pht + hm * lm.covariance * hm.transpose() + measurements.r), s_inverse, log_det))
    return;
  p.anchor = Anchor{static_cast<std::uint32_t>(scans - 1), p.pose.head<2>(),
                    symmetric(prior - pht * s_inverse * pht.transpose())};
}

bool FastSlam::Impl::expected_in_view(const Particle& p, const LandmarkGaussian& lm) const {
  const Vector2 z = measurements.predict(p.pose, lm.mean);
  if (!relocalising() || lm.last_seen >= window_start) return existence.detection_view().contains_polar(z[0], z[1]);
  // Mapped before the window: the drift since may have put it anywhere within its reach of where the
  // particle predicts it, and at the return from a lap its misses there would remove it just before
  // relocalisation can pair it. It is expected only where the drift cannot have moved it out of view.
  Matrix2 hm;
  const Matrix2 spread = drift_in_measurement(p, lm, hm);
  const Vector2 reach = std::sqrt(gates.accept) * spread.diagonal().cwiseMax(0.0).cwiseSqrt();
  return existence.detection_view().contains_polar(z[0] + reach[0], std::abs(z[1]) + reach[1]);
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
    const bool expected = expected_in_view(p, p.map[c.index]);
    if (!expected && existence.confirmed(p.map[c.index].existence)) continue;  // nothing to record: no copy
    LandmarkGaussian& lm = p.map.mutate(c.index);
    if (expected ? existence.missed(lm.existence) : existence.unseen_nearby(lm.existence)) lm.removed = true;
  }
}

namespace {

/// Relocalisation's view of one particle: its pose with the drift as covariance, and the landmarks it
/// mapped before the window, independent of the pose and of each other (so they are, given the
/// particle's path; the drift is what the path since does not know).
class DriftedMapView final : public GaussianMapView {
 public:
  DriftedMapView(const Pose2& pose, const Matrix3& drift, const LandmarkTree& map, std::span<const std::uint32_t> old)
      : pose_(pose), drift_(drift), map_(map), old_(old) {}
  Pose2 pose() const override { return pose_; }
  Matrix3 pose_covariance() const override { return drift_; }
  Vector2 landmark_position(std::size_t index) const override { return map_[old_[index]].mean; }
  Matrix23 landmark_pose_covariance(std::size_t) const override { return Matrix23::Zero(); }
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override {
    return i == j ? map_[old_[i]].covariance : Matrix2::Zero();
  }

 private:
  Pose2 pose_;
  Matrix3 drift_;
  const LandmarkTree& map_;
  std::span<const std::uint32_t> old_;
};

}  // namespace

void FastSlam::Impl::relocalise(Particle& p, Slot& s, std::uint32_t first_new) const {
  // The landmarks seen in the window (they are in the frame of the particle's pose now) and those
  // mapped before it and not seen since (in the frame of the pose that last saw them).
  s.recent.clear();
  s.old.clear();
  s.started.clear();
  // Room as the candidates' list has it (see gather_candidates): grown only when that grows.
  const std::size_t at_most = relocalise_candidates.capacity() + (p.map.size() - first_new);
  make_room(s.recent, at_most);
  make_room(s.old, at_most);
  make_room(s.started, at_most);
  make_room(s.recent_as_seen, at_most);
  auto sort_landmark = [&](std::uint32_t index) {
    const LandmarkGaussian& lm = p.map[index];
    if (lm.removed) return;
    if (lm.last_seen >= window_start) {
      s.recent.push_back(index);
      if (lm.started >= window_start) s.started.push_back(index);
    } else if (existence.confirmed(lm.existence)) {
      s.old.push_back(index);
    }
  };
  for (const std::uint32_t index : relocalise_candidates) {
    if (index >= first_new) break;
    sort_landmark(index);
  }
  for (auto index = first_new; index < p.map.size(); ++index) sort_landmark(index);
  const std::size_t min_pairs = config.association.relocalise_min_pairs;
  if (s.started.size() < min_pairs || s.old.size() < min_pairs) return;
  // The landmarks started in the window, as the particle sees them: the search's measurements.
  s.recent_as_seen.clear();
  for (const std::uint32_t index : s.started)
    s.recent_as_seen.push_back({measurements.predict(p.pose, p.map[index].mean), kUnknownId});
  // An old landmark can pair only with a landmark started in the window that lies in the gate its
  // drift (drift_of since it was last seen) allows; the others are left out of the search, whose
  // prior is the drift of the oldest kept. The search runs only when a landmark this scan started or
  // confirmed may duplicate one; otherwise the pairs, if any, are those earlier searches found too
  // few of.
  std::uint32_t oldest = static_cast<std::uint32_t>(scans - 1);
  bool may_duplicate = false;
  std::size_t kept = 0;
  for (const std::uint32_t j : s.old) {
    const LandmarkGaussian& lm = p.map[j];
    Matrix2 hm;
    const Matrix2 drift_cov = drift_in_measurement(p, lm, hm);
    const Vector2 predicted = measurements.predict(p.pose, lm.mean);
    bool may_pair = false;
    for (std::size_t k = 0; k < s.started.size(); ++k) {
      const std::uint32_t index = s.started[k];
      const LandmarkGaussian& fresh = p.map[index];
      const Matrix2 cov = drift_cov + hm * (lm.covariance + fresh.covariance) * hm.transpose();
      const Vector2 nu = measurements.residual(s.recent_as_seen[k].z, predicted);
      Matrix2 inverse;
      double log_det = 0.0;
      if (!invert_spd(symmetric(cov), inverse, log_det) || !(nu.dot(inverse * nu) < gates.accept)) continue;
      may_pair = true;
      const bool changed_now = index >= first_new || std::find(s.confirmed_now.begin(), s.confirmed_now.end(),
                                                               index) != s.confirmed_now.end();
      if (changed_now) {
        may_duplicate = true;
        break;
      }
    }
    if (!may_pair) continue;
    s.old[kept++] = j;
    oldest = std::min(oldest, lm.last_seen);
  }
  s.old.resize(kept);
  if (!may_duplicate || kept < min_pairs) return;

  // The old landmarks kept, with the drift since the oldest was last seen as the pose's covariance,
  // are the map.
  const Matrix3 drift_prior = drift_of(p, oldest);
  s.old_positions.resize(s.old.size());
  std::iota(s.old_positions.begin(), s.old_positions.end(), std::size_t{0});
  const DriftedMapView view(p.pose, drift_prior, p.map, s.old);
  ++s.relocalisation_searches;
  slamkit::associate(s.recent_as_seen, s.old_positions, view, *observation, relocalise_association, s.workspace,
                     s.matches);
  std::size_t pairs = 0, confirmed_pairs = 0;
  std::uint32_t oldest_paired = static_cast<std::uint32_t>(scans - 1);
  for (std::size_t k = 0; k < s.matches.size(); ++k)
    if (s.matches[k].decision == AssociationDecision::kUpdate) {
      ++pairs;
      confirmed_pairs += existence.confirmed(p.map[s.started[k]].existence) ? 1 : 0;
      oldest_paired = std::min(oldest_paired, p.map[s.old[s.matches[k].landmark]].last_seen);
    }
  if (confirmed_pairs < min_pairs) return;

  // The search's prior was the drift since the oldest landmark it could pair, which is wide enough
  // for every candidate; the pairs found must also be jointly compatible under the drift since the
  // oldest of them, with both landmarks' covariances as the noise. Otherwise a few landmarks mapped
  // just before the window, next to new ones, would pass under a lap's drift.
  const Matrix3 drift_paired = drift_of(p, oldest_paired);
  const double joint_gate = eval::chi_square_quantile(relocalise_association.accept_probability, 2.0 * static_cast<double>(pairs));

  // The pose that best explains the pairs, with that drift as its prior: iterated Kalman updates
  // over the stacked pairs, in information form (the pairs' noises are independent 2x2 blocks, so
  // every sum is 3x3 and nothing is allocated). A pair's noise is both landmarks' covariances in
  // measurement space; the duplicate's, seen from the prior pose, is the same at every iterate.
  Matrix3 prior_information;
  {
    const Eigen::LDLT<Matrix3> ldlt(drift_paired);
    if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 0.0).all()) return;
    prior_information = symmetric(Matrix3(ldlt.solve(Matrix3::Identity())));
  }
  s.duplicate_noise.clear();
  make_room(s.duplicate_noise, pairs);
  for (std::size_t k = 0; k < s.matches.size(); ++k) {
    if (s.matches[k].decision != AssociationDecision::kUpdate) continue;
    const LandmarkGaussian& duplicate = p.map[s.started[k]];
    Matrix23 hx;
    Matrix2 hm;
    measurements.jacobians(p.pose, duplicate.mean, hx, hm);
    s.duplicate_noise.push_back(hm * duplicate.covariance * hm.transpose());
  }
  const Pose2 prior = p.pose;
  Pose2 x = prior;
  Matrix3 posterior = drift_paired;  // of the pose given the pairs, at the last iterate
  for (int iteration = 0; iteration < 5; ++iteration) {
    Pose2 offset = x - prior;
    offset[2] = wrap_angle(offset[2]);
    Matrix3 information = prior_information;
    Eigen::Vector3d weighted = Eigen::Vector3d::Zero();  // H^T N^-1 (innovation)
    double innovation_d2 = 0.0;           // innovation^T N^-1 innovation
    for (std::size_t k = 0, pair = 0; k < s.matches.size(); ++k) {
      if (s.matches[k].decision != AssociationDecision::kUpdate) continue;
      const LandmarkGaussian& original = p.map[s.old[s.matches[k].landmark]];
      Matrix23 hx;
      Matrix2 hm;
      measurements.jacobians(x, original.mean, hx, hm);
      const Vector2 innovation =
          measurements.residual(s.recent_as_seen[k].z, measurements.predict(x, original.mean)) + hx * offset;
      Matrix2 noise_inverse;
      double log_det = 0.0;
      if (!invert_spd(symmetric(s.duplicate_noise[pair++] + hm * original.covariance * hm.transpose()), noise_inverse,
                      log_det))
        return;
      const Eigen::Matrix<double, 3, 2> htn = hx.transpose() * noise_inverse;
      information += htn * hx;
      weighted += htn * innovation;
      innovation_d2 += innovation.dot(noise_inverse * innovation);
    }
    const Eigen::LDLT<Matrix3> ldlt(symmetric(information));
    if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 0.0).all()) return;
    posterior = symmetric(Matrix3(ldlt.solve(Matrix3::Identity())));
    const Eigen::Vector3d correction = posterior * weighted;
    // innovation^T (H P H^T + N)^-1 innovation, by the matrix inversion lemma.
    if (iteration == 0 && !(innovation_d2 - weighted.dot(correction) < joint_gate)) return;
    Pose2 next = prior + correction;
    next[2] = wrap_angle(next[2]);
    if (!next.allFinite()) return;
    const bool converged = (next - x).head<2>().norm() < 1e-4 && std::abs(wrap_angle(next[2] - x[2])) < 1e-6;
    x = next;
    if (converged) break;
  }

  // Negative evidence: from x the particle should now see the old landmarks in its view that a
  // recent one could duplicate, and those it has not started a duplicate of (paired here) it has not
  // seen. A wrong alignment (under a drift of a lap, two or three landmarks of a dense map can fit
  // one) puts the vehicle among landmarks it does not see; the right one among those it sees again,
  // so it is taken only where the pairs are more than twice the unseen. (Half the pairs let a wrong
  // two-pair alignment with one landmark unseen through on the loop-closure world.)
  s.paired.assign(s.old.size(), 0);
  for (const slamkit::Pairing& match : s.matches)
    if (match.decision == AssociationDecision::kUpdate) s.paired[match.landmark] = 1;
  std::size_t unseen = 0;
  for (std::size_t j = 0; j < s.old.size(); ++j)
    if (!s.paired[j] && existence.detection_view().contains(*observation, x, p.map[s.old[j]].mean)) ++unseen;
  if (2 * unseen >= pairs) return;

  // The landmarks seen in the window keep where they are relative to the particle, which moves to
  // x; each duplicate is then fused into its original (two independent estimates of one place).
  const double turn = wrap_angle(x[2] - prior[2]);
  Matrix2 rotation;
  rotation << std::cos(turn), -std::sin(turn), std::sin(turn), std::cos(turn);
  for (const std::uint32_t index : s.recent) {
    LandmarkGaussian& lm = p.map.mutate(index);
    lm.mean = measurements.inverse(x, measurements.predict(prior, lm.mean));
    lm.covariance = symmetric(rotation * lm.covariance * rotation.transpose());
    s.grid_entries.emplace_back(lm.mean, index);
  }
  for (std::size_t k = 0; k < s.matches.size(); ++k) {
    if (s.matches[k].decision != AssociationDecision::kUpdate) continue;
    LandmarkGaussian& duplicate = p.map.mutate(s.started[k]);
    LandmarkGaussian& original = p.map.mutate(s.old[s.matches[k].landmark]);
    const Matrix2 sum = original.covariance + duplicate.covariance;
    const Matrix2 gain = original.covariance * sum.inverse();
    original.mean += gain * (duplicate.mean - original.mean);
    original.covariance = symmetric(original.covariance - gain * original.covariance);
    original.last_seen = duplicate.last_seen;
    duplicate.removed = true;
    s.grid_entries.emplace_back(original.mean, s.old[s.matches[k].landmark]);
  }
  p.pose = x;
  if (!p.path.empty()) p.path.replace_newest(p.pose);
  p.relocalised_at = static_cast<std::uint32_t>(scans - 1);
  p.anchor = Anchor{*p.relocalised_at, x.head<2>(), posterior};
  s.relocalised = true;
}

}  // namespace slamkit
