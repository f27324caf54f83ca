// Evaluation metrics: known answers for alignment, time matching, trajectory and map error, NEES and
// its summary, plus a brute-force cross-check of the time-matching merge.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "slamkit/core/angles.hpp"
#include "slamkit/eval/metrics.hpp"

using namespace slamkit;
using namespace slamkit::eval;

namespace {

constexpr double kPlusInfinity = std::numeric_limits<double>::infinity();

std::vector<Vector2> random_points(std::size_t n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> coordinate(-50.0, 50.0);
  std::vector<Vector2> points(n);
  for (Vector2& p : points) p = Vector2(coordinate(rng), coordinate(rng));
  return points;
}

double alignment_cost(const Se2Transform& t, const std::vector<Vector2>& source,
                      const std::vector<Vector2>& target) {
  double cost = 0.0;
  for (std::size_t i = 0; i < source.size(); ++i) cost += (t.apply(source[i]) - target[i]).squaredNorm();
  return cost;
}

/// A curving path with headings along it, 1 s apart.
std::vector<StampedPose> curved_path(int n) {
  std::vector<StampedPose> path;
  for (int i = 0; i < n; ++i) {
    const double s = 0.3 * i;
    path.push_back(
        {static_cast<double>(i), Pose2(10.0 * std::sin(s), 6.0 * std::sin(2.0 * s), wrap_angle(2.0 * s))});
  }
  return path;
}

std::vector<PosePair> pair_up(const std::vector<StampedPose>& estimate,
                              const std::vector<StampedPose>& truth) {
  std::vector<PosePair> pairs;
  for (std::size_t i = 0; i < truth.size(); ++i)
    pairs.push_back({truth[i].t, estimate[i].pose, truth[i].pose, static_cast<int>(i)});
  return pairs;
}

}  // namespace

TEST(Se2Transform, RotatesThenTranslates) {
  const Se2Transform t{kPi / 2, Vector2(1.0, 2.0)};
  const Vector2 p = t.apply(Vector2(1.0, 0.0));
  EXPECT_NEAR(p.x(), 1.0, 1e-15);
  EXPECT_NEAR(p.y(), 3.0, 1e-15);
  const Pose2 pose = t.apply(Pose2(1.0, 0.0, 3.0));
  EXPECT_NEAR(pose[0], 1.0, 1e-15);
  EXPECT_NEAR(pose[1], 3.0, 1e-15);
  EXPECT_NEAR(pose[2], 3.0 + kPi / 2 - 2 * kPi, 1e-15);  // wrapped
}

TEST(AlignSe2, RecoversAKnownTransformExactly) {
  std::mt19937_64 rng(7);
  for (const double theta : {0.0, 0.7, -2.5, 3.1, kPi}) {
    SCOPED_TRACE(testing::Message() << "theta " << theta);
    const Se2Transform truth{theta, Vector2(300.0, -120.0)};
    const std::vector<Vector2> source = random_points(20, rng);
    std::vector<Vector2> target;
    for (const Vector2& p : source) target.push_back(truth.apply(p));
    const Se2Transform t = align_se2(source, target);
    EXPECT_NEAR(wrap_angle(t.theta - theta), 0.0, 1e-12);
    EXPECT_NEAR(t.translation.x(), 300.0, 1e-9);
    EXPECT_NEAR(t.translation.y(), -120.0, 1e-9);
  }
}

TEST(AlignSe2, MinimisesTheSquaredErrorOfNoisyPoints) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 2.0);
  const std::vector<Vector2> source = random_points(30, rng);
  const Se2Transform truth{1.2, Vector2(-4.0, 9.0)};
  std::vector<Vector2> target;
  for (const Vector2& p : source) target.push_back(truth.apply(p) + Vector2(noise(rng), noise(rng)));
  const Se2Transform best = align_se2(source, target);
  const double cost = alignment_cost(best, source, target);
  // Any perturbation of the optimum, in rotation or in translation, costs more.
  for (const double d : {-1e-3, 1e-3}) {
    EXPECT_GT(alignment_cost({best.theta + d, best.translation}, source, target), cost);
    EXPECT_GT(alignment_cost({best.theta, best.translation + Vector2(d, 0.0)}, source, target), cost);
    EXPECT_GT(alignment_cost({best.theta, best.translation + Vector2(0.0, d)}, source, target), cost);
  }
}

