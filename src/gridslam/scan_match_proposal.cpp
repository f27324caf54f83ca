#include "slamkit/gridslam/scan_match_proposal.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <stdexcept>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/random_draws.hpp"
#include "slamkit/models/motion_model.hpp"

namespace slamkit {

namespace {

constexpr int kStencilPoses = 27;

/// Keeps the prior's density finite where the odometry has not moved (a zero covariance) or moves
/// along a degenerate direction: a millimetre and a tenth of a milliradian are far below anything a
/// laser resolves.
Matrix3 regularised(const Matrix3& covariance) {
  Matrix3 c = 0.5 * (covariance + covariance.transpose());
  c.diagonal() += Eigen::Vector3d(1e-6, 1e-6, 1e-8);
  return c;
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
  require(o.weight_temperature >= 1.0 && o.weight_temperature <= 1000.0, "weight_temperature", "from 1 to 1000",
          o.weight_temperature);
  require(o.min_matched_fraction >= 0.0 && o.min_matched_fraction <= 1.0, "min_matched_fraction", "from 0 to 1",
          o.min_matched_fraction);
  require(o.proposal_spread_m > 0.0 && o.proposal_spread_m <= 1.0, "proposal_spread_m", "> 0 and <= 1",
          o.proposal_spread_m);
  require(o.proposal_sample_fraction >= 0.0 && o.proposal_sample_fraction <= 1.0, "proposal_sample_fraction",
          "from 0 to 1", o.proposal_sample_fraction);
  require(o.update_distance >= 0.0 && o.update_distance <= 100.0, "update_distance_m", "from 0 to 100",
          o.update_distance);
  require(o.update_rotation >= 0.0 && o.update_rotation <= kPi, "update_rotation_deg", "from 0 to 180",
          rad2deg(o.update_rotation));
  require(o.proposal_spread_rad > 0.0 && o.proposal_spread_rad <= deg2rad(10.0), "proposal_spread_deg",
          "> 0 and <= 10", rad2deg(o.proposal_spread_rad));
}

void ScanCadence::moved(const Pose2& before, const Pose2& after) {
  travelled_ += (after.head<2>() - before.head<2>()).norm();
  turned_ += std::abs(wrap_angle(after.z() - before.z()));
}

bool ScanCadence::due(const GridSlamOptions& options) const {
  return !started_ || travelled_ >= options.update_distance || turned_ >= options.update_rotation;
}

bool ScanCadence::take(const GridSlamOptions& options) {
  if (!due(options)) {
    ++skipped_;
    return false;
  }
  started_ = true;
  travelled_ = turned_ = 0.0;
  return true;
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
  const Eigen::LDLT<Matrix3> prior(regularised(prior_covariance));
  const Matrix3 prior_information = prior.solve(Matrix3::Identity());
  const PosePrior odometry{prior_mean, prior_information, 1.0 / temperature};
  const ScanMatch peak = matcher.match(map, odometry, scan);
  proposal.matched = peak.beams_used > 0 &&
                     peak.beams_matched >= options.min_matched_fraction * static_cast<double>(peak.beams_used);
  const auto odometry_proposes = [&] {
    proposal.mean = prior_mean;
    proposal.covariance = prior_covariance;
    draw(proposal, options, rng);
    proposal.log_weight = matcher.evaluate(map, proposal.mean, scan).log_likelihood / temperature;
    return proposal;
  };
  if (!proposal.matched) return odometry_proposes();

  // The product's logarithm around the peak, on the poses of a 3 x 3 x 3 stencil that move along one
  // or two axes (the second differences need no more): its curvature is that of a Laplace
  // approximation, whose Gaussian is as wide as the product is, not as the stencil: along a
  // corridor, where the scan says little, the proposal keeps the odometry's spread, and that is what
  // keeps the particles diverse until a loop tells them apart.
  const double prior_log_norm = -0.5 * prior.vectorD().array().log().sum() - 1.5 * std::log(2.0 * kPi);
  const Eigen::Vector3d step(options.proposal_spread_m, options.proposal_spread_m, options.proposal_spread_rad);
  std::array<double, kStencilPoses> log_terms{};
  for (int k = 0; k < kStencilPoses; ++k) {
    const Eigen::Vector3i cell(k % 3 - 1, k / 3 % 3 - 1, k / 9 - 1);
    if (cell.cwiseAbs().sum() == 3) continue;
    const Eigen::Vector3d offset = cell.cast<double>().cwiseProduct(step);
    Pose2 pose = peak.pose + offset;
    pose[2] = wrap_angle(pose[2]);
    log_terms[k] = odometry.log_posterior(pose, matcher.evaluate(map, pose, scan).log_likelihood) + prior_log_norm;
  }
  const auto at = [&](Eigen::Vector3i offset) {
    return log_terms[(offset[0] + 1) + 3 * (offset[1] + 1) + 9 * (offset[2] + 1)];
  };
  const double centre = at(Eigen::Vector3i::Zero());
  Matrix3 hessian;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3i ei = Eigen::Vector3i::Unit(i);
    hessian(i, i) = (at(ei) - 2.0 * centre + at(-ei)) / (step[i] * step[i]);
    for (int j = 0; j < i; ++j) {
      const Eigen::Vector3i ej = Eigen::Vector3i::Unit(j);
      hessian(i, j) = hessian(j, i) =
          (at(ei + ej) - at(ei - ej) - at(ej - ei) + at(-ei - ej)) / (4.0 * step[i] * step[j]);
    }
  }
  // The prior's curvature is known exactly; what the differences add beyond it is the scan's
  // information, which cannot be negative. A likelihood field is only piecewise smooth, so where the
  // differences make it so (a ridge between two walls' cells) that direction keeps the prior's alone.
  const Eigen::SelfAdjointEigenSolver<Matrix3> scan_part(-hessian - prior_information);
  const Matrix3 scan_information = scan_part.eigenvectors() * scan_part.eigenvalues().cwiseMax(0.0).asDiagonal() *
                                   scan_part.eigenvectors().transpose();
  const Matrix3 information = prior_information + scan_information;
  const Eigen::LLT<Matrix3> factor(information);
  // Only a prior too wide for doubles (a covariance near 1e300 from a log's wild odometry) gets here
  // with curvatures that are not numbers; the odometry then says what is known.
  if (!information.allFinite() || factor.info() != Eigen::Success) {
    proposal.matched = false;
    return odometry_proposes();
  }
  // The climb found the product's peak already: a Newton step from the pattern's gradient would
  // follow the likelihood field's roughness (a tree's one or two cells, a beam crossing to the next
  // wall cell), and where the scan is weak, the covariance it is scaled by is wide.
  proposal.mean = peak.pose;
  proposal.covariance = factor.solve(Matrix3::Identity());
  proposal.covariance = 0.5 * (proposal.covariance + proposal.covariance.transpose());
  // The weight factor is p(z | m, x', u), the product's integral over the pose: its Laplace
  // approximation, the product's peak times sqrt(det(2 pi covariance)). It is on the same scale as
  // an unmatched particle's factor (the likelihood at a draw from the prior, an estimate of the same
  // integral), so particles of one scan that did and did not match compete fairly.
  const Matrix3 l = factor.matrixL();
  proposal.log_weight = centre + 1.5 * std::log(2.0 * kPi) - l.diagonal().array().log().sum();
  draw(proposal, options, rng);
  return proposal;
}

}  // namespace slamkit
