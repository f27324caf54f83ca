// The compressed EKF is an exact reorganisation of the full one: the same data must give the same
// state, covariance and association decisions, whichever local areas it went through.
#include <gtest/gtest.h>

#include <algorithm>
#include <iomanip>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "slamkit/filters/compressed_joint_gaussian.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/joint_gaussian.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

using namespace slamkit;

namespace {

constexpr double kTolerance = 1e-8;

struct CompressedDifferences {
  double state = 0.0;
  double covariance = 0.0;
  std::size_t checks = 0;
  std::size_t decisions_differing = 0;
  double flushes = 0.0;
  double landmarks_fused = 0.0;
  std::size_t landmarks = 0;
};

/// The full EKF and the compressed one, built alike for `data` (joint scan updates unless `update`
/// says otherwise) and driven by the same events.
struct VariantPair {
  VariantPair(const Dataset& data, AssociationMethod method, EkfUpdate update = EkfUpdate::kJoint) {
    FilterConfig config;
    config.association.method = method;
    config.ekf_update = update;
    full_filter = make_filter(config, data);
    config.ekf_variant = EkfVariant::kCompressed;
    compressed_filter = make_filter(config, data);
  }
  /// Feeds `event` to both; true when it was a scan.
  bool step(const Event& event) {
    if (const auto* c = std::get_if<ControlEvent>(&event)) {
      full().predict(*c);
      compressed().predict(*c);
      return false;
    }
    full().update(std::get<ScanEvent>(event));
    compressed().update(std::get<ScanEvent>(event));
    return true;
  }
  EkfSlam& full() { return dynamic_cast<EkfSlam&>(*full_filter); }
  EkfSlam& compressed() { return dynamic_cast<EkfSlam&>(*compressed_filter); }

  std::unique_ptr<SlamFilter> full_filter;
  std::unique_ptr<SlamFilter> compressed_filter;
};

/// An estimator fed with known identities by hand, as EkfSlam with sequential updates and no outlier
/// gate feeds it, so that a test can remove landmarks between scans.
struct KnownIdentities {
  explicit KnownIdentities(std::unique_ptr<EkfEstimator> e) : estimator(std::move(e)) {}
  void update(const ScanEvent& scan) {
    estimator->begin_scan();
    std::vector<const Observation*> fresh;
    for (const Observation& o : scan.observations) {
      const auto it = std::find(ids.begin(), ids.end(), o.id);
      if (it == ids.end())
        fresh.push_back(&o);
      else
        estimator->update_landmark(static_cast<std::size_t>(it - ids.begin()), o.z);
    }
    for (const Observation* o : fresh) {
      const auto it = std::find(ids.begin(), ids.end(), o->id);
      if (it != ids.end()) {
        estimator->update_landmark(static_cast<std::size_t>(it - ids.begin()), o->z);
        continue;
      }
      estimator->add_landmark(o->z);
      ids.push_back(o->id);
    }
  }
  void remove(std::size_t index) {
    estimator->remove_landmark(index);
    ids.erase(ids.begin() + static_cast<std::ptrdiff_t>(index));
  }

