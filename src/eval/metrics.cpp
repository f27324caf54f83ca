#include "slamkit/eval/metrics.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "slamkit/core/angles.hpp"

namespace slamkit::eval {

namespace {

void require_sorted(const std::vector<StampedPose>& poses, const char* what) {
  const auto unsorted = std::adjacent_find(
      poses.begin(), poses.end(), [](const StampedPose& a, const StampedPose& b) { return b.t < a.t; });
  if (unsorted != poses.end())
    throw std::invalid_argument(std::string(what) + " trajectory is not sorted by time at sample " +
                                std::to_string(unsorted - poses.begin() + 1));
}

bool all_coincide(const std::vector<Vector2>& points) {
  return std::all_of(points.begin(), points.end(), [&](const Vector2& p) { return p == points.front(); });
}

}  // namespace

Vector2 Se2Transform::apply(const Vector2& p) const { return Eigen::Rotation2Dd(theta) * p + translation; }

Pose2 Se2Transform::apply(const Pose2& pose) const {
  const Vector2 p = apply(Vector2(pose.head<2>()));
  return Pose2(p.x(), p.y(), wrap_angle(pose[2] + theta));
}

Se2Transform align_se2(const std::vector<Vector2>& source, const std::vector<Vector2>& target) {
  if (source.size() != target.size())
    throw std::invalid_argument("alignment needs equally many source and target points, got " +
                                std::to_string(source.size()) + " and " + std::to_string(target.size()));
  if (source.empty()) throw std::invalid_argument("alignment needs at least one point pair");

  const double n = static_cast<double>(source.size());
  Vector2 source_centroid = Vector2::Zero();
  Vector2 target_centroid = Vector2::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) {
    source_centroid += source[i];
    target_centroid += target[i];
  }
  source_centroid /= n;
  target_centroid /= n;

  // With all points of either set in one place every rotation fits equally well. The sums below would
  // then be rounding noise whose atan2 is arbitrary, so the rotation is pinned to 0 instead.
  Se2Transform t;
  if (!all_coincide(source) && !all_coincide(target)) {
    // For centred points the cost is const - 2 (cos(theta) sum s.t + sin(theta) sum s x t), which is
    // minimal where (cos, sin) points along (sum s.t, sum s x t).
    double dot = 0.0;
    double cross = 0.0;
    for (std::size_t i = 0; i < source.size(); ++i) {
      const Vector2 s = source[i] - source_centroid;
      const Vector2 d = target[i] - target_centroid;
      dot += s.dot(d);
      cross += s.x() * d.y() - s.y() * d.x();
    }
    t.theta = std::atan2(cross, dot);
  }
  t.translation = target_centroid - Eigen::Rotation2Dd(t.theta) * source_centroid;
  return t;
}

std::vector<PosePair> match_by_time(const std::vector<StampedPose>& estimate,
                                    const std::vector<StampedPose>& truth, double max_gap) {
  if (!(max_gap >= 0.0))
    throw std::invalid_argument("maximum interpolation gap must be non-negative, got " +
                                std::to_string(max_gap));
  require_sorted(estimate, "estimated");
  require_sorted(truth, "true");

  std::vector<PosePair> pairs;
  if (estimate.empty()) return pairs;
  pairs.reserve(truth.size());
  std::size_t i = 0;
  for (const StampedPose& sample : truth) {
    if (sample.t < estimate.front().t) continue;
    if (sample.t > estimate.back().t) break;
    while (i + 1 < estimate.size() && estimate[i + 1].t <= sample.t) ++i;

    const StampedPose& before = estimate[i];
    Pose2 pose;
    if (before.t == sample.t) {
      pose = before.pose;
    } else {
      // before.t < sample.t < estimate.back().t, so there is a later sample, strictly later than
      // sample.t.
      const StampedPose& after = estimate[i + 1];
      if (after.t - before.t > max_gap) continue;
      const double alpha = (sample.t - before.t) / (after.t - before.t);
      pose.head<2>() = (1.0 - alpha) * before.pose.head<2>() + alpha * after.pose.head<2>();
      pose[2] = wrap_angle(before.pose[2] + alpha * wrap_angle(after.pose[2] - before.pose[2]));
    }
    pairs.push_back({sample.t, pose, sample.pose, static_cast<int>(i)});
  }
  return pairs;
}

