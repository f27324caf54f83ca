// One particle's scan in FastSLAM 1.0 and 2.0: association (or the known identities and their
// outlier gate), the proposal of eq. (18), the landmark updates, the weight (eqs. 15 and 17) and the
// misses of the existence rule. The filter around it is in fastslam.cpp.
#include <Eigen/Cholesky>
#include <algorithm>

#include "fastslam_impl.hpp"
#include "slamkit/core/angles.hpp"

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

}  // namespace

Matrix2 FastSlam::Impl::innovation_covariance(const Particle& p, const LandmarkGaussian& lm, Matrix23& hx,
                                              Matrix2& hm) const {
  // At the pose as predicted: for FastSLAM 2.0 its covariance enters S, as the proposal's
  // uncertainty should when judging whether an observation fits a landmark.
  observation->jacobians(p.pose, lm.mean, hx, hm);
  Matrix2 cov = hm * lm.covariance * hm.transpose() + r;
  if (config.version == 2) cov += hx * p.pose_cov * hx.transpose();
  return cov;
}

bool FastSlam::Impl::beyond_gate(const Particle& p, const LandmarkGaussian& lm, const Vector2& z) const {
  Matrix23 hx;
  Matrix2 hm;
  Matrix2 inverse;
  double log_det = 0.0;
  if (!invert_spd(symmetric(innovation_covariance(p, lm, hx, hm)), inverse, log_det)) return false;
  const Vector2 nu = observation->residual(z, observation->predict(p.pose, lm.mean));
  return nu.dot(inverse * nu) > gates.new_landmark;
}

