// Data association: the settings check, the gates, nearest neighbour, joint compatibility (JCBB),
// the view test, the existence rule, and the grid that finds the candidates.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <random>

#include "slamkit/core/angles.hpp"
#include "slamkit/assoc/association.hpp"
#include "slamkit/assoc/landmark_existence.hpp"
#include "slamkit/assoc/landmark_grid.hpp"
#include "slamkit/assoc/sensor_view.hpp"
#include "slamkit/pipeline/factory.hpp"

using namespace slamkit;

namespace {

/// A belief with independent, well-known landmarks and a pose whose y is uncertain.
class FakeBelief final : public GaussianMapView {
 public:
  FakeBelief(Pose2 pose, Matrix3 pose_cov, std::vector<Vector2> landmarks, double landmark_sigma)
      : pose_(pose), pose_cov_(pose_cov), landmarks_(std::move(landmarks)), sigma_(landmark_sigma) {}
  Pose2 pose() const override { return pose_; }
  Matrix3 pose_covariance() const override { return pose_cov_; }
  Vector2 landmark_position(std::size_t i) const override { return landmarks_[i]; }
  Matrix23 landmark_pose_covariance(std::size_t) const override { return Matrix23::Zero(); }
  Matrix2 landmark_cross_covariance(std::size_t i, std::size_t j) const override {
    return i == j ? Matrix2(sigma_ * sigma_ * Matrix2::Identity()) : Matrix2::Zero();
  }

 private:
  Pose2 pose_;
  Matrix3 pose_cov_;
  std::vector<Vector2> landmarks_;
  double sigma_;
};

AssociationConfig config_for(AssociationMethod method) {
  AssociationConfig c;
  c.method = method;
  return c;
}

}  // namespace

TEST(Gates, AreChiSquareQuantilesWithTheMeasurementsDegreesOfFreedom) {
  const Gates g = Gates::from(AssociationConfig{}, 2);
  EXPECT_NEAR(g.accept, 9.2103, 1e-3);
  EXPECT_NEAR(g.new_landmark, 18.4207, 1e-3);
  // A range or a bearing alone: one degree of freedom (chi-square quantiles 6.635 at 0.99 and
  // 15.137 at 0.9999).
  const Gates one = Gates::from(AssociationConfig{}, 1);
  EXPECT_NEAR(one.accept, 6.6349, 1e-3);
  EXPECT_NEAR(one.new_landmark, 15.1367, 1e-3);
  AssociationConfig bad;
  bad.accept_probability = 0.9999;
  bad.new_landmark_probability = 0.99;
  EXPECT_THROW(Gates::from(bad, 2), std::invalid_argument);
  EXPECT_THROW(parse_association_method("fuzzy"), std::invalid_argument);
  EXPECT_EQ(parse_association_method("jcbb"), AssociationMethod::kJcbb);
  EXPECT_EQ(to_string(AssociationMethod::kNearestNeighbour), "nn");
}

// One check of the settings for every filter: each value out of range is named in the error.
TEST(AssociationConfig, ValidateNamesTheSettingOutOfRange) {
  EXPECT_NO_THROW(validate(AssociationConfig{}));
  const std::vector<std::pair<std::string, std::function<void(AssociationConfig&)>>> cases = {
      {"accept_probability", [](AssociationConfig& c) { c.accept_probability = 1.0; }},
      {"accept_probability", [](AssociationConfig& c) { c.accept_probability = std::nan(""); }},
      {"new_landmark_probability", [](AssociationConfig& c) { c.new_landmark_probability = 0.5; }},
      {"new_landmark_probability", [](AssociationConfig& c) { c.new_landmark_probability = 1.0; }},
      {"confirm_after", [](AssociationConfig& c) { c.confirm_after = 0; }},
      {"provisional_max_misses", [](AssociationConfig& c) { c.provisional_max_misses = 0; }},
      {"confirmed_max_misses", [](AssociationConfig& c) { c.confirmed_max_misses = -1; }},
      {"view_margin_m", [](AssociationConfig& c) { c.view_margin_m = -0.5; }},
      {"view_margin_rad", [](AssociationConfig& c) { c.view_margin_rad = std::numeric_limits<double>::infinity(); }},
      {"jcbb_max_nodes", [](AssociationConfig& c) { c.jcbb_max_nodes = 0; }},
      {"min_pairing_probability", [](AssociationConfig& c) { c.min_pairing_probability = 1.0; }},
      {"clutter_per_scan", [](AssociationConfig& c) { c.clutter_per_scan = -1.0; }},
  };
  for (const auto& [setting, spoil] : cases) {
    AssociationConfig c;
    spoil(c);
    try {
      validate(c);
      ADD_FAILURE() << setting << ": expected std::invalid_argument";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(setting), std::string::npos) << e.what();
    }
  }
  // No band of ambiguity between the gates is a valid choice.
  AssociationConfig equal_gates;
  equal_gates.new_landmark_probability = equal_gates.accept_probability;
  EXPECT_NO_THROW(validate(equal_gates));
}