std::vector<PosePair> match_nearest(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& truth,
                                    double max_difference) {
  if (!(max_difference >= 0.0))
    throw std::invalid_argument("maximum time difference must be non-negative, got " + std::to_string(max_difference));
  require_sorted(estimate, "estimated");
  require_sorted(truth, "true");
  const bool walk_truth = estimate.size() > truth.size();
  const std::vector<StampedPose>& walked = walk_truth ? truth : estimate;
  const std::vector<StampedPose>& searched = walk_truth ? estimate : truth;
  std::vector<PosePair> pairs;
  if (searched.empty()) return pairs;
  std::size_t next = 0;  // the first searched sample at or after the walked one (times only grow)
  for (std::size_t i = 0; i < walked.size(); ++i) {
    const double t = walked[i].t;
    while (next < searched.size() && searched[next].t < t) ++next;
    std::size_t nearest = next;
    if (next == searched.size() || (next > 0 && t - searched[next - 1].t <= searched[next].t - t)) {
      // The earlier neighbour, at its first sample of that time: evo takes the first of equal distances.
      nearest = next - 1;
      while (nearest > 0 && searched[nearest - 1].t == searched[nearest].t) --nearest;
    }
    if (std::abs(searched[nearest].t - t) > max_difference) continue;
    const std::size_t e = walk_truth ? nearest : i;
    const std::size_t g = walk_truth ? i : nearest;
    pairs.push_back({truth[g].t, estimate[e].pose, truth[g].pose, static_cast<int>(e)});
  }
  return pairs;
}

double ate_rmse(const std::vector<PosePair>& pairs, const Se2Transform& align) {
  if (pairs.empty()) throw std::invalid_argument("trajectory error needs at least one matched pose");
  double sum = 0.0;
  for (const PosePair& p : pairs)
    sum += (align.apply(Vector2(p.estimate.head<2>())) - p.truth.head<2>()).squaredNorm();
  return std::sqrt(sum / static_cast<double>(pairs.size()));
}

AteResult absolute_trajectory_error(const std::vector<PosePair>& pairs) {
  if (pairs.empty()) throw std::invalid_argument("trajectory error needs at least one matched pose");
  std::vector<Vector2> estimated;
  std::vector<Vector2> true_positions;
  estimated.reserve(pairs.size());
  true_positions.reserve(pairs.size());
  for (const PosePair& p : pairs) {
    estimated.emplace_back(p.estimate.head<2>());
    true_positions.emplace_back(p.truth.head<2>());
  }
  AteResult result;
  result.align = align_se2(estimated, true_positions);
  result.rmse = ate_rmse(pairs, result.align);
  result.final_error = (result.align.apply(estimated.back()) - true_positions.back()).norm();
  result.matched = pairs.size();
  return result;
}

MapError map_rmse(const std::vector<Landmark>& estimate, const std::vector<Landmark>& truth,
                  const Se2Transform& align) {
  std::unordered_map<int, const Landmark*> truth_by_id;
  truth_by_id.reserve(truth.size());
  for (const Landmark& l : truth)
    if (l.id != kUnknownId && !truth_by_id.emplace(l.id, &l).second)
      throw std::invalid_argument("true map has landmark id " + std::to_string(l.id) + " more than once");

  std::unordered_set<int> seen;
  seen.reserve(estimate.size());
  MapError result;
  double sum = 0.0;
  for (const Landmark& l : estimate) {
    if (l.id == kUnknownId) continue;
    if (!seen.insert(l.id).second)
      throw std::invalid_argument("estimated map has landmark id " + std::to_string(l.id) +
                                  " more than once");
    const auto match = truth_by_id.find(l.id);
    if (match == truth_by_id.end()) continue;
    sum += (align.apply(l.position) - match->second->position).squaredNorm();
    ++result.paired;
  }
  if (result.paired > 0) result.rmse = std::sqrt(sum / static_cast<double>(result.paired));
  return result;
}