void FastSlam::Impl::reject_known_outliers(const Particle& p, Slot& s, const ScanEvent& scan) const {
  for (std::size_t k = 0; k < s.pairings.size(); ++k) {
    const Pairing& pairing = s.pairings[k];
    if (pairing.decision == AssociationDecision::kUpdate && pairing.index < p.map.size() &&
        beyond_gate(p, p.map[pairing.index], scan.observations[k].z))
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
    const Vector2 zhat = observation->predict(p.pose, lm.mean);
    if (!association_view.contains(zhat)) continue;
    Matrix23 hx;
    Matrix2 hm;
    Matrix2 inverse;
    double log_det = 0.0;
    if (invert_spd(symmetric(innovation_covariance(p, lm, hx, hm)), inverse, log_det))
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
    const Vector2& z = scan.observations[k].z;
    for (std::size_t c = 0; c < s.candidates.size(); ++c) {
      const Vector2 nu = observation->residual(z, s.candidates[c].zhat);
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

double FastSlam::Impl::update_landmark(LandmarkGaussian& lm, const Pose2& x, const Vector2& z) const {
  Matrix23 hx;
  Matrix2 hm;
  observation->jacobians(x, lm.mean, hx, hm);
  const Vector2 nu = observation->residual(z, observation->predict(x, lm.mean));
  const Matrix2 pht = lm.covariance * hm.transpose();
  Matrix2 s_inverse;
  double log_det = 0.0;
  if (!nu.allFinite() || !invert_spd(symmetric(hm * pht + r), s_inverse, log_det)) return kMinusInf;
  const Matrix2 gain = pht * s_inverse;
  lm.mean += gain * nu;
  // Joseph form: stays symmetric positive definite however the gain is rounded.
  const Matrix2 ikh = Matrix2::Identity() - gain * hm;
  lm.covariance = symmetric(ikh * lm.covariance * ikh.transpose() + gain * r * gain.transpose());
  existence.observed(lm.existence);
  return -0.5 * nu.dot(s_inverse * nu) - kLog2Pi - 0.5 * log_det;
}

LandmarkGaussian FastSlam::Impl::new_landmark(const Pose2& x, const Vector2& z, int id) const {
  Matrix23 gx;
  Matrix2 gz;
  observation->inverse_jacobians(x, z, gx, gz);
  LandmarkGaussian lm;
  lm.mean = observation->inverse(x, z);
  lm.covariance = symmetric(gz * r * gz.transpose());
  lm.id = id;
  lm.existence = known() ? existence.given() : existence.first_observed();
  return lm;
}

void FastSlam::Impl::update_particle(std::size_t i, const ScanEvent& scan) {
  Particle& p = particles[i];
  Slot& s = slots[i];
  const std::size_t n_obs = scan.observations.size();
  if (known()) {
    // Every particle starts from the common plan; the outlier gate is each particle's own.
    make_room(s.pairings, n_obs);
    s.pairings = known_plan;
    if (gate_known) reject_known_outliers(p, s, scan);
  } else {
    associate(p, s, scan);
  }
  s.grid_entries.clear();
  make_room(s.grid_entries, n_obs);
  // A landmark update at the particle's final pose; a landmark leaving its grid cell is listed in
  // the new one.
  auto update_at = [&](std::uint32_t index, const Vector2& z) {
    LandmarkGaussian& lm = p.map.mutate(index);
    if (known()) return update_landmark(lm, p.pose, z);
    const LandmarkGrid::Cell before = grid.cell_of(lm.mean);
    const double ll = update_landmark(lm, p.pose, z);
    if (grid.cell_of(lm.mean) != before) s.grid_entries.emplace_back(lm.mean, index);
    return ll;
  };
  std::vector<Pairing>& pairings = s.pairings;
  const std::size_t old_size = p.map.size();
  auto is_old_update = [&](std::size_t k) {
    return pairings[k].decision == AssociationDecision::kUpdate && pairings[k].index < old_size;
  };
  double log_likelihood = 0.0;

  if (config.version == 2) {
    // The proposal (eq. 18): the prediction refined by each paired observation in turn.
    Pose2 mu = p.pose;
    Matrix3 sigma = p.pose_cov;
    for (std::size_t k = 0; k < n_obs; ++k) {
      if (!is_old_update(k)) continue;
      const LandmarkGaussian& lm = p.map[pairings[k].index];
      Matrix23 hx;
      Matrix2 hm;
      observation->jacobians(mu, lm.mean, hx, hm);
      const Vector2 nu = observation->residual(scan.observations[k].z, observation->predict(mu, lm.mean));
      const Matrix2 z_cov = hm * lm.covariance * hm.transpose() + r;
      const Eigen::Matrix<double, 3, 2> sht = sigma * hx.transpose();
      Matrix2 s_inverse;
      double log_det = 0.0;
      if (!nu.allFinite() || !invert_spd(symmetric(hx * sht + z_cov), s_inverse, log_det)) {
        log_likelihood = kMinusInf;
        continue;
      }
      log_likelihood += -0.5 * nu.dot(s_inverse * nu) - kLog2Pi - 0.5 * log_det;
      const Eigen::Matrix<double, 3, 2> gain = sht * s_inverse;
      mu += gain * nu;
      mu[2] = wrap_angle(mu[2]);
      const Matrix3 ikh = Matrix3::Identity() - gain * hx;
      sigma = symmetric(ikh * sigma * ikh.transpose() + gain * z_cov * gain.transpose());
    }
    p.pose = sample_gaussian(mu, sigma, s.rng);
    p.pose_cov.setZero();
    if (!p.path.empty()) p.path.replace_newest(p.pose);
  }

  // Landmark updates at the particle's final pose; for FastSLAM 1.0 they also give the weight.
  for (std::size_t k = 0; k < n_obs; ++k) {
    if (!is_old_update(k)) continue;
    const double ll = update_at(pairings[k].index, scan.observations[k].z);
    if (config.version == 1) log_likelihood += ll;
  }
  // New landmarks, and repeated observations of landmarks started in this scan, in scan order.
  for (std::size_t k = 0; k < n_obs; ++k) {
    Pairing& pairing = pairings[k];
    const Vector2& z = scan.observations[k].z;
    // A landmark started in this scan and seen again in it meets the outlier gate only now.
    if (known() && gate_known && pairing.decision == AssociationDecision::kUpdate && !is_old_update(k) &&
        beyond_gate(p, p.map[pairing.index], z))
      pairing = Pairing{};
    if (pairing.decision == AssociationDecision::kNew) {
      p.map.push_back(new_landmark(p.pose, z, known() ? scan.observations[k].id : kUnknownId));
      if (!known()) s.grid_entries.emplace_back(p.map[pairing.index].mean, pairing.index);
      log_likelihood += log_p0;
    } else if (pairing.decision == AssociationDecision::kDiscard) {
      log_likelihood += log_p0;
    } else if (!is_old_update(k)) {
      log_likelihood += update_at(pairing.index, z);
    }
  }
  if (!known()) count_misses(p, s);
  s.log_likelihood = log_likelihood;
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
    const bool expected = existence.detection_view().contains(observation->predict(p.pose, p.map[c.index].mean));
    if (!expected && existence.confirmed(p.map[c.index].existence)) continue;  // nothing to record: no copy
    LandmarkGaussian& lm = p.map.mutate(c.index);
    if (expected ? existence.missed(lm.existence) : existence.unseen_nearby(lm.existence)) lm.removed = true;
  }
}

}  // namespace slamkit