TEST(AlignSe2, OnePointOrCoincidentPointsFixOnlyTheTranslation) {
  const Se2Transform one = align_se2({Vector2(1.0, 2.0)}, {Vector2(4.0, -1.0)});
  EXPECT_EQ(one.theta, 0.0);
  EXPECT_EQ(one.translation, Vector2(3.0, -3.0));

  // The centroid of three copies of 0.1 is not exactly 0.1, so without special care the centred points
  // would be rounding noise with an arbitrary direction (here it would give theta = -pi/4).
  const std::vector<Vector2> same(3, Vector2(0.1, 0.7));
  const Se2Transform coincident = align_se2(same, {Vector2(0.1, 0.2), Vector2(0.7, 0.3), Vector2(1.1, 2.3)});
  EXPECT_EQ(coincident.theta, 0.0);
  EXPECT_NEAR(coincident.translation.x(), 1.9 / 3 - 0.1, 1e-15);
  EXPECT_NEAR(coincident.translation.y(), 2.8 / 3 - 0.7, 1e-15);
}

TEST(AlignSe2, RejectsMismatchedOrEmptyInput) {
  EXPECT_THROW(align_se2({Vector2(0, 0), Vector2(1, 0)}, {Vector2(0, 0)}), std::invalid_argument);
  EXPECT_THROW(align_se2({}, {}), std::invalid_argument);
}

TEST(MatchByTime, InterpolatesAtMidpoints) {
  const std::vector<StampedPose> estimate{{0.0, Pose2(0.0, 0.0, 0.0)}, {2.0, Pose2(2.0, 4.0, 1.0)}};
  const std::vector<StampedPose> truth{{0.5, Pose2(9, 9, 0)}, {1.0, Pose2(8, 8, 0)}};
  const std::vector<PosePair> pairs = match_by_time(estimate, truth, 5.0);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_DOUBLE_EQ(pairs[0].t, 0.5);
  EXPECT_TRUE(pairs[0].estimate.isApprox(Pose2(0.5, 1.0, 0.25), 1e-15));
  EXPECT_TRUE(pairs[1].estimate.isApprox(Pose2(1.0, 2.0, 0.5), 1e-15));
  EXPECT_EQ(pairs[1].truth, Pose2(8, 8, 0));
  EXPECT_EQ(pairs[0].estimate_index, 0);
  EXPECT_EQ(pairs[1].estimate_index, 0);
}

TEST(MatchByTime, InterpolatesHeadingTheShortWayAcrossPi) {
  const std::vector<StampedPose> estimate{{0.0, Pose2(0, 0, kPi - 0.1)}, {1.0, Pose2(0, 0, -kPi + 0.1)}};
  const std::vector<StampedPose> truth{{0.25, Pose2::Zero()}, {0.5, Pose2::Zero()}, {0.75, Pose2::Zero()}};
  const std::vector<PosePair> pairs = match_by_time(estimate, truth, 1.0);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_NEAR(pairs[0].estimate[2], kPi - 0.05, 1e-12);
  EXPECT_NEAR(std::abs(pairs[1].estimate[2]), kPi, 1e-12);
  EXPECT_NEAR(pairs[2].estimate[2], -kPi + 0.05, 1e-12);
}

