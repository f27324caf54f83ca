#include "slamkit/gridslam/scan_match_proposal.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/random_draws.hpp"
#include "slamkit/models/motion_model.hpp"

namespace slamkit {

namespace {

constexpr int kPatternPoses = 27;
constexpr double kCovarianceFloor = 0.1;  // of the pattern's spacing

/// Keeps the prior's density finite where the odometry has not moved (a zero covariance) or moves
/// along a degenerate direction: a millimetre and a tenth of a milliradian are far below anything a
/// laser resolves.
Matrix3 regularised(const Matrix3& covariance) {
  Matrix3 c = 0.5 * (covariance + covariance.transpose());
  c.diagonal() += Eigen::Vector3d(1e-6, 1e-6, 1e-8);
  return c;
}

double log_sum_exp(const std::array<double, kPatternPoses>& terms) {
  const double peak = *std::max_element(terms.begin(), terms.end());
  if (!std::isfinite(peak)) return peak;
  double sum = 0.0;
  for (double t : terms) sum += std::exp(t - peak);
  return peak + std::log(sum);
}

/// With a generator, moves the proposal's mean to a draw from N(mean, f covariance) and leaves it
/// the (1 - f) covariance it carries about the draw.
void draw(PoseProposal& proposal, const GridSlamOptions& options, std::mt19937_64* rng) {
  if (rng == nullptr) return;
  const double f = options.proposal_sample_fraction;
  proposal.mean = sample_gaussian(proposal.mean, f * proposal.covariance, *rng);
  proposal.covariance *= 1.0 - f;
}

}  // namespace

void validate(const GridSlamOptions& o) {
  const auto require = [](bool ok, const char* key, const char* range, double value) {
    if (!ok) throw std::invalid_argument(fmt::format("grid.{} must be {}, found {}", key, range, value));
  };
  require(o.grid.resolution >= 0.005 && o.grid.resolution <= 1.0, "resolution_m", "from 0.005 to 1", o.grid.resolution);
  require(o.grid.range_cutoff > 0.0 && o.grid.range_cutoff <= 1000.0, "range_cutoff_m", "> 0 and <= 1000",
          o.grid.range_cutoff);
  require(o.grid.max_cells >= 1.0 && o.grid.max_cells <= 1e12, "max_cells", "from 1 to 1e12", o.grid.max_cells);
  require(o.matcher.sigma > 0.0 && o.matcher.sigma <= 1.0, "match_sigma_m", "> 0 and <= 1", o.matcher.sigma);
  require(o.matcher.search_cells >= 0 && o.matcher.search_cells <= 10, "match_search_cells", "from 0 to 10",
          o.matcher.search_cells);
  require(o.matcher.beam_stride >= 1 && o.matcher.beam_stride <= 100, "match_beam_stride", "from 1 to 100",
          o.matcher.beam_stride);
  require(o.matcher.max_range > 0.0 && o.matcher.max_range <= 1000.0, "match_max_range_m", "> 0 and <= 1000",
          o.matcher.max_range);
  require(o.likelihood_temperature >= 1.0 && o.likelihood_temperature <= 1000.0, "likelihood_temperature",
          "from 1 to 1000", o.likelihood_temperature);
  require(o.min_matched_fraction >= 0.0 && o.min_matched_fraction <= 1.0, "min_matched_fraction", "from 0 to 1",
          o.min_matched_fraction);
  require(o.proposal_spread_m > 0.0 && o.proposal_spread_m <= 1.0, "proposal_spread_m", "> 0 and <= 1",
          o.proposal_spread_m);
  require(o.proposal_sample_fraction >= 0.0 && o.proposal_sample_fraction <= 1.0, "proposal_sample_fraction",
          "from 0 to 1", o.proposal_sample_fraction);
  require(o.proposal_spread_rad > 0.0 && o.proposal_spread_rad <= deg2rad(10.0), "proposal_spread_deg",
          "> 0 and <= 10", rad2deg(o.proposal_spread_rad));
}

void predict_pose(const MotionModel& motion, const ControlEvent& control, Pose2& mean, Matrix3& covariance) {
  const Matrix3 f = motion.jacobian_state(mean, control.u, control.dt);
  const Matrix3 q = motion.process_noise(mean, control.u, control.dt);
  mean = motion.predict(mean, control.u, control.dt);
  covariance = f * covariance * f.transpose() + q;
  covariance = 0.5 * (covariance + covariance.transpose());
}

PoseProposal scan_match_proposal(const ScanMatcher& matcher, const OccupancyGrid& map, const RangeScanEvent& scan,
                                 const Pose2& prior_mean, const Matrix3& prior_covariance,
                                 const GridSlamOptions& options, std::mt19937_64* rng) {
  const double temperature = options.likelihood_temperature;
  PoseProposal proposal;
  const ScanMatch peak = matcher.match(map, prior_mean, scan);
  proposal.matched = peak.beams_used > 0 &&
                     peak.beams_matched >= options.min_matched_fraction * static_cast<double>(peak.beams_used);
  if (!proposal.matched) {
    proposal.mean = prior_mean;
    proposal.covariance = prior_covariance;
    draw(proposal, options, rng);
    proposal.log_weight = matcher.evaluate(map, proposal.mean, scan).log_likelihood / temperature;
    return proposal;
  }

  const Eigen::LDLT<Matrix3> prior(regularised(prior_covariance));
  const double prior_log_norm = -0.5 * prior.vectorD().array().log().sum() - 1.5 * std::log(2.0 * kPi);
  const Eigen::Vector3d spread(options.proposal_spread_m, options.proposal_spread_m, options.proposal_spread_rad);
  std::array<Eigen::Vector3d, kPatternPoses> offsets;
  std::array<double, kPatternPoses> log_terms;
  for (int k = 0; k < kPatternPoses; ++k) {
    offsets[k] = Eigen::Vector3d(k % 3 - 1, k / 3 % 3 - 1, k / 9 - 1).cwiseProduct(spread);
    Pose2 pose = peak.pose + offsets[k];
    pose[2] = wrap_angle(pose[2]);
    Eigen::Vector3d from_prior = pose - prior_mean;
    from_prior[2] = wrap_angle(from_prior[2]);
    log_terms[k] = matcher.evaluate(map, pose, scan).log_likelihood / temperature -
                   0.5 * from_prior.dot(prior.solve(from_prior)) + prior_log_norm;
  }
  // The weight factor is p(z | m, x', u), the integral of the product over the pose: the pattern's
  // sum times the volume each of its poses stands for. The volume matters where some particles of
  // a scan are matched and others are not (their factor, the likelihood at a draw from the prior,
  // estimates the same integral): without it a matched particle would gain the prior's density,
  // some 13 nats on a Radish log's scan, over one that is not, whatever its map.
  const double log_sum = log_sum_exp(log_terms);
  proposal.log_weight = log_sum + std::log(spread.prod());
  Eigen::Vector3d mean_offset = Eigen::Vector3d::Zero();
  Matrix3 second_moment = Matrix3::Zero();
  for (int k = 0; k < kPatternPoses; ++k) {
    const double w = std::exp(log_terms[k] - log_sum);
    mean_offset += w * offsets[k];
    second_moment += w * offsets[k] * offsets[k].transpose();
  }
  // A peak much sharper than the pattern's spacing puts (almost) every weight on the centre, and the
  // pattern's covariance would be singular: a tenth of the spacing is kept, far below the spread a
  // scan's likelihood leaves (a few millimetres with the defaults) and so below anything it adds.
  const Eigen::Vector3d floor = (kCovarianceFloor * spread).cwiseAbs2();
  proposal.covariance = second_moment - mean_offset * mean_offset.transpose();
  proposal.covariance.diagonal() += floor;
  proposal.mean = peak.pose + mean_offset;
  proposal.mean[2] = wrap_angle(proposal.mean[2]);
  draw(proposal, options, rng);
  return proposal;
}

}  // namespace slamkit