// The front end's check of the filter settings, run before any data is read, is this same check.
TEST(AssociationConfig, FilterSettingsCheckIncludesIt) {
  FilterConfig config;
  config.association.confirm_after = 0;
  try {
    validate(config);
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("confirm_after"), std::string::npos) << e.what();
  }
}

TEST(SensorView, WidensAndNarrowsTheViewByItsMargins) {
  const SensorLimits forward{20.0, kPi};  // 180 degrees ahead
  const SensorView exact(forward, 0.0, 0.0), wide(forward, 2.0, 0.1), narrow(forward, -2.0, -0.1);
  const Vector2 at_edge(20.0, 0.5 * kPi), beyond(21.0, 0.5 * kPi + 0.05), inside(17.0, 0.5 * kPi - 0.2);
  const auto polar = [](const SensorView& view, const Vector2& p) { return view.contains_polar(p[0], p[1]); };
  EXPECT_TRUE(polar(exact, at_edge));
  EXPECT_FALSE(polar(exact, beyond));
  EXPECT_TRUE(polar(wide, beyond));
  EXPECT_FALSE(polar(narrow, at_edge));
  EXPECT_TRUE(polar(narrow, inside));
  EXPECT_FALSE(polar(exact, Vector2(5.0, -0.5 * kPi - 0.01)));
  EXPECT_FALSE(polar(wide, Vector2(std::nan(""), 0.0)));
  EXPECT_DOUBLE_EQ(narrow.reach(), 18.0);
  // A full circle, also when 360 degrees comes out a rounding error short of 2 pi, sees behind.
  const SensorView all_round(SensorLimits{20.0, 2.0 * kPi * (1.0 - 1e-15)}, -2.0, -0.1);
  EXPECT_TRUE(polar(all_round, Vector2(5.0, kPi)));
  // Narrowing a view by a margin is the view made with the margin narrower still.
  const SensorView narrowed = wide.narrowed(4.0, 0.2);
  EXPECT_DOUBLE_EQ(narrowed.reach(), narrow.reach());
  for (const Vector2& p : {at_edge, beyond, inside, Vector2(17.9, 0.5 * kPi - 0.11), Vector2(18.1, 0.0)})
    EXPECT_EQ(polar(narrowed, p), polar(narrow, p)) << p.transpose();
  EXPECT_TRUE(polar(all_round.narrowed(1.0, 3.0), Vector2(5.0, kPi))) << "a full circle stays one";
}

