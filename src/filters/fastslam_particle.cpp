// One particle's scan in FastSLAM 1.0 and 2.0: association (or the known identities and their
// outlier gate), the proposal of eq. (18), the landmark updates, the weight (eqs. 15 and 17), the
// misses of the existence rule and the test for copies of a landmark in one map. The filter around
// it is in fastslam.cpp, relocalisation in fastslam_relocalise.cpp.
#include <Eigen/Cholesky>
#include <algorithm>

#include "fastslam_impl.hpp"
#include "slamkit/core/angles.hpp"
#include "slamkit/core/random_draws.hpp"

namespace slamkit {

using namespace fastslam_detail;

namespace {

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
  s.in_view.clear();
  make_room(s.in_view, scan_candidates.size());
  for (const std::uint32_t index : scan_candidates) {
    if (index >= p.map.size()) break;
    const LandmarkGaussian& lm = p.map[index];
    if (!lm.removed && association_view.contains(*observation, p.pose, lm.mean)) s.in_view.push_back(index);
  }
  // The kernel the EKF family associates with, on this particle's belief: the same gates, pairing
  // probabilities and new-landmark rule.
  slamkit::associate(scan.observations, s.in_view, ParticleMapView(p.pose, p.pose_cov, p.map), *observation, config.association,
                     s.association, s.decisions, &s.association_stats, clutter_density);
  const std::size_t n_obs = scan.observations.size();
  make_room(s.pairings, n_obs);
  s.pairings.assign(n_obs, Pairing{});
  auto next_index = static_cast<std::uint32_t>(p.map.size());
  for (std::size_t k = 0; k < n_obs; ++k) {
    if (!valid[k]) continue;
    if (s.decisions[k].decision == AssociationDecision::kUpdate)
      s.pairings[k] = {AssociationDecision::kUpdate, static_cast<std::uint32_t>(s.decisions[k].landmark)};
    else if (s.decisions[k].decision == AssociationDecision::kNew)
      s.pairings[k] = {AssociationDecision::kNew, next_index++};
  }
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
  MeasurementSquare<D> r_eff = k.r + hx * p.pose_cov * hx.transpose();
  if (!nu.allFinite() || !invert_spd(symmetric(hm * pht + r_eff), s_inverse, log_det)) return kMinusInf;
  const double m2 = nu.dot(s_inverse * nu);
  const double log_likelihood = log_likelihood_of<D>(m2, log_det);
  double unused = 0.0;
  if (inflate_noise<D>(m2, r_eff) && !invert_spd(symmetric(hm * pht + r_eff), s_inverse, unused)) return kMinusInf;
  const Eigen::Matrix<double, 2, D> gain = pht * s_inverse;
  lm.mean += gain * nu;
  // Joseph form: stays symmetric positive definite however the gain is rounded.
  const Matrix2 ikh = Matrix2::Identity() - gain * hm;
  lm.covariance = symmetric(ikh * lm.covariance * ikh.transpose() + gain * r_eff * gain.transpose());
  existence.observed(lm.existence);
  lm.last_seen = static_cast<std::uint32_t>(scans - 1);
  return log_likelihood;
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
  MeasurementSquare<D> r_eff = k.r + hx * p.pose_cov * hx.transpose();
  const Eigen::Matrix<double, 4, D> pht = sigma * h.transpose();
  MeasurementSquare<D> s_inverse;
  double log_det = 0.0;
  if (!nu.allFinite() || !invert_spd(symmetric(h * pht + r_eff), s_inverse, log_det)) return kMinusInf;
  const double m2 = nu.dot(s_inverse * nu);
  const double log_likelihood = log_likelihood_of<D>(m2, log_det);
  double unused = 0.0;
  if (inflate_noise<D>(m2, r_eff) && !invert_spd(symmetric(h * pht + r_eff), s_inverse, unused)) return kMinusInf;
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
  return log_likelihood;
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
double FastSlam::Impl::propose(Particle& p, Slot& s, const ScanEvent& scan, std::size_t old_size,
                              std::mt19937_64& rng) const {
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
    MeasurementSquare<D> z_cov = hm * lm.covariance * hm.transpose() + kernel.r;
    const Eigen::Matrix<double, N, D> sht = sigma * h.transpose();
    MeasurementSquare<D> s_inverse;
    double log_det = 0.0;
    if (!nu.allFinite() || !invert_spd(symmetric(h * sht + z_cov), s_inverse, log_det)) {
      log_likelihood = kMinusInf;
      continue;
    }
    const double m2 = nu.dot(s_inverse * nu);
    log_likelihood += log_likelihood_of<D>(m2, log_det);
    double unused = 0.0;
    if (inflate_noise<D>(m2, z_cov) && !invert_spd(symmetric(h * sht + z_cov), s_inverse, unused)) {
      log_likelihood = kMinusInf;
      continue;
    }
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
  p.pose = sample_gaussian(mean, fraction * pose_sigma, rng);
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
  s.fused_now = 0;
  if (weighing_duplicates()) weigh_duplicates(p, s, scan);
  double log_likelihood = 0.0;
  if (config.version == 2)
    log_likelihood = calibrating() ? propose<D, 5>(p, s, scan, old_size, particles.stream(i))
                                   : propose<D, 3>(p, s, scan, old_size, particles.stream(i));

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
  if (weighing_duplicates()) fuse_duplicates(p, s);
  s.relocalised = false;
  if (relocalising() && (!s.confirmed_now.empty() || old_size < p.map.size()))
    relocalise(p, s, static_cast<std::uint32_t>(old_size));
  if (!known()) count_misses(p, s);
  log_likelihoods[i] = log_likelihood;
}

template void FastSlam::Impl::update_particle<1>(std::size_t, const ScanEvent&);
template void FastSlam::Impl::update_particle<2>(std::size_t, const ScanEvent&);
template void FastSlam::Impl::update_particle<3>(std::size_t, const ScanEvent&);

namespace {
constexpr float kNeverACopy = -std::numeric_limits<float>::infinity();
}  // namespace

void FastSlam::Impl::weigh_duplicates(Particle& p, Slot& s, const ScanEvent& scan) const {
  const std::size_t n_obs = scan.observations.size();
  make_room(s.shared_gates, n_obs);
  s.shared_gates.assign(n_obs, SharedGate{});
  make_room(s.gated_by, s.in_view.size());
  s.gated_by.assign(s.in_view.size(), 0);
  s.copies_to_fuse.clear();
  make_room(s.copies_to_fuse, n_obs);
  const SensorView& view = existence.detection_view();
  for (std::size_t c = 0; c < s.in_view.size(); ++c) {
    const LandmarkGaussian& lm = p.map[s.in_view[c]];
    // Out of view, one of two landmarks goes unseen whether or not it is the other's copy.
    if (!existence.confirmed(lm.existence) || !view.contains(*observation, p.pose, lm.mean)) continue;
    Matrix23 hx;
    Matrix2 hm;
    Matrix2 inverse;
    double log_det = 0.0;
    if (!invert_spd(symmetric(innovation_covariance<2>(p, lm, hx, hm)), inverse, log_det)) continue;
    const Vector2 predicted = measurements.predict(p.pose, lm.mean);
    for (std::size_t k = 0; k < n_obs; ++k) {
      if (!valid[k]) continue;
      const Vector2 nu = measurements.residual(scan.observations[k].z, predicted);
      if (!(nu.dot(inverse * nu) < gates.accept)) continue;
      ++s.gated_by[c];
      SharedGate& gate = s.shared_gates[k];
      if (gate.count < gate.first.size()) gate.first[gate.count] = static_cast<std::uint32_t>(c);
      ++gate.count;
    }
  }
  // Two landmarks that this scan paired each with an observation of its own are two.
  s.paired_now.clear();
  make_room(s.paired_now, n_obs);
  for (const Pairing& pairing : s.pairings)
    if (pairing.decision == AssociationDecision::kUpdate && pairing.index < p.map.size())
      s.paired_now.push_back(pairing.index);
  std::sort(s.paired_now.begin(), s.paired_now.end());
  for (const std::uint32_t index : s.paired_now) {
    const std::uint32_t original = p.map[index].duplicate_of;
    if (original != LandmarkGaussian::kNotADuplicate && p.map[index].duplicate_log_odds > kNeverACopy &&
        std::binary_search(s.paired_now.begin(), s.paired_now.end(), original))
      p.map.mutate(index).duplicate_log_odds = kNeverACopy;
  }
  for (const SharedGate& gate : s.shared_gates) {
    if (gate.count != 2 || s.gated_by[gate.first[0]] != 1 || s.gated_by[gate.first[1]] != 1) continue;
    // in_view is in index order, and indices in the order landmarks were started.
    const auto original = static_cast<std::uint32_t>(s.in_view[gate.first[0]]);
    const auto copy = static_cast<std::uint32_t>(s.in_view[gate.first[1]]);
    // A copy is started where its original, out of sight for the window, was not recognised: two
    // landmarks started within a window of each other were started as two (twins seen together are).
    if (p.map[copy].duplicate_of != original &&
        scan_times[p.map[copy].started] - scan_times[p.map[original].started] <= config.association.relocalise_window_s)
      continue;
    LandmarkGaussian& lm = p.map.mutate(copy);
    if (lm.duplicate_of != original) {
      lm.duplicate_of = original;
      lm.duplicate_log_odds = 0.0f;
    }
    lm.duplicate_log_odds += static_cast<float>(duplicate_log_ratio);
    if (lm.duplicate_log_odds >= duplicate_log_odds_bar) s.copies_to_fuse.push_back(copy);
  }
}

void FastSlam::Impl::fuse_duplicates(Particle& p, Slot& s) const {
  for (const std::uint32_t copy : s.copies_to_fuse) {
    const std::uint32_t original = p.map[copy].duplicate_of;
    if (p.map[copy].removed || p.map[original].removed) continue;
    fuse(p, original, copy, s);
    ++s.fused_now;
  }
}

bool FastSlam::Impl::expected_in_view(const Particle& p, const LandmarkGaussian& lm) const {
  const SensorView& view = existence.detection_view();
  if (!relocalising() || lm.last_seen >= window_start) return view.contains(*observation, p.pose, lm.mean);
  // Mapped before the window: the drift since may have put it anywhere within its reach of where the
  // particle predicts it, and at the return from a lap its misses there would remove it just before
  // relocalisation can pair it. It is expected only where the drift cannot have moved it out of view.
  // (Relocalisation pairs landmarks, so its sensor measures range and bearing.)
  Matrix2 hm;
  const Matrix2 spread = drift_in_measurement(p, lm, hm);
  const Vector2 reach = std::sqrt(gates.accept) * spread.diagonal().cwiseMax(0.0).cwiseSqrt();
  const MeasuredRows rows = observation->rows();
  return view.narrowed(reach[rows.range], reach[rows.bearing]).contains(*observation, p.pose, lm.mean);
}

void FastSlam::Impl::count_misses(Particle& p, Slot& s) const {
  s.observed.clear();
  make_room(s.observed, s.pairings.size());
  for (const Pairing& pairing : s.pairings)
    if (pairing.decision == AssociationDecision::kUpdate) s.observed.push_back(pairing.index);
  std::sort(s.observed.begin(), s.observed.end());
  // The candidates were chosen in the widened view of the predicted pose, so they include every
  // landmark the existence rule expects to be seen from the final pose.
  for (const std::size_t index : s.in_view) {
    if (std::binary_search(s.observed.begin(), s.observed.end(), index)) continue;
    const bool expected = expected_in_view(p, p.map[index]);
    if (!expected && existence.confirmed(p.map[index].existence)) continue;  // nothing to record: no copy
    LandmarkGaussian& lm = p.map.mutate(index);
    if (expected ? existence.missed(lm.existence) : existence.unseen_nearby(lm.existence)) lm.removed = true;
  }
}

}  // namespace slamkit
