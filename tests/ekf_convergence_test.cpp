// EKF-SLAM on the simulator: the convergence properties of the tutorial's EKF-SLAM section and
// Figure 3, and statistical consistency over Monte Carlo runs.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "slamkit/core/chi_square.hpp"
#include "slamkit/eval/metrics.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/sim/simulator.hpp"
#include "sim_test_support.hpp"

using namespace slamkit;

namespace {

/// The dataset cut at time `t_end`: a short simulation of the default world.
using test_sim::truncated;

EkfSlam make_ekf(const Dataset& d) {
  EkfSlamOptions options;
  options.initial_pose = d.initial_pose;
  return EkfSlam(d.motion, d.observation, options);
}

double log_det(const Eigen::MatrixXd& m) {
  const Eigen::LLT<Eigen::MatrixXd> llt(m);
  EXPECT_EQ(llt.info(), Eigen::Success);
  return 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
}

}  // namespace

class EkfOnDefaultWorld : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { data_ = new Dataset(simulate(default_world(), SimulatorConfig{})); }
  static void TearDownTestSuite() { delete data_; }
  static Dataset* data_;
};
Dataset* EkfOnDefaultWorld::data_ = nullptr;

TEST_F(EkfOnDefaultWorld, MapCovarianceDeterminantAndLandmarkVariancesNeverIncrease) {
  EkfSlam ekf = make_ekf(*data_);
  std::vector<Eigen::Vector2d> last_variance;  // per landmark, diag of its 2x2 block
  double last_log_det = 0.0;
  std::size_t tracked = 0;  // the fixed set of landmarks whose joint determinant is followed
  std::size_t scans = 0;
  for (const Event& e : data_->events) {
    if (const auto* c = std::get_if<ControlEvent>(&e)) {
      ekf.predict(*c);
      continue;
    }
    ekf.update(std::get<ScanEvent>(e));
    ++scans;
    for (std::size_t i = 0; i < ekf.num_landmarks(); ++i) {
      const Eigen::Vector2d v = ekf.estimator().landmark_covariance(i).diagonal();
      if (i < last_variance.size()) {
        EXPECT_LE(v[0], last_variance[i][0] * (1 + 1e-9)) << "landmark " << i << " scan " << scans;
        EXPECT_LE(v[1], last_variance[i][1] * (1 + 1e-9)) << "landmark " << i << " scan " << scans;
        last_variance[i] = v;
      } else {
        last_variance.push_back(v);
      }
    }
    // Fix the set after a few scans; the marginal covariance of a fixed set can only shrink.
    if (scans == 5) tracked = ekf.num_landmarks();
    if (tracked > 0) {
      const Eigen::MatrixXd pmm = ekf.estimator().covariance().block(3, 3, 2 * tracked, 2 * tracked);
      const double ld = log_det(pmm);
      if (scans > 5) EXPECT_LE(ld, last_log_det + 1e-9) << "scan " << scans;
      last_log_det = ld;
    }
  }
  EXPECT_GT(tracked, 5u);
  EXPECT_EQ(ekf.num_landmarks(), data_->truth.landmarks.size());
}

TEST_F(EkfOnDefaultWorld, RelativeLandmarkUncertaintyIsBelowAbsolute) {
  EkfSlam ekf = make_ekf(*data_);
  for (const Event& e : data_->events) {
    if (const auto* c = std::get_if<ControlEvent>(&e))
      ekf.predict(*c);
    else
      ekf.update(std::get<ScanEvent>(e));
  }
  // For neighbouring landmarks (seen together), the relative position m_i - m_j is known better
  // than either absolute position: the common error from the vehicle cancels.
  const EkfEstimator& g = ekf.estimator();
  std::size_t pairs = 0, relative_better = 0;
  for (std::size_t i = 0; i < ekf.num_landmarks(); ++i) {
    for (std::size_t j = i + 1; j < ekf.num_landmarks(); ++j) {
      if ((g.landmark_position(i) - g.landmark_position(j)).norm() > 20.0) continue;
      const Matrix2 pij = g.landmark_cross_covariance(i, j);
      const Matrix2 rel = g.landmark_covariance(i) + g.landmark_covariance(j) - pij - pij.transpose();
      const double absolute = std::min(g.landmark_covariance(i).trace(), g.landmark_covariance(j).trace());
      ++pairs;
      relative_better += rel.trace() < absolute;
    }
  }
  EXPECT_GT(pairs, 100u);
  EXPECT_GE(static_cast<double>(relative_better) / static_cast<double>(pairs), 0.9)
      << relative_better << " of " << pairs;
}

TEST_F(EkfOnDefaultWorld, CovarianceStaysSymmetricPositiveSemiDefinite) {
  EkfSlam ekf = make_ekf(*data_);
  for (const Event& e : data_->events) {
    if (const auto* c = std::get_if<ControlEvent>(&e))
      ekf.predict(*c);
    else
      ekf.update(std::get<ScanEvent>(e));
  }
  const Eigen::MatrixXd p = ekf.estimator().covariance();
  EXPECT_EQ((p - p.transpose()).cwiseAbs().maxCoeff(), 0.0);
  const double min_eig = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(p).eigenvalues().minCoeff();
  EXPECT_GT(min_eig, -1e-10 * p.trace());
}

TEST(EkfConsistency, AveragePoseNeesInsideChiSquareBoundsOverMonteCarloRuns) {
  constexpr int kRuns = 50;
  constexpr double kDuration = 40.0;  // s: a short simulation, as in the consistency literature
  std::vector<double> nees_sum;
  std::vector<double> times;
  for (int run = 0; run < kRuns; ++run) {
    SimulatorConfig config;
    config.seed = 1000 + static_cast<std::uint64_t>(run);
    const Dataset d = truncated(simulate(default_world(), config), kDuration);
    EkfSlam ekf = make_ekf(d);
    std::size_t k = 0;
    std::size_t truth_index = 1;  // truth[0] is the start pose, known exactly
    for (const Event& e : d.events) {
      if (const auto* c = std::get_if<ControlEvent>(&e)) {
        ekf.predict(*c);
        continue;
      }
      const auto& scan = std::get<ScanEvent>(e);
      ekf.update(scan);
      while (d.truth.poses[truth_index].t < scan.t) ++truth_index;
      ASSERT_DOUBLE_EQ(d.truth.poses[truth_index].t, scan.t);
      const double nees = eval::pose_nees(ekf.pose(), ekf.pose_covariance(), d.truth.poses[truth_index].pose);
      if (run == 0) {
        nees_sum.push_back(0.0);
        times.push_back(scan.t);
      }
      ASSERT_LT(k, nees_sum.size());
      nees_sum[k++] += nees;
    }
  }
  const eval::Interval bounds = eval::averaged_nees_interval(0.95, 3, kRuns);
  std::size_t inside = 0;
  for (const double s : nees_sum) inside += (s / kRuns >= bounds.lo && s / kRuns <= bounds.hi);
  const double fraction = static_cast<double>(inside) / static_cast<double>(nees_sum.size());
  RecordProperty("nees_in_bounds_fraction", std::to_string(fraction));
  EXPECT_GE(fraction, 0.9) << inside << " of " << nees_sum.size() << " scans inside [" << bounds.lo << ", "
                           << bounds.hi << "]";
}