TEST(MatchByTime, ExactTimestampsAreNotPerturbed) {
  // Values chosen so that reaching t = 1 by interpolating from t = 0 (alpha = 1) rounds differently:
  // -3.1 + (-0.9 - -3.1) == -0.8999999999999999.
  const std::vector<StampedPose> estimate{
      {0.0, Pose2(-3.1, -3.1, -3.1)}, {1.0, Pose2(-0.9, -0.9, -0.9)}, {2.0, Pose2(0.5, 0.5, 0.5)}};
  const std::vector<PosePair> pairs =
      match_by_time(estimate, {{1.0, Pose2::Zero()}, {2.0, Pose2::Zero()}}, 1.0);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].estimate, Pose2(-0.9, -0.9, -0.9));
  EXPECT_EQ(pairs[0].estimate_index, 1);
  EXPECT_EQ(pairs[1].estimate, Pose2(0.5, 0.5, 0.5));
  EXPECT_EQ(pairs[1].estimate_index, 2);
}

TEST(MatchByTime, RepeatedTimestampUsesTheLastSample) {
  const std::vector<StampedPose> estimate{
      {0.0, Pose2(0, 0, 0)}, {1.0, Pose2(1, 0, 0)}, {1.0, Pose2(1, 1, 0)}, {2.0, Pose2(2, 1, 0)}};
  const std::vector<PosePair> pairs = match_by_time(estimate, {{1.0, Pose2::Zero()}}, 1.0);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].estimate, Pose2(1, 1, 0));
  EXPECT_EQ(pairs[0].estimate_index, 2);
}

TEST(MatchByTime, SkipsTruthOutsideTheSpanOrInLongGaps) {
  const std::vector<StampedPose> estimate{
      {0.0, Pose2(0, 0, 0)}, {1.0, Pose2(1, 0, 0)}, {5.0, Pose2(5, 0, 0)}, {6.0, Pose2(6, 0, 0)}};
  const std::vector<StampedPose> truth{{-1.0, Pose2::Zero()},
                                       {0.5, Pose2::Zero()},
                                       {3.0, Pose2::Zero()},
                                       {5.5, Pose2::Zero()},
                                       {7.0, Pose2::Zero()}};
  const std::vector<PosePair> pairs = match_by_time(estimate, truth, 2.0);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].t, 0.5);
  EXPECT_EQ(pairs[0].estimate_index, 0);
  EXPECT_EQ(pairs[1].t, 5.5);
  EXPECT_EQ(pairs[1].estimate_index, 2);
  EXPECT_NEAR(pairs[1].estimate[0], 5.5, 1e-15);

  // With no gap allowed only exact timestamps pair up.
  const std::vector<PosePair> exact =
      match_by_time(estimate, {{0.5, Pose2::Zero()}, {5.0, Pose2::Zero()}}, 0.0);
  ASSERT_EQ(exact.size(), 1u);
  EXPECT_EQ(exact[0].t, 5.0);
}

TEST(MatchByTime, AgreesWithABruteForceSearch) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> time(0.0, 100.0);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  std::vector<StampedPose> estimate(400);
  std::vector<StampedPose> truth(300);
  for (StampedPose& s : estimate)
    s = {std::round(time(rng) * 4.0) / 4.0, Pose2(time(rng), time(rng), angle(rng))};
  for (StampedPose& s : truth) s = {std::round(time(rng) * 8.0) / 8.0 - 5.0, Pose2::Zero()};
  const auto by_time = [](const StampedPose& a, const StampedPose& b) { return a.t < b.t; };
  std::stable_sort(estimate.begin(), estimate.end(), by_time);
  std::stable_sort(truth.begin(), truth.end(), by_time);
  const double max_gap = 0.6;

  std::vector<PosePair> expected;
  for (const StampedPose& s : truth) {
    if (s.t < estimate.front().t || s.t > estimate.back().t) continue;
    const auto after = std::upper_bound(estimate.begin(), estimate.end(), s, by_time);
    const auto before = after - 1;
    const int index = static_cast<int>(before - estimate.begin());
    if (before->t == s.t) {
      expected.push_back({s.t, before->pose, s.pose, index});
    } else if (after->t - before->t <= max_gap) {
      const double alpha = (s.t - before->t) / (after->t - before->t);
      Pose2 p;
      p.head<2>() = before->pose.head<2>() + alpha * (after->pose.head<2>() - before->pose.head<2>());
      p[2] = wrap_angle(before->pose[2] + alpha * wrap_angle(after->pose[2] - before->pose[2]));
      expected.push_back({s.t, p, s.pose, index});
    }
  }

  const std::vector<PosePair> pairs = match_by_time(estimate, truth, max_gap);
  ASSERT_EQ(pairs.size(), expected.size());
  ASSERT_GT(pairs.size(), 50u);  // the data must exercise both branches
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    SCOPED_TRACE(testing::Message() << "pair " << i << " at t " << pairs[i].t);
    EXPECT_EQ(pairs[i].t, expected[i].t);
    EXPECT_EQ(pairs[i].estimate_index, expected[i].estimate_index);
    EXPECT_NEAR((pairs[i].estimate.head<2>() - expected[i].estimate.head<2>()).norm(), 0.0, 1e-12);
    EXPECT_NEAR(wrap_angle(pairs[i].estimate[2] - expected[i].estimate[2]), 0.0, 1e-12);
  }
}