  std::unique_ptr<EkfEstimator> estimator;
  std::vector<int> ids;  // per map index
};

/// Runs the full and the compressed EKF side by side over `data`, comparing the whole state and
/// covariance every `check_every` scans and at the end, and every scan's association decisions.
CompressedDifferences compare_variants(const Dataset& data, AssociationMethod method, std::size_t check_every,
                             EkfUpdate update = EkfUpdate::kJoint) {
  VariantPair pair(data, method, update);
  EkfSlam& full = pair.full();
  EkfSlam& compressed = pair.compressed();

  CompressedDifferences diff;
  auto compare = [&] {
    const EkfEstimator& a = full.estimator();
    const EkfEstimator& b = compressed.estimator();
    EXPECT_EQ(a.state_dim(), b.state_dim());
    if (a.state_dim() != b.state_dim()) return;
    diff.state = std::max(diff.state, (a.state() - b.state()).cwiseAbs().maxCoeff());
    diff.covariance = std::max(diff.covariance, (a.covariance() - b.covariance()).cwiseAbs().maxCoeff());
    ++diff.checks;
  };
  std::size_t scans = 0;
  for (const Event& e : data.events) {
    if (!pair.step(e)) continue;
    const auto& a = full.last_associations();
    const auto& b = compressed.last_associations();
    for (std::size_t k = 0; k < a.size(); ++k)
      if (a[k].decision != b[k].decision || a[k].landmark_id != b[k].landmark_id) ++diff.decisions_differing;
    if (++scans % check_every == 0) compare();
  }
  compare();
  diff.flushes = compressed.statistics().at("local_area_flushes");
  if (method != AssociationMethod::kKnown) diff.landmarks_fused = compressed.statistics().at("landmarks_fused");
  diff.landmarks = compressed.num_landmarks();
  return diff;
}

std::string scientific(double v) {
  std::ostringstream out;
  out << std::scientific << std::setprecision(2) << v;
  return out.str();
}

void expect_equivalent(const CompressedDifferences& diff) {
  EXPECT_LT(diff.state, kTolerance);
  EXPECT_LT(diff.covariance, kTolerance);
  EXPECT_EQ(diff.decisions_differing, 0u);
  ::testing::Test::RecordProperty("max_state_difference", scientific(diff.state));
  ::testing::Test::RecordProperty("max_covariance_difference", scientific(diff.covariance));
  ::testing::Test::RecordProperty("local_area_flushes", scientific(diff.flushes));
  ::testing::Test::RecordProperty("landmarks", static_cast<int>(diff.landmarks));
}

}  // namespace

TEST(EkfCompressed, EqualsFullEkfOnDefaultWorld) {
  const CompressedDifferences diff =
      compare_variants(simulate(default_world(), SimulatorConfig{}), AssociationMethod::kKnown, 200);
  expect_equivalent(diff);
  EXPECT_GT(diff.checks, 3u);
  EXPECT_GT(diff.flushes, 2.0);  // the default world's laps cross several areas
}

TEST(EkfCompressed, EqualsFullEkfWithSequentialUpdates) {
  const CompressedDifferences diff = compare_variants(simulate(default_world(), SimulatorConfig{}), AssociationMethod::kKnown,
                                            200, EkfUpdate::kSequential);
  expect_equivalent(diff);
  EXPECT_GT(diff.flushes, 2.0);
}

TEST(EkfCompressed, EqualsFullEkfOnLargeWorldAcrossManyAreas) {
  // A 15 m sensor keeps the full EKF's share of the run short (it sees fewer landmarks at a time)
  // while the map grows to most of the 1000 and the vehicle crosses dozens of areas.
  WorldGenOptions options;
  options.landmarks = 1000;
  options.width = 500.0;
  options.height = 250.0;
  SimulatorConfig sim;
  sim.loops = 1;
  sim.max_range = 15.0;
  const CompressedDifferences diff = compare_variants(simulate(generate_world(options), sim), AssociationMethod::kKnown, 200);
  expect_equivalent(diff);
  EXPECT_GT(diff.landmarks, 500u);
  EXPECT_GT(diff.flushes, 30.0);
}

// Without identities the map is managed, and the return of the second lap is recognised by
// relocalisation, which fuses the landmarks mapped again there into the first lap's: the fusion
// (whose landmarks may lie outside the local area) is exact too.
TEST(EkfCompressed, SameDecisionsAndEstimateWithNearestNeighbourAssociation) {
  SimulatorConfig sim;
  sim.provide_ids = false;
  const CompressedDifferences diff =
      compare_variants(simulate(default_world(), sim), AssociationMethod::kNearestNeighbour, 200);
  expect_equivalent(diff);
  EXPECT_GT(diff.flushes, 2.0);
  EXPECT_GE(diff.landmarks_fused, 2.0);
}