TEST(SensorView, JudgesALandmarkByWhereItIsWhateverTheSensorMeasures) {
  // The vehicle at (1, 2) heading north, its sensor 1 m ahead of the pose origin: at (1, 3).
  const SensorView ahead(SensorLimits{10.0, kPi}, 0.0, 0.0);
  const Pose2 x(1.0, 2.0, 0.5 * kPi);
  const RangeBearingModel range_bearing({.offset_x = 1.0});
  const RangeOnlyModel range_only({.offset_x = 1.0});
  const BearingOnlyModel bearing_only({.offset_x = 1.0});
  for (const ObservationModel* model : std::initializer_list<const ObservationModel*>{&range_bearing, &range_only, &bearing_only}) {
    EXPECT_TRUE(ahead.contains(*model, x, Vector2(1.0, 12.9))) << model->name() << ": 9.9 m straight ahead";
    EXPECT_FALSE(ahead.contains(*model, x, Vector2(1.0, 13.1))) << model->name() << ": 10.1 m ahead";
    EXPECT_FALSE(ahead.contains(*model, x, Vector2(1.0, 2.9))) << model->name() << ": behind the sensor";
    EXPECT_TRUE(ahead.contains(*model, x, Vector2(-5.0, 3.1))) << model->name() << ": to the left, just ahead";
  }
  // The same test as the range-bearing prediction's, bit for bit: map management's decisions are
  // the same as before the test went geometric.
  const Vector2 m(4.0, 9.0);
  const Measurement z = range_bearing.predict(x, m);
  EXPECT_EQ(ahead.contains(range_bearing, x, m), ahead.contains_polar(z[0], z[1]));
  EXPECT_THROW(validate(SensorLimits{0.0, kPi}), std::invalid_argument);
  EXPECT_THROW(validate(SensorLimits{10.0, std::nan("")}), std::invalid_argument);
}

TEST(ExistenceRule, AProvisionalLandmarkNearbyButOutOfViewIsRemovedUnlessConfirmed) {
  AssociationConfig c;
  c.confirm_after = 2;
  c.provisional_max_misses = 3;
  const ExistenceRule rule(c, SensorLimits{});
  LandmarkExistence provisional = rule.first_observed();
  EXPECT_FALSE(rule.unseen_nearby(provisional));
  EXPECT_FALSE(rule.missed(provisional)) << "misses in view and out of it add up";
  EXPECT_TRUE(rule.unseen_nearby(provisional)) << "never confirmed: removed even outside the view";

  LandmarkExistence confirmed = rule.first_observed();
  rule.observed(confirmed);
  ASSERT_TRUE(rule.confirmed(confirmed));
  for (int scan = 0; scan < 100; ++scan) EXPECT_FALSE(rule.unseen_nearby(confirmed)) << scan;
  EXPECT_FALSE(rule.missed(confirmed)) << "out-of-view scans are not misses of a confirmed landmark";
}

TEST(ExistenceRule, ConfirmsAfterRepeatedObservationsAndRemovesAfterMisses) {
  AssociationConfig c;
  c.confirm_after = 3;
  c.provisional_max_misses = 2;
  c.confirmed_max_misses = 4;
  const ExistenceRule rule(c, SensorLimits{});

  LandmarkExistence provisional = rule.first_observed();
  EXPECT_FALSE(rule.confirmed(provisional));
  EXPECT_FALSE(rule.missed(provisional));
  rule.observed(provisional);  // a sighting starts the misses over
  EXPECT_FALSE(rule.missed(provisional));
  EXPECT_TRUE(rule.missed(provisional)) << "two misses in a row remove a provisional landmark";

  LandmarkExistence confirmed = rule.first_observed();
  rule.observed(confirmed);
  rule.observed(confirmed);
  EXPECT_TRUE(rule.confirmed(confirmed)) << "the third observation confirms";
  for (int miss = 1; miss < 4; ++miss) EXPECT_FALSE(rule.missed(confirmed)) << miss;
  EXPECT_TRUE(rule.missed(confirmed));

  EXPECT_TRUE(rule.confirmed(rule.given()));
  c.confirmed_max_misses = 0;  // confirmed landmarks stay
  LandmarkExistence kept = ExistenceRule(c, SensorLimits{}).given();
  for (int miss = 0; miss < 100; ++miss) EXPECT_FALSE(ExistenceRule(c, SensorLimits{}).missed(kept));
  c.confirm_after = 1;
  EXPECT_TRUE(ExistenceRule(c, SensorLimits{}).confirmed(ExistenceRule(c, SensorLimits{}).first_observed()));

  // Misses count only well inside the view: the view narrowed by the margins.
  EXPECT_DOUBLE_EQ(rule.detection_view().reach(), SensorLimits{}.max_range - c.view_margin_m);
}