TEST(MatchByTime, HandlesEmptyAndRejectsBadInput) {
  EXPECT_TRUE(match_by_time({}, {{0.0, Pose2::Zero()}}, 1.0).empty());
  EXPECT_TRUE(match_by_time({{0.0, Pose2::Zero()}}, {}, 1.0).empty());
  const std::vector<StampedPose> unsorted{{1.0, Pose2::Zero()}, {0.0, Pose2::Zero()}};
  const std::vector<StampedPose> sorted{{0.0, Pose2::Zero()}, {1.0, Pose2::Zero()}};
  EXPECT_THROW(match_by_time(unsorted, sorted, 1.0), std::invalid_argument);
  EXPECT_THROW(match_by_time(sorted, unsorted, 1.0), std::invalid_argument);
  EXPECT_THROW(match_by_time(sorted, sorted, -1.0), std::invalid_argument);
  EXPECT_THROW(match_by_time(sorted, sorted, std::nan("")), std::invalid_argument);
}

// evo's pairing, by hand. The vehicle drives along x at 1 m/s and every estimate sample lies exactly
// on its path, at its own time; the truth is sampled once a second. evo walks the shorter trajectory
// (the truth: 5 samples against 6) and pairs each sample with the nearest estimate within 0.01 s:
//   t = 0 with 0.004 (x error +0.004), t = 1 with 1.0 (0), t = 2 with 2.008 (+0.008),
//   t = 3: the nearest, 3.02, is 0.02 s away, so it is left out; t = 4 with 3.996 (-0.004).
// The points are collinear along x with errors along x, so the alignment is a shift by their mean
// error, 0.002 m, leaving residuals +0.002, -0.002, +0.006, -0.006: RMSE sqrt(80e-6 / 4) = sqrt(2e-5)
// = 4.472 mm. Interpolated at the truth times (across gaps up to 2 s), the same estimate is exact
// (0 m) over the three truth samples inside its span.
TEST(MatchNearest, ReproducesEvosPairingAndNumberByHand) {
  std::vector<StampedPose> truth, estimate;
  for (const double t : {0.0, 1.0, 2.0, 3.0, 4.0}) truth.push_back({t, Pose2(t, 0.0, 0.0)});
  for (const double t : {0.004, 1.0, 1.5, 2.008, 3.02, 3.996}) estimate.push_back({t, Pose2(t, 0.0, 0.0)});

  const std::vector<PosePair> evo = match_nearest(estimate, truth, 0.01);
  ASSERT_EQ(evo.size(), 4u);
  const int expected_index[] = {0, 1, 3, 5};
  const double expected_t[] = {0.0, 1.0, 2.0, 4.0};
  for (std::size_t i = 0; i < evo.size(); ++i) {
    EXPECT_EQ(evo[i].estimate_index, expected_index[i]) << i;
    EXPECT_EQ(evo[i].t, expected_t[i]) << i;
    EXPECT_EQ(evo[i].estimate, estimate[static_cast<std::size_t>(expected_index[i])].pose) << i;
  }
  const AteResult ate = absolute_trajectory_error(evo);
  EXPECT_NEAR(ate.rmse, std::sqrt(2e-5), 1e-12);
  EXPECT_NEAR(ate.align.theta, 0.0, 1e-12);
  EXPECT_NEAR(ate.align.translation.x(), -0.002, 1e-12);

  const std::vector<PosePair> interpolated = match_by_time(estimate, truth, 2.0);
  ASSERT_EQ(interpolated.size(), 3u);
  EXPECT_NEAR(absolute_trajectory_error(interpolated).rmse, 0.0, 1e-12);

  // A wider window takes t = 3 too (with 3.02); none at all only exact times.
  EXPECT_EQ(match_nearest(estimate, truth, 0.05).size(), 5u);
  EXPECT_EQ(match_nearest(estimate, truth, 0.0).size(), 1u);
}