TEST(EkfCompressed, AccessorsAnswerForTheWholeMapInsideAnArea) {
  // Landmark 0 is left behind the area when the vehicle drives off and a new area opens: reading it
  // then must include the updates accumulated since, without a flush.
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  VariantPair pair(data, AssociationMethod::kKnown);
  const EkfEstimator& full = pair.full().estimator();
  const EkfEstimator& compressed = pair.compressed().estimator();
  std::size_t scans = 0;
  for (const Event& e : data.events)
    if (pair.step(e) && ++scans == 400) break;
  const double flushes = pair.compressed().statistics().at("local_area_flushes");
  ASSERT_GT(flushes, 0.0);
  const std::size_t n = full.num_landmarks();
  ASSERT_EQ(compressed.num_landmarks(), n);
  EXPECT_LT((full.pose_covariance() - compressed.pose_covariance()).cwiseAbs().maxCoeff(), kTolerance);
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_LT((full.landmark_position(i) - compressed.landmark_position(i)).cwiseAbs().maxCoeff(), kTolerance);
    EXPECT_LT((full.landmark_covariance(i) - compressed.landmark_covariance(i)).cwiseAbs().maxCoeff(), kTolerance);
    EXPECT_LT((full.landmark_pose_covariance(i) - compressed.landmark_pose_covariance(i)).cwiseAbs().maxCoeff(),
              kTolerance);
    for (std::size_t j = 0; j < n; j += 7) {
      const Matrix2 difference = full.landmark_cross_covariance(i, j) - compressed.landmark_cross_covariance(i, j);
      EXPECT_LT(difference.cwiseAbs().maxCoeff(), kTolerance);
    }
  }
  // Reading changed nothing: the area is still open.
  EXPECT_EQ(pair.compressed().statistics().at("local_area_flushes"), flushes);
}

TEST(EkfCompressed, WholeMapReadEqualsLandmarkByLandmarkInsideAnArea) {
  // landmark_marginals answers for the landmarks outside the area with products over all of them;
  // it must give what the per-landmark accessors give, and the full EKF's marginals.
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  VariantPair pair(data, AssociationMethod::kKnown);
  std::size_t scans = 0;
  for (const Event& e : data.events)
    if (pair.step(e) && ++scans == 400) break;
  const EkfEstimator& full = pair.full().estimator();
  const EkfEstimator& compressed = pair.compressed().estimator();
  std::vector<Vector2> means, full_means;
  std::vector<Matrix2> covariances, full_covariances;
  compressed.landmark_marginals(means, covariances);
  full.landmark_marginals(full_means, full_covariances);
  const std::size_t n = compressed.num_landmarks();
  ASSERT_EQ(means.size(), n);
  ASSERT_EQ(covariances.size(), n);
  ASSERT_EQ(full_means.size(), n);
  ASSERT_GT(pair.compressed().statistics().at("local_area_flushes"), 0.0);  // landmark 0 is left behind
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_LT((means[i] - compressed.landmark_position(i)).cwiseAbs().maxCoeff(), 1e-12) << i;
    EXPECT_LT((covariances[i] - compressed.landmark_covariance(i)).cwiseAbs().maxCoeff(), 1e-12) << i;
    EXPECT_LT((covariances[i] - covariances[i].transpose()).cwiseAbs().maxCoeff(), 1e-12) << i;
    EXPECT_LT((means[i] - full_means[i]).cwiseAbs().maxCoeff(), kTolerance) << i;
    EXPECT_LT((covariances[i] - full_covariances[i]).cwiseAbs().maxCoeff(), kTolerance) << i;
  }
}

TEST(EkfCompressed, RunRecordsTheFullEkfsLandmarkDeviations) {
  // The runner reads every landmark's standard deviation each second (landmark_std.txt, the
  // tutorial's Figure 3): through the compressed EKF, with areas open at most reads, the series must
  // be the full EKF's.
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  VariantPair pair(data, AssociationMethod::kKnown);
  const RunResult full = run_filter(*pair.full_filter, data);
  const RunResult compressed = run_filter(*pair.compressed_filter, data);
  ASSERT_EQ(compressed.landmark_std.size(), full.landmark_std.size());
  ASSERT_GT(full.landmark_std.size(), 1000u);
  double largest = 0.0;
  for (std::size_t k = 0; k < full.landmark_std.size(); ++k) {
    const LandmarkStdSample& a = full.landmark_std[k];
    const LandmarkStdSample& b = compressed.landmark_std[k];
    ASSERT_EQ(a.t, b.t) << k;
    ASSERT_EQ(a.id, b.id) << k;
    largest = std::max({largest, std::abs(a.std_x - b.std_x), std::abs(a.std_y - b.std_y)});
  }
  EXPECT_LT(largest, kTolerance);
  ASSERT_EQ(compressed.map.size(), full.map.size());
  for (std::size_t i = 0; i < full.map.size(); ++i)
    EXPECT_LT((compressed.map[i].covariance - full.map[i].covariance).cwiseAbs().maxCoeff(), kTolerance);
  EXPECT_GT(pair.compressed().statistics().at("local_area_flushes"), 2.0);
}