TEST(Association, AmbiguityThatNearestNeighbourGetsWrongAndJcbbGetsRight) {
  // Landmarks A and B lie 1.5 m apart; C is further off. The vehicle is really 0.8 m to the right of
  // where it believes it is (y uncertain, sigma 1 m), so everything appears shifted 0.8 m left.
  // Seen alone, the observation of A is nearer to B (0.7 m) than to A (0.8 m); jointly with the
  // observation of C, only "A and C" explains both by one common shift.
  const std::vector<Vector2> map = {{10.0, 0.0}, {10.0, 1.5}, {10.0, -5.0}};  // A, B, C
  const Pose2 believed(0, 0, 0);
  const Pose2 actual(0, -0.8, 0);
  const FakeBelief belief(believed, Eigen::Vector3d(1e-4, 1.0, 1e-8).asDiagonal(), map, 0.01);
  RangeBearingModel::Params params;
  params.sigma_range = 0.05;
  params.sigma_bearing = 0.005;
  const RangeBearingModel model(params);
  const std::vector<Observation> scan = {{model.predict(actual, map[0]), kUnknownId},
                                         {model.predict(actual, map[2]), kUnknownId}};
  const std::vector<std::size_t> candidates = {0, 1, 2};

  const auto nn = associate(scan, candidates, belief, model, config_for(AssociationMethod::kNearestNeighbour));
  ASSERT_EQ(nn[0].decision, AssociationDecision::kUpdate);
  EXPECT_EQ(nn[0].landmark, 1u) << "nearest neighbour takes the individually nearest, B";
  EXPECT_EQ(nn[1].landmark, 2u);

  AssociationStats stats;
  const auto jcbb = associate(scan, candidates, belief, model, config_for(AssociationMethod::kJcbb), &stats);
  ASSERT_EQ(jcbb[0].decision, AssociationDecision::kUpdate);
  EXPECT_EQ(jcbb[0].landmark, 0u) << "the joint test sees the common shift: A";
  ASSERT_EQ(jcbb[1].decision, AssociationDecision::kUpdate);
  EXPECT_EQ(jcbb[1].landmark, 2u);
  EXPECT_GT(stats.jcbb_nodes, 0u);
  EXPECT_FALSE(stats.jcbb_budget_exhausted);
}

TEST(Association, GatesDecideBetweenUpdateNewAndDiscard) {
  const std::vector<Vector2> map = {{10.0, 0.0}};
  const FakeBelief belief(Pose2::Zero(), Eigen::Vector3d(0.01, 0.01, 1e-6).asDiagonal(), map, 0.05);
  const RangeBearingModel model;
  const Matrix2 s_approx = Eigen::Vector2d(0.01 + 0.0125, 0.01 * 0.0003 + 0.0003).asDiagonal();
  (void)s_approx;
  const std::vector<std::size_t> candidates = {0};
  for (const auto method : {AssociationMethod::kNearestNeighbour, AssociationMethod::kJcbb}) {
    // On top of the landmark: update. Far away: new. In between the gates: discarded as ambiguous.
    const std::vector<Observation> scan = {{Vector2(10.0, 0.0), kUnknownId},
                                           {Vector2(20.0, 1.0), kUnknownId},
                                           {Vector2(10.5, 0.0), kUnknownId}};
    const auto out = associate(scan, candidates, belief, model, config_for(method));
    EXPECT_EQ(out[0].decision, AssociationDecision::kUpdate);
    EXPECT_EQ(out[1].decision, AssociationDecision::kNew);
    EXPECT_EQ(out[2].decision, AssociationDecision::kDiscard) << to_string(method);
  }
}