// When the estimate is the shorter (or as long), evo walks the estimate; a truth sample may then
// serve two estimate samples, and of equally near ones the first is taken (numpy's argmin). The
// times are binary fractions, so "equally near" is exact.
TEST(MatchNearest, WalksTheShorterTrajectoryAndTakesTheFirstOfEquallyNear) {
  const std::vector<StampedPose> truth{{0.0, Pose2(0, 0, 0)}, {0.25, Pose2(1, 0, 0)}, {0.25, Pose2(2, 0, 0)},
                                       {0.5, Pose2(3, 0, 0)}};
  const std::vector<StampedPose> estimate{{0.125, Pose2::Zero()}, {0.3125, Pose2::Zero()}, {0.375, Pose2::Zero()}};
  const std::vector<PosePair> pairs = match_nearest(estimate, truth, 0.125);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[0].truth, Pose2(0, 0, 0));  // halfway between 0 and 0.25: the earlier
  EXPECT_EQ(pairs[1].truth, Pose2(1, 0, 0));  // nearest the two samples at 0.25: the first of them
  EXPECT_EQ(pairs[2].truth, Pose2(1, 0, 0));  // halfway between 0.25 and 0.5: the first at 0.25
  for (std::size_t i = 0; i < pairs.size(); ++i) EXPECT_EQ(pairs[i].estimate_index, static_cast<int>(i));

  EXPECT_TRUE(match_nearest({}, truth, 0.01).empty());
  EXPECT_TRUE(match_nearest(estimate, {}, 0.01).empty());
  const std::vector<StampedPose> unsorted{{1.0, Pose2::Zero()}, {0.0, Pose2::Zero()}};
  EXPECT_THROW(match_nearest(unsorted, truth, 0.01), std::invalid_argument);
  EXPECT_THROW(match_nearest(estimate, truth, -0.01), std::invalid_argument);
  EXPECT_THROW(match_nearest(estimate, truth, std::nan("")), std::invalid_argument);
}

TEST(AbsoluteTrajectoryError, RigidlyMovedCopyHasZeroError) {
  const std::vector<StampedPose> truth = curved_path(40);
  const Se2Transform moved{-2.2, Vector2(150.0, 75.0)};
  std::vector<StampedPose> estimate = truth;
  for (StampedPose& s : estimate) s.pose = moved.apply(s.pose);

  const AteResult ate = absolute_trajectory_error(pair_up(estimate, truth));
  EXPECT_EQ(ate.matched, 40u);
  EXPECT_NEAR(ate.rmse, 0.0, 1e-9);
  EXPECT_NEAR(ate.final_error, 0.0, 1e-9);
  // The alignment found is the inverse of the displacement.
  EXPECT_NEAR(wrap_angle(ate.align.theta + moved.theta), 0.0, 1e-12);
}