double pose_nees(const Pose2& estimate, const Matrix3& covariance, const Pose2& truth) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (!estimate.allFinite() || !truth.allFinite() || !covariance.allFinite()) return kInf;
  Eigen::Vector3d error = estimate - truth;
  error[2] = wrap_angle(error[2]);
  const Eigen::LLT<Matrix3> llt(covariance);
  if (llt.info() != Eigen::Success) return kInf;
  // e^T (L L^T)^-1 e = |L^-1 e|^2: one triangular solve, and the result cannot come out negative.
  return llt.matrixL().solve(error).squaredNorm();
}

NeesSummary summarize_nees(const std::vector<double>& nees, int dof, double confidence) {
  if (nees.empty()) throw std::invalid_argument("NEES summary needs at least one value");
  if (dof < 1) throw std::invalid_argument("NEES dimension must be at least 1, got " + std::to_string(dof));
  NeesSummary s;
  s.interval = chi_square_interval(confidence, dof);
  s.steps = nees.size();
  double sum = 0.0;
  std::size_t inside = 0;
  for (std::size_t i = 0; i < nees.size(); ++i) {
    if (!(nees[i] >= 0.0))
      throw std::invalid_argument("NEES value " + std::to_string(i) + " is " + std::to_string(nees[i]) +
                                  "; NEES is a non-negative number");
    sum += nees[i];
    if (s.interval.contains(nees[i])) ++inside;
  }
  s.mean = sum / static_cast<double>(nees.size());
  s.in_interval_fraction = static_cast<double>(inside) / static_cast<double>(nees.size());
  return s;
}

namespace {

/// a^-1 b: pose b seen from pose a.
Pose2 between(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a[2]), s = std::sin(a[2]);
  const Vector2 d = b.head<2>() - a.head<2>();
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y(), wrap_angle(b[2] - a[2])};
}

struct MeanAndStd {
  double sum = 0.0, squares = 0.0;
  void add(double v) {
    sum += v;
    squares += v * v;
  }
  double mean(std::size_t n) const { return sum / static_cast<double>(n); }
  double std(std::size_t n) const {
    const double m = mean(n);
    return std::sqrt(std::max(0.0, squares / static_cast<double>(n) - m * m));
  }
};

}  // namespace

std::optional<RelativePoseError> relative_pose_error(const std::vector<PosePair>& pairs) {
  if (pairs.empty()) return std::nullopt;
  RelativePoseError out;
  MeanAndStd translation, rotation;
  std::size_t from = 0;
  for (std::size_t to = 1; to < pairs.size(); ++to) {
    const Pose2 truth_motion = between(pairs[from].truth, pairs[to].truth);
    if (truth_motion.head<2>().norm() < kRelativePairDistance && std::abs(truth_motion[2]) < kRelativePairRotation)
      continue;
    const Pose2 error = between(truth_motion, between(pairs[from].estimate, pairs[to].estimate));
    translation.add(error.head<2>().norm());
    rotation.add(std::abs(error[2]));
    ++out.pairs;
    from = to;
  }
  if (out.pairs == 0) return std::nullopt;
  out.translation_mean_m = translation.mean(out.pairs);
  out.translation_std_m = translation.std(out.pairs);
  out.rotation_mean_rad = rotation.mean(out.pairs);
  out.rotation_std_rad = rotation.std(out.pairs);
  return out;
}

}  // namespace slamkit::eval