// The pairing probability: a landmark's innovation likelihood against every candidate's and the
// clutter density. An observation midway between two landmarks inside both gates is paired by the
// gates alone (with one of them), but not when a pairing must be 90% probable; one near a single
// landmark is paired unless false detections are dense enough to explain it as well.
TEST(Association, MinPairingProbabilityLeavesAmbiguousObservationsUnpaired) {
  const std::vector<Vector2> map = {{10.0, -0.5}, {10.0, 0.5}, {30.0, 30.0}};
  const FakeBelief belief(Pose2::Zero(), Eigen::Vector3d(0.3, 0.3, 1e-4).asDiagonal(), map, 0.05);
  const RangeBearingModel model;
  const SensorLimits sensor{30.0, std::numbers::pi};
  const std::vector<Observation> scan = {{model.predict(Pose2::Zero(), Vector2(10.0, 0.05)), kUnknownId},
                                         {model.predict(Pose2::Zero(), Vector2(30.2, 30.0)), kUnknownId}};
  const std::vector<std::size_t> candidates = {0, 1, 2};
  for (const auto method : {AssociationMethod::kNearestNeighbour, AssociationMethod::kJcbb}) {
    AssociationConfig config = config_for(method);
    const auto gated = associate(scan, candidates, belief, model, config);
    ASSERT_EQ(gated[0].decision, AssociationDecision::kUpdate) << to_string(method);
    EXPECT_LT(gated[0].landmark, 2u);
    ASSERT_EQ(gated[1].decision, AssociationDecision::kUpdate);

    config.min_pairing_probability = 0.9;
    const auto unique = associate(scan, candidates, belief, model, config);
    EXPECT_EQ(unique[0].decision, AssociationDecision::kDiscard) << "A and B explain it about as well";
    ASSERT_EQ(unique[1].decision, AssociationDecision::kUpdate) << "only C is near";
    EXPECT_EQ(unique[1].landmark, 2u);

    config.clutter_per_scan = 1.0;
    const auto sparse_clutter = associate(scan, candidates, belief, model, config, nullptr, clutter_density(config, sensor, model));
    EXPECT_EQ(sparse_clutter[1].decision, AssociationDecision::kUpdate) << "one false detection per scan is rare here";
    config.clutter_per_scan = 1e4;
    const auto dense_clutter = associate(scan, candidates, belief, model, config, nullptr, clutter_density(config, sensor, model));
    EXPECT_EQ(dense_clutter[1].decision, AssociationDecision::kDiscard) << "clutter explains it as well";
  }
}

TEST(Association, EachLandmarkIsPairedAtMostOncePerScan) {
  const std::vector<Vector2> map = {{10.0, 0.0}, {30.0, 30.0}};
  const FakeBelief belief(Pose2::Zero(), Eigen::Vector3d(0.04, 0.04, 1e-4).asDiagonal(), map, 0.05);
  const RangeBearingModel model;
  const std::vector<Observation> scan = {{Vector2(10.0, 0.0), kUnknownId}, {Vector2(10.05, 0.002), kUnknownId}};
  const std::vector<std::size_t> candidates = {0, 1};
  for (const auto method : {AssociationMethod::kNearestNeighbour, AssociationMethod::kJcbb}) {
    const auto out = associate(scan, candidates, belief, model, config_for(method));
    const int updates = static_cast<int>(std::count_if(out.begin(), out.end(), [](const Pairing& p) {
      return p.decision == AssociationDecision::kUpdate;
    }));
    EXPECT_EQ(updates, 1) << to_string(method);
  }
}