TEST(AbsoluteTrajectoryError, ErrorThatNoRigidMotionRemoves) {
  // Every estimate pushed 0.5 m radially outwards from the centre of a symmetric square: the pushes
  // cancel in the centroid and exert no torque, so the best alignment is the identity and the error
  // stays 0.5 m at every pose.
  const std::vector<StampedPose> truth{
      {0, Pose2(1, 1, 0)}, {1, Pose2(-1, 1, 0)}, {2, Pose2(-1, -1, 0)}, {3, Pose2(1, -1, 0)}};
  std::vector<StampedPose> estimate = truth;
  for (StampedPose& s : estimate) s.pose.head<2>() += 0.5 * s.pose.head<2>().normalized();

  const AteResult ate = absolute_trajectory_error(pair_up(estimate, truth));
  EXPECT_NEAR(ate.rmse, 0.5, 1e-12);
  EXPECT_NEAR(ate.final_error, 0.5, 1e-12);
  EXPECT_NEAR(ate.align.theta, 0.0, 1e-12);
  EXPECT_NEAR(ate.align.translation.norm(), 0.0, 1e-12);
}

TEST(AteRmse, KnownOffsetWithAGivenAlignment) {
  const std::vector<StampedPose> truth = curved_path(10);
  std::vector<StampedPose> estimate = truth;
  for (StampedPose& s : estimate) s.pose.head<2>() += Vector2(3.0, 4.0);
  const std::vector<PosePair> pairs = pair_up(estimate, truth);
  EXPECT_NEAR(ate_rmse(pairs, Se2Transform{}), 5.0, 1e-12);
  EXPECT_NEAR(ate_rmse(pairs, Se2Transform{0.0, Vector2(-3.0, -4.0)}), 0.0, 1e-12);
  // Alignment takes a pure offset out.
  EXPECT_NEAR(absolute_trajectory_error(pairs).rmse, 0.0, 1e-12);
}

TEST(AteRmse, RejectsNoPairs) {
  EXPECT_THROW(ate_rmse({}, Se2Transform{}), std::invalid_argument);
  EXPECT_THROW(absolute_trajectory_error({}), std::invalid_argument);
}

TEST(MapRmse, PairsLandmarksById) {
  const std::vector<Landmark> truth{
      {1, Vector2(0, 0)}, {2, Vector2(10, 0)}, {5, Vector2(0, 10)}, {kUnknownId, Vector2(1, 1)}};
  // Estimates in a frame rotated by 90 degrees; id 7 has no true counterpart, id 5 was never mapped,
  // and unidentified landmarks pair with nothing, not even each other.
  const std::vector<Landmark> estimate{{2, Vector2(0, -10)},
                                       {7, Vector2(3, 3)},
                                       {1, Vector2(2, 0)},
                                       {kUnknownId, Vector2(1, -1)},
                                       {kUnknownId, Vector2(9, 9)}};
  const Se2Transform align{kPi / 2, Vector2::Zero()};
  const MapError error = map_rmse(estimate, truth, align);
  EXPECT_EQ(error.paired, 2u);
  ASSERT_TRUE(error.rmse.has_value());
  // Landmark 1 is off by 2 m after alignment, landmark 2 is exact.
  EXPECT_NEAR(*error.rmse, std::sqrt(4.0 / 2.0), 1e-12);
}

TEST(MapRmse, NoPairsGivesNoValue) {
  const MapError error = map_rmse({{3, Vector2(1, 1)}}, {{4, Vector2(1, 1)}}, Se2Transform{});
  EXPECT_EQ(error.paired, 0u);
  EXPECT_FALSE(error.rmse.has_value());
  EXPECT_FALSE(map_rmse({}, {}, Se2Transform{}).rmse.has_value());
}

TEST(MapRmse, RejectsDuplicateIds) {
  const std::vector<Landmark> duplicated{{1, Vector2(0, 0)}, {1, Vector2(1, 1)}};
  const std::vector<Landmark> single{{1, Vector2(0, 0)}};
  EXPECT_THROW(map_rmse(duplicated, single, Se2Transform{}), std::invalid_argument);
  EXPECT_THROW(map_rmse(single, duplicated, Se2Transform{}), std::invalid_argument);
}

