// Map matching (assoc/map_matching.hpp): JCBB over pairs of landmarks of one joint Gaussian, the
// search relocalisation uses to recognise an old map mapped again after a drift.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <vector>

#include "slamkit/assoc/map_matching.hpp"

using namespace slamkit;

namespace {

/// Landmarks with a full joint covariance; the pose plays no part in map matching.
class FullMap final : public GaussianMapView {
 public:
  FullMap(std::vector<Vector2> means, Eigen::MatrixXd covariance)
      : means_(std::move(means)), covariance_(std::move(covariance)) {}
  Pose2 pose() const override { return Pose2::Zero(); }
  Matrix3 pose_covariance() const override { return Matrix3::Zero(); }
  Vector2 landmark_position(std::size_t i) const override { return means_[i]; }
  Matrix23 landmark_pose_covariance(std::size_t) const override { return Matrix23::Zero(); }
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override {
    return covariance_.block<2, 2>(2 * static_cast<Eigen::Index>(i), 2 * static_cast<Eigen::Index>(j));
  }

 private:
  std::vector<Vector2> means_;
  Eigen::MatrixXd covariance_;
};

/// Old landmarks known to sigma_old each; duplicates mapped after a drift common to all of them
/// (sigma_drift per axis) plus sigma_own each: the duplicates are strongly correlated with each
/// other, so their discrepancies from the originals must agree.
FullMap drifted_map(const std::vector<Vector2>& old, const std::vector<Vector2>& duplicates) {
  constexpr double sigma_old = 0.1, sigma_drift = 2.0, sigma_own = 0.2;
  std::vector<Vector2> means = old;
  means.insert(means.end(), duplicates.begin(), duplicates.end());
  const auto n = static_cast<Eigen::Index>(means.size());
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  const auto first_duplicate = static_cast<Eigen::Index>(old.size());
  for (Eigen::Index i = 0; i < n; ++i) {
    const bool dup_i = i >= first_duplicate;
    p.block<2, 2>(2 * i, 2 * i) = (dup_i ? sigma_own * sigma_own : sigma_old * sigma_old) * Matrix2::Identity();
    for (Eigen::Index j = first_duplicate; j < n && dup_i; ++j)
      p.block<2, 2>(2 * i, 2 * j) += sigma_drift * sigma_drift * Matrix2::Identity();
  }
  return FullMap(std::move(means), std::move(p));
}

constexpr double kProbability = 0.99;

}  // namespace

TEST(MapMatching, RecognisesDuplicatesShiftedByACommonDrift) {
  const std::vector<Vector2> old = {{0, 0}, {10, 2}, {4, 9}, {30, 30}};
  const Vector2 drift(3.0, -2.0);  // 1.5 and 1 sd of the drift
  const FullMap map = drifted_map(old, {old[0] + drift, old[1] + drift + Vector2(0.1, 0.05), old[2] + drift});
  MapMatcher matcher;
  const std::vector<std::size_t> recent = {4, 5, 6}, candidates = {0, 1, 2, 3};
  const std::vector<LandmarkPair>& pairs = matcher.match(recent, candidates, map, kProbability, 1000);
  ASSERT_EQ(pairs.size(), 3u);
  for (const LandmarkPair& p : pairs) EXPECT_EQ(p.original + 4, p.duplicate);
}

// Each duplicate alone fits an old landmark 3 m off in some direction (inside the drift's gate), but
// one drift cannot move the two the opposite ways: jointly they are incompatible.
TEST(MapMatching, RejectsPairsThatNoCommonDriftExplains) {
  const std::vector<Vector2> old = {{0, 0}, {10, 0}};
  const FullMap map = drifted_map(old, {old[0] + Vector2(3, 0), old[1] + Vector2(-3, 0)});
  MapMatcher matcher;
  const std::vector<std::size_t> recent = {2, 3}, candidates = {0, 1};
  const std::vector<LandmarkPair>& pairs = matcher.match(recent, candidates, map, kProbability, 1000);
  EXPECT_EQ(pairs.size(), 1u) << "either pair alone passes its gate, both together do not";
}

// A wrong old landmark lies closer to one duplicate than its original does; nearest neighbour would
// take it, but only the originals fit the drift the other duplicates show.
TEST(MapMatching, PrefersTheJointlyCompatibleHypothesisOverTheNearestPair) {
  const Vector2 drift(-2.5, 1.5);
  std::vector<Vector2> old = {{0, 0}, {8, 3}, {-5, 7}};
  old.push_back(old[0] + drift + Vector2(0.3, 0.2));  // next to the first duplicate
  const FullMap map = drifted_map(old, {old[0] + drift, old[1] + drift, old[2] + drift});
  MapMatcher matcher;
  const std::vector<std::size_t> recent = {4, 5, 6}, candidates = {0, 1, 2, 3};
  const std::vector<std::size_t> first_duplicate = {4};
  ASSERT_EQ(matcher.match(first_duplicate, candidates, map, kProbability, 1000).size(), 1u);
  EXPECT_EQ(matcher.match(first_duplicate, candidates, map, kProbability, 1000)[0].original, 3u) << "alone, the nearest";
  const std::vector<LandmarkPair>& pairs = matcher.match(recent, candidates, map, kProbability, 1000);
  ASSERT_EQ(pairs.size(), 3u);
  for (const LandmarkPair& p : pairs) EXPECT_EQ(p.original + 4, p.duplicate);
}

TEST(MapMatching, FindsNothingWithoutCandidatesOrWithinTheBudget) {
  const std::vector<Vector2> old = {{0, 0}, {10, 2}};
  const FullMap map = drifted_map(old, {old[0] + Vector2(40, 0), old[1] + Vector2(1, 1)});
  MapMatcher matcher;
  const std::vector<std::size_t> far = {2}, near = {3}, candidates = {0, 1};
  MapMatchStats stats;
  EXPECT_TRUE(matcher.match(far, candidates, map, kProbability, 1000, &stats).empty()) << "40 m is 20 sd of drift";
  EXPECT_EQ(stats.pairs_tested, 2u);
  EXPECT_EQ(matcher.match(near, candidates, map, kProbability, 1000).size(), 1u);
  EXPECT_TRUE(matcher.match(near, candidates, map, kProbability, 0).empty()) << "no search node allowed";
}