TEST(EkfCompressed, RemovalFlushesAndStaysExact) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const double range = data.sensor.max_range;
  KnownIdentities full(std::make_unique<JointGaussian>(data.motion, data.observation, data.initial_pose));
  KnownIdentities compressed(
      std::make_unique<CompressedJointGaussian>(data.motion, data.observation, range, 0.0, data.initial_pose));
  std::size_t scans = 0;
  for (const Event& e : data.events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      full.estimator->predict(c->u, c->dt);
      compressed.estimator->predict(c->u, c->dt);
      continue;
    }
    full.update(std::get<ScanEvent>(e));
    compressed.update(std::get<ScanEvent>(e));
    // Remove an active landmark (the one added last) and one far behind, then go on.
    if (++scans == 300 || scans == 600) {
      for (KnownIdentities* f : {&full, &compressed}) {
        f->remove(f->ids.size() - 1);
        f->remove(0);
      }
    }
    if (scans == 800) break;
  }
  EXPECT_LT((full.estimator->state() - compressed.estimator->state()).cwiseAbs().maxCoeff(), kTolerance);
  EXPECT_LT((full.estimator->covariance() - compressed.estimator->covariance()).cwiseAbs().maxCoeff(), kTolerance);
}

TEST(EkfCompressed, AStraightDriveCrossesTheWholeSquareBeforeLeavingIt) {
  // The square opens ahead of the vehicle: driving straight (here not along an axis) it leaves
  // after crossing the whole side, not half of it as from a square centred on it.
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  const double side = 40.0, speed = 3.0, dt = 0.1, distance = 400.0;
  CompressedJointGaussian estimator(data.motion, data.observation, data.sensor.max_range, side, Pose2(5.0, -3.0, 0.4),
                                    Matrix3::Identity() * 1e-4);
  Control straight(2);
  straight << speed, 0.0;
  for (double driven = 0.0; driven < distance; driven += speed * dt) {
    estimator.predict(straight, dt);
    estimator.begin_scan();
  }
  std::map<std::string, double> statistics;
  estimator.add_statistics(statistics);
  EXPECT_GE(statistics.at("local_area_flushes"), distance / side - 1.0);
  EXPECT_LE(statistics.at("local_area_flushes"), distance / side);
}

// Widening the pose (the known-identity recovery, ekf_slam.hpp) is process noise with an identity
// transition: q joins the vehicle's block, and nothing else moves, in either storage.
TEST(EkfCompressed, InflatingThePoseAddsToTheVehicleBlockAlone) {
  const Dataset data = simulate(default_world(), SimulatorConfig{});
  JointGaussian full(data.motion, data.observation, data.initial_pose, Matrix3::Identity() * 1e-4);
  CompressedJointGaussian compressed(data.motion, data.observation, data.sensor.max_range, 0.0, data.initial_pose,
                                     Matrix3::Identity() * 1e-4);
  Control straight(2);
  straight << 3.0, 0.05;
  for (EkfEstimator* estimator : {static_cast<EkfEstimator*>(&full), static_cast<EkfEstimator*>(&compressed)}) {
    for (int step = 0; step < 20; ++step) {
      estimator->predict(straight, 0.1);
      estimator->begin_scan();
      if (step % 5 == 0) estimator->add_landmark(Vector2(8.0, 0.3 * step - 1.0));
    }
    const Eigen::MatrixXd before = estimator->covariance();
    Matrix3 q;
    q << 4.0, 0.5, 0.1, 0.5, 2.0, -0.2, 0.1, -0.2, 0.3;
    estimator->inflate_pose(q);
    Eigen::MatrixXd expected = before;
    expected.topLeftCorner<3, 3>() += q;
    EXPECT_LT((estimator->covariance() - expected).cwiseAbs().maxCoeff(), 1e-12);
  }
  EXPECT_LT((full.covariance() - compressed.covariance()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(EkfCompressed, FactoryRejectsAnUnknownVariant) {
  try {
    parse_ekf_variant("sparse");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("full, compressed"), std::string::npos) << e.what();
  }
}