TEST(Association, JcbbBudgetReturnsTheBestHypothesisFoundSoFar) {
  // Many observations of a regular row of landmarks: a large search tree.
  std::vector<Vector2> map;
  for (int i = 0; i < 30; ++i) map.push_back(Vector2(10.0, -15.0 + i));
  const FakeBelief belief(Pose2::Zero(), Eigen::Vector3d(0.3, 0.3, 1e-4).asDiagonal(), map, 0.05);
  const RangeBearingModel model;
  std::vector<Observation> scan;
  for (const Vector2& m : map) scan.push_back({model.predict(Pose2::Zero(), m), kUnknownId});
  std::vector<std::size_t> candidates(map.size());
  for (std::size_t i = 0; i < map.size(); ++i) candidates[i] = i;
  AssociationConfig config = config_for(AssociationMethod::kJcbb);
  config.jcbb_max_nodes = 200;
  AssociationStats stats;
  const auto out = associate(scan, candidates, belief, model, config, &stats);
  EXPECT_LE(stats.jcbb_nodes, 200u);
  std::size_t correct = 0;
  for (std::size_t i = 0; i < out.size(); ++i)
    correct += out[i].decision == AssociationDecision::kUpdate && out[i].landmark == i;
  EXPECT_EQ(correct, map.size()) << "the first descent is already the right answer here";
}

TEST(LandmarkGrid, QueryFindsEveryLandmarkInTheDiscAndFewOthers) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-500.0, 500.0);
  std::vector<Vector2> points(5000);
  for (auto& p : points) p = Vector2(u(rng), u(rng));
  LandmarkGrid grid(10.0);
  for (std::size_t i = 0; i < points.size(); ++i) grid.insert(grid.cell_of(points[i]), static_cast<std::uint32_t>(i));
  std::vector<std::uint32_t> found;
  for (int trial = 0; trial < 50; ++trial) {
    const Vector2 centre(u(rng), u(rng));
    grid.query(centre, 30.0, found);
    std::sort(found.begin(), found.end());
    EXPECT_EQ(std::adjacent_find(found.begin(), found.end()), found.end()) << "each landmark is in one cell";
    std::size_t inside = 0;
    for (std::uint32_t i = 0; i < points.size(); ++i) {
      if ((points[i] - centre).norm() > 30.0) continue;
      ++inside;
      EXPECT_TRUE(std::binary_search(found.begin(), found.end(), i));
    }
    EXPECT_LE(found.size(), 3 * inside + 20) << "the query must stay local";
  }
  // Moving a landmark re-bins it.
  grid.erase(grid.cell_of(points[7]), 7);
  grid.insert(grid.cell_of(Vector2(1000.0, 1000.0)), 7);
  grid.query(Vector2(1000.0, 1000.0), 1.0, found);
  EXPECT_EQ(found, std::vector<std::uint32_t>{7});
  grid.query(points[7], 1.0, found);
  EXPECT_EQ(std::find(found.begin(), found.end(), 7u), found.end());
  // Clearing empties every cell.
  grid.clear();
  grid.query(Vector2::Zero(), 600.0, found);
  EXPECT_TRUE(found.empty());
}

// Positions from a diverged estimate (1e20 m, infinite, NaN) and a search region grown with it: no
// undefined conversion, and a query over 10^30 cells answers from the cells that exist.
TEST(LandmarkGrid, FarPositionsAndHugeQueriesStayBounded) {
  LandmarkGrid grid(5.0);
  const std::vector<Vector2> points = {Vector2(1.0, 1.0), Vector2(1e20, -1e20), Vector2(-1e300, 3.0),
                                       Vector2(std::numeric_limits<double>::infinity(), 0.0),
                                       Vector2(std::nan(""), 2.0)};
  for (std::uint32_t i = 0; i < points.size(); ++i) grid.insert(grid.cell_of(points[i]), i);
  // Saturated columns keep far points apart from the near one.
  EXPECT_NE(grid.cell_of(points[1]), grid.cell_of(points[0]));
  EXPECT_NE(grid.cell_of(points[2]), grid.cell_of(points[0]));
  std::vector<std::uint32_t> found;
  const std::size_t cells = grid.cells();
  grid.query(Vector2::Zero(), 1e6, found);  // 4e10 cells
  EXPECT_EQ(grid.cells(), cells) << "a wide query creates no cells (a 1e5 s gap once took FastSLAM 5.6 GB)";
  std::sort(found.begin(), found.end());
  EXPECT_EQ(found, (std::vector<std::uint32_t>{0, 4}));  // NaN is binned at column 0
  grid.query(Vector2::Zero(), std::numeric_limits<double>::infinity(), found);
  EXPECT_EQ(found.size(), points.size());
  // prune() after a wide query visits the same cells.
  grid.prune([](LandmarkGrid::Cell, std::uint32_t index) { return index != 3; });
  grid.query(Vector2::Zero(), std::numeric_limits<double>::infinity(), found);
  EXPECT_EQ(found.size(), points.size() - 1);
  // An ordinary query after them still lists what is near.
  grid.query(Vector2(1.0, 1.0), 2.0, found);
  std::sort(found.begin(), found.end());
  EXPECT_EQ(found, (std::vector<std::uint32_t>{0, 4}));
}