TEST(PoseNees, KnownErrorAndCovariance) {
  const Matrix3 diagonal = Eigen::Vector3d(1.0, 4.0, 0.01).asDiagonal();
  EXPECT_NEAR(pose_nees(Pose2(1.0, 2.0, 0.1), diagonal, Pose2::Zero()), 3.0, 1e-12);

  Matrix3 correlated;
  correlated << 2.0, 0.5, 0.1, 0.5, 1.0, -0.2, 0.1, -0.2, 0.3;
  const Eigen::Vector3d e(0.3, -1.2, 0.4);
  const double expected = e.dot(correlated.inverse() * e);
  EXPECT_NEAR(pose_nees(Pose2(5.3, 1.8, 0.4), correlated, Pose2(5.0, 3.0, 0.0)), expected, 1e-12);
}

TEST(PoseNees, HeadingErrorIsWrapped) {
  const Matrix3 p = Eigen::Vector3d(1.0, 1.0, 0.01).asDiagonal();
  // 0.1 rad apart across the +-pi seam, not 2 pi - 0.1.
  EXPECT_NEAR(pose_nees(Pose2(0, 0, kPi - 0.05), p, Pose2(0, 0, -kPi + 0.05)), 1.0, 1e-9);
}

TEST(PoseNees, InvalidCovarianceOrInputGivesInfinity) {
  const Pose2 x(1.0, 0.0, 0.0);
  Matrix3 indefinite = Matrix3::Identity();
  indefinite(1, 1) = -1.0;
  EXPECT_EQ(pose_nees(x, indefinite, Pose2::Zero()), kPlusInfinity);
  Matrix3 singular = Matrix3::Identity();
  singular(2, 2) = 0.0;
  EXPECT_EQ(pose_nees(x, singular, Pose2::Zero()), kPlusInfinity);
  Matrix3 with_nan = Matrix3::Identity();
  with_nan(2, 2) = std::nan("");
  EXPECT_EQ(pose_nees(x, with_nan, Pose2::Zero()), kPlusInfinity);
  EXPECT_EQ(pose_nees(Pose2(std::nan(""), 0, 0), Matrix3::Identity(), Pose2::Zero()), kPlusInfinity);
}

TEST(PoseNees, SamplesFromTheCovarianceAreConsistent) {
  // Errors drawn from N(0, P) give a chi2(3) NEES: mean 3, 95% inside the 95% interval.
  Matrix3 p;
  p << 0.5, 0.1, 0.02, 0.1, 0.3, -0.01, 0.02, -0.01, 0.05;
  const Matrix3 l = p.llt().matrixL();
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  std::vector<double> nees;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d e = l * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    nees.push_back(
        pose_nees(Pose2(10.0 + e[0], -3.0 + e[1], wrap_angle(0.2 + e[2])), p, Pose2(10.0, -3.0, 0.2)));
  }
  const NeesSummary s = summarize_nees(nees, 3);
  // Standard errors: sqrt(6 / 20000) = 0.017 for the mean, 0.0015 for the fraction.
  EXPECT_NEAR(s.mean, 3.0, 0.07);
  EXPECT_NEAR(s.in_interval_fraction, 0.95, 0.006);
}

TEST(SummarizeNees, MeanAndShareInsideTheInterval) {
  // chi2(2) 95% interval: [-2 ln 0.975, -2 ln 0.025] = [0.0506, 7.378].
  const double lo = -2.0 * std::log(0.975);
  const std::vector<double> nees{0.01, lo, 1.0, 3.0, 8.0};
  const NeesSummary s = summarize_nees(nees, 2, 0.95);
  EXPECT_NEAR(s.interval.lo, lo, 1e-13);
  EXPECT_NEAR(s.interval.hi, -2.0 * std::log(0.025), 1e-13);
  EXPECT_EQ(s.steps, 5u);
  EXPECT_NEAR(s.mean, (0.01 + lo + 1.0 + 3.0 + 8.0) / 5.0, 1e-15);
  EXPECT_DOUBLE_EQ(s.in_interval_fraction, 0.6);

  // The 50% interval [-2 ln 0.75, -2 ln 0.25] = [0.575, 2.773] holds only the 1.
  EXPECT_DOUBLE_EQ(summarize_nees(nees, 2, 0.5).in_interval_fraction, 0.2);
}