// FastSLAM's relocalisation lists candidates over squares that grow with the drift: list() answers
// as query() does, narrow or wide, but creates no cell and leaves the cells prune() visits alone.
TEST(LandmarkGrid, ListAnswersAsQueryWithoutCreatingCellsOrMovingThePrune) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-200.0, 200.0);
  LandmarkGrid grid(10.0);
  for (std::uint32_t i = 0; i < 500; ++i) grid.insert(grid.cell_of(Vector2(u(rng), u(rng))), i);
  std::vector<std::uint32_t> listed, queried;
  for (const double radius : {5.0, 40.0, 1e4, std::numeric_limits<double>::infinity()}) {
    const std::size_t cells = grid.cells();
    grid.list(Vector2(u(rng), u(rng)), radius, listed);
    EXPECT_EQ(grid.cells(), cells) << "radius " << radius;
    grid.list(Vector2(3.0, -7.0), radius, listed);
    grid.query(Vector2(3.0, -7.0), radius, queried);
    std::sort(listed.begin(), listed.end());
    std::sort(queried.begin(), queried.end());
    EXPECT_EQ(listed, queried) << "radius " << radius;
  }
  EXPECT_GE(grid.max_entries(), 500u);
  // The prune after a narrow query and a wide list still visits the query's cells only.
  grid.query(Vector2(3.0, -7.0), 5.0, queried);
  grid.list(Vector2::Zero(), std::numeric_limits<double>::infinity(), listed);
  const std::size_t all = listed.size();
  grid.prune([](LandmarkGrid::Cell, std::uint32_t) { return false; });
  grid.list(Vector2::Zero(), std::numeric_limits<double>::infinity(), listed);
  EXPECT_EQ(listed.size(), all - queried.size());
}

// FastSLAM's use: one landmark listed in several cells (one per particle's version), once per cell,
// and entries no version needs pruned from the cells the last query visited only.
TEST(LandmarkGrid, ListsALandmarkInSeveralCellsAndPrunesAroundTheLastQuery) {
  LandmarkGrid grid(5.0);
  const LandmarkGrid::Cell a = grid.cell_of(Vector2(1.0, 1.0));
  const LandmarkGrid::Cell b = grid.cell_of(Vector2(-1.0, 1.0));
  const LandmarkGrid::Cell far = grid.cell_of(Vector2(100.0, 100.0));
  ASSERT_NE(a, b);
  grid.insert(a, 3);
  grid.insert(a, 3);  // listed once per cell
  grid.insert(b, 3);
  grid.insert(b, 4);
  grid.insert(far, 3);
  std::vector<std::uint32_t> found;
  grid.query(Vector2::Zero(), 2.0, found);
  std::sort(found.begin(), found.end());
  EXPECT_EQ(found, (std::vector<std::uint32_t>{3, 3, 4}));

  // Only version 3 in cell a is still needed; the entries in the far cell are not visited.
  grid.prune([&](LandmarkGrid::Cell cell, std::uint32_t index) { return cell == a && index == 3; });
  grid.query(Vector2(-1.0, 1.0), 0.5, found);
  EXPECT_TRUE(found.empty());
  grid.query(Vector2(1.0, 1.0), 0.5, found);
  EXPECT_EQ(found, std::vector<std::uint32_t>{3});
  grid.query(Vector2(100.0, 100.0), 0.5, found);
  EXPECT_EQ(found, std::vector<std::uint32_t>{3});
}