TEST(SummarizeNees, InfinityCountsAsOutside) {
  const NeesSummary s = summarize_nees({1.0, kPlusInfinity}, 1);
  EXPECT_EQ(s.mean, kPlusInfinity);
  EXPECT_DOUBLE_EQ(s.in_interval_fraction, 0.5);
}

TEST(SummarizeNees, RejectsInvalidInput) {
  EXPECT_THROW(summarize_nees({}, 3), std::invalid_argument);
  EXPECT_THROW(summarize_nees({1.0, std::nan("")}, 3), std::invalid_argument);
  EXPECT_THROW(summarize_nees({1.0, -0.5}, 3), std::invalid_argument);
  EXPECT_THROW(summarize_nees({1.0}, 0), std::invalid_argument);
  EXPECT_THROW(summarize_nees({1.0}, 3, 1.0), std::invalid_argument);
}

namespace {

/// Pairs along a straight drive of `n` steps of `step` metres, the estimate's k-th motion off by
/// `extra` metres along the way and `turn` radians.
std::vector<PosePair> straight_drive(int n, double step, double extra, double turn) {
  std::vector<PosePair> pairs;
  Pose2 estimate = Pose2::Zero();
  for (int k = 0; k <= n; ++k) {
    pairs.push_back({static_cast<double>(k), estimate, Pose2(step * k, 0.0, 0.0), k});
    estimate += Pose2((step + extra) * std::cos(estimate[2]), (step + extra) * std::sin(estimate[2]), turn);
  }
  return pairs;
}

}  // namespace

TEST(RelativePoseError, IsTheMotionErrorBetweenPairsHalfAMetreApart) {
  // Steps of 0.25 m: pairs are every second sample (0.5 m). Each estimated step is 0.01 m long and
  // turns 0.002 rad more than the truth's, so over a pair the translation error is about 0.02 m
  // and the rotation error 0.004 rad, whatever the estimate's accumulated heading error.
  const std::optional<RelativePoseError> r = relative_pose_error(straight_drive(40, 0.25, 0.01, 0.002));
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->pairs, 20u);
  EXPECT_NEAR(r->translation_mean_m, 0.02, 1e-3);
  EXPECT_NEAR(r->rotation_mean_rad, 0.004, 1e-9);
  EXPECT_NEAR(r->rotation_std_rad, 0.0, 1e-9);
}

TEST(RelativePoseError, IsZeroForAnEstimateOffByOneRigidMotion) {
  std::vector<PosePair> pairs = straight_drive(20, 0.5, 0.0, 0.0);
  for (PosePair& p : pairs) {
    const double c = std::cos(0.7), s = std::sin(0.7);
    p.estimate = Pose2(c * p.truth.x() - s * p.truth.y() + 3.0, s * p.truth.x() + c * p.truth.y() - 1.0, 0.7);
  }
  const std::optional<RelativePoseError> r = relative_pose_error(pairs);
  ASSERT_TRUE(r.has_value());
  EXPECT_NEAR(r->translation_mean_m, 0.0, 1e-12);
  EXPECT_NEAR(r->rotation_mean_rad, 0.0, 1e-12);
}

TEST(RelativePoseError, NeedsTheTruthToMove) {
  EXPECT_FALSE(relative_pose_error(straight_drive(10, 0.01, 0.0, 0.0)).has_value());
  EXPECT_FALSE(relative_pose_error({}).has_value());
}
