// The invariant EKF is kept in the standard coordinates; these tests redo its steps in the
// right-invariant error's own coordinates, xi = (dtheta, dp - dtheta J p, dm - dtheta J m), with
// the observation Jacobian taken by central differences through the group's exponential, and
// compare.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "linear_models.hpp"
#include "slamkit/filters/joint_gaussian.hpp"

using namespace slamkit;

namespace {

// The position blocks of a state [x y theta | m1 | m2 | ...]: the vehicle's at 0, landmarks' after.
std::vector<Eigen::Index> position_offsets(Eigen::Index n) {
  std::vector<Eigen::Index> o{0};
  for (Eigen::Index i = 3; i < n; i += 2) o.push_back(i);
  return o;
}

// xi = T(x) delta.
Eigen::MatrixXd to_invariant(const Eigen::VectorXd& x) {
  Eigen::MatrixXd t = Eigen::MatrixXd::Identity(x.size(), x.size());
  for (const Eigen::Index o : position_offsets(x.size())) {
    t(o, 2) = x[o + 1];
    t(o + 1, 2) = -x[o];
  }
  return t;
}

// The rotation by phi and SE(2)'s V(phi), which takes xi_p to the translation of exp(xi).
struct TurnAndV {
  Matrix2 rot, v;
  explicit TurnAndV(double phi) {
    rot << std::cos(phi), -std::sin(phi), std::sin(phi), std::cos(phi);
    if (std::abs(phi) < 1e-12)
      v.setIdentity();
    else
      v << std::sin(phi) / phi, -(1 - std::cos(phi)) / phi, (1 - std::cos(phi)) / phi, std::sin(phi) / phi;
  }
};

// exp(xi) X: heading + phi, every position p -> R(phi) p + V(phi) xi_p.
Eigen::VectorXd retract(const Eigen::VectorXd& x, const Eigen::VectorXd& xi) {
  const double phi = xi[2];
  const auto [rot, v] = TurnAndV(phi);
  Eigen::VectorXd out = x;
  for (const Eigen::Index o : position_offsets(x.size()))
    out.segment<2>(o) = rot * x.segment<2>(o) + v * xi.segment<2>(o);
  out[2] = wrap_angle(x[2] + phi);
  return out;
}

// The inverse of retract: the xi with retract(x, xi) = y.
Eigen::VectorXd unretract(const Eigen::VectorXd& x, const Eigen::VectorXd& y) {
  const double phi = wrap_angle(y[2] - x[2]);
  const auto [rot, v] = TurnAndV(phi);
  Eigen::VectorXd xi(x.size());
  for (const Eigen::Index o : position_offsets(x.size()))
    xi.segment<2>(o) = v.inverse() * (y.segment<2>(o) - rot * x.segment<2>(o));
  xi[2] = phi;
  return xi;
}

struct Fixture {
  std::shared_ptr<AckermannModel> motion = std::make_shared<AckermannModel>();
  std::shared_ptr<RangeBearingModel> observation = std::make_shared<RangeBearingModel>(
      RangeBearingModel::Params{.sigma_range = 0.1, .sigma_bearing = deg2rad(1.0), .offset_x = 1.5, .offset_y = 0.2});
  JointGaussian filter{motion, observation, Pose2(3.0, -1.0, 2.9), Eigen::Vector3d(0.3, 0.2, 0.02).asDiagonal().toDenseMatrix(),
                       Linearisation::kInvariant};
  Control u = (Control(2) << 3.0, 0.2).finished();
  Fixture() {
    filter.add_landmark(Vector2(12.0, 0.4));
    filter.predict(u, 0.5);
    filter.add_landmark(Vector2(8.0, -0.7));
  }
};

}  // namespace

TEST(InvariantEkf, TimeUpdateIsTheIdentityInTheInvariantError) {
  Fixture f;
  const Eigen::VectorXd x = f.filter.state();
  const Eigen::MatrixXd p = f.filter.covariance();
  f.filter.predict(f.u, 0.5);
  const Eigen::VectorXd x1 = f.filter.state();
  // xi' = xi + T(x') w: the error's Jacobian is the identity, the noise enters at the new estimate.
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(x.size(), x.size());
  q.topLeftCorner<3, 3>() = f.motion->process_noise(x.head<3>(), f.u, 0.5);
  const Eigen::MatrixXd p_xi = to_invariant(x) * p * to_invariant(x).transpose() +
                               to_invariant(x1) * q * to_invariant(x1).transpose();
  const Eigen::MatrixXd t1_inv = to_invariant(x1).inverse();
  const Eigen::MatrixXd expected = t1_inv * p_xi * t1_inv.transpose();
  EXPECT_LT((f.filter.covariance() - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff());
}

TEST(InvariantEkf, ObservationUpdateIsTheKalmanUpdateOfTheInvariantError) {
  Fixture f;
  f.filter.predict(f.u, 0.5);
  const Eigen::VectorXd x = f.filter.state();
  const Eigen::MatrixXd p = f.filter.covariance();
  const Eigen::Index n = x.size();
  const LandmarkObservation scan[] = {{0, Vector2(9.5, -0.2)}, {1, Vector2(6.9, -1.2)}};
  ASSERT_TRUE(f.filter.update_landmarks(scan));

  // The reference, in xi: H by central differences of h(exp(xi) X) at xi = 0.
  auto measure = [&](const Eigen::VectorXd& state) {
    Eigen::VectorXd z(4);
    for (int i = 0; i < 2; ++i) z.segment<2>(2 * i) = f.observation->predict(state.head<3>(), state.segment<2>(3 + 2 * i));
    return z;
  };
  Eigen::MatrixXd h(4, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double e = 1e-6;
    const Eigen::VectorXd step = Eigen::VectorXd::Unit(n, j) * e;
    const Eigen::VectorXd d = measure(retract(x, step)) - measure(retract(x, -step));
    for (int r = 0; r < 4; ++r) h(r, j) = (r % 2 == 1 ? wrap_angle(d[r]) : d[r]) / (2 * e);
  }
  const Eigen::MatrixXd p_xi = to_invariant(x) * p * to_invariant(x).transpose();
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(4, 4);
  r.topLeftCorner<2, 2>() = r.bottomRightCorner<2, 2>() = f.observation->noise();
  const Eigen::MatrixXd s = h * p_xi * h.transpose() + r;
  const Eigen::MatrixXd k = p_xi * h.transpose() * s.inverse();
  Eigen::VectorXd nu = measure(x);
  for (int i = 0; i < 2; ++i)
    nu.segment<2>(2 * i) = f.observation->residual(scan[i].z, nu.segment<2>(2 * i));
  const Eigen::VectorXd x_plus = retract(x, k * nu);
  const Eigen::MatrixXd p_xi_plus = p_xi - k * s * k.transpose();
  const Eigen::MatrixXd t_inv = to_invariant(x_plus).inverse();
  const Eigen::MatrixXd p_plus = t_inv * p_xi_plus * t_inv.transpose();

  Eigen::VectorXd dx = f.filter.state() - x_plus;
  dx[2] = wrap_angle(dx[2]);
  EXPECT_LT(dx.cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GT((x_plus - x).norm(), 1e-2);  // the update did move the estimate
  EXPECT_LT((f.filter.covariance() - p_plus).cwiseAbs().maxCoeff(), 1e-6 * p_plus.cwiseAbs().maxCoeff());
}

namespace {

constexpr int kUpdateIterations = 10;

// A loop closure after a long drift (position std 3 m, heading 5 degrees, the landmark mapped well at
// the start): one linearisation at the drifted pose stops far from the maximum a posteriori
// estimate.
struct InvariantLoopClosure {
  std::shared_ptr<RangeBearingModel> observation = std::make_shared<RangeBearingModel>();
  Pose2 prior_pose{4.0, -3.0, 0.0};
  Vector2 landmark{20.0, 5.0};
  Vector2 z = observation->predict(Pose2(1.0, 2.0, 0.05), landmark);

  std::unique_ptr<JointGaussian> prior(int iterations) const {
    const Matrix3 drift = Eigen::Vector3d(9.0, 9.0, deg2rad(5.0) * deg2rad(5.0)).asDiagonal();
    auto g = std::make_unique<JointGaussian>(std::make_shared<test_models::LinearMotion>(drift), observation,
                                             prior_pose, Matrix3::Zero(), Linearisation::kInvariant, iterations);
    g->add_landmark(observation->predict(prior_pose, landmark));
    g->predict((Control(3) << 0.0, 0.0, 0.0).finished(), 1.0);
    return g;
  }
  // The negative log posterior about the estimate x, in the invariant error eps at x (X = exp(eps) x):
  // the prior's invariant error expressed at x, xi - xi_x with xi_x the one of x (the invariant
  // filter's reset), and the measurement at exp(eps) x.
  double cost(const Eigen::VectorXd& x0, const Eigen::MatrixXd& p_xi, const Eigen::VectorXd& x,
              const Eigen::VectorXd& eps) const {
    const Eigen::VectorXd prior = eps + unretract(x0, x);
    const Eigen::VectorXd moved = retract(x, eps);
    const Vector2 r = observation->residual(z, observation->predict(moved.head<3>(), moved.tail<2>()));
    return prior.dot(p_xi.ldlt().solve(prior)) + r.dot(observation->noise().ldlt().solve(r));
  }
};

}  // namespace

// Iterating on the group changes nothing where the update is linear in it: a known heading (no
// heading variance, so no heading correction) and an observation linear in the positions.
TEST(InvariantEkf, IteratedUpdateEqualsTheSingleUpdateWhereItIsLinear) {
  const Matrix3 noise = Eigen::Vector3d(0.04, 0.09, 0.0).asDiagonal();
  auto make = [&](int iterations) {
    return std::make_unique<JointGaussian>(std::make_shared<test_models::LinearMotion>(noise),
                                           std::make_shared<test_models::LinearOffset>(), Pose2(1.0, 2.0, 0.1),
                                           Eigen::Vector3d(1.0, 2.0, 0.0).asDiagonal().toDenseMatrix(),
                                           Linearisation::kInvariant, iterations);
  };
  auto single = make(1), iterated = make(kUpdateIterations);
  for (JointGaussian* g : {single.get(), iterated.get()}) {
    g->add_landmark(Vector2(3.0, -1.0));
    g->add_landmark(Vector2(-2.0, 4.0));
    g->predict((Control(3) << 1.0, 0.5, 0.2).finished(), 2.0);
    const LandmarkObservation scan[] = {{0, Vector2(1.5, -3.5)}, {1, Vector2(-4.0, 1.0)}};
    ASSERT_TRUE(g->update_landmarks(scan));
    ASSERT_TRUE(g->update_landmark(1, Vector2(-4.2, 1.3)));
  }
  EXPECT_LT((single->state() - iterated->state()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((single->covariance() - iterated->covariance()).cwiseAbs().maxCoeff(), 1e-12);
}

// The iterated update is Gauss-Newton on the group: it stops where the posterior about its estimate,
// in the invariant error there, has no gradient, and its covariance is the Kalman update's in that
// error with the observation Jacobian at the estimate.
TEST(InvariantEkf, IteratedUpdateStopsWhereThePosteriorOnTheGroupHasNoGradient) {
  const InvariantLoopClosure c;
  const auto g0 = c.prior(1);
  const Eigen::VectorXd x0 = g0->state();
  const Eigen::Index n = x0.size();
  const Eigen::MatrixXd p_xi = to_invariant(x0) * g0->covariance() * to_invariant(x0).transpose();
  auto gradient_norm = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd grad(n);
    for (Eigen::Index j = 0; j < n; ++j) {
      const Eigen::VectorXd step = Eigen::VectorXd::Unit(n, j) * 1e-6;
      grad[j] = (c.cost(x0, p_xi, x, step) - c.cost(x0, p_xi, x, -step)) / 2e-6;
    }
    return grad.norm();
  };
  auto single = c.prior(1), iterated = c.prior(kUpdateIterations);
  ASSERT_TRUE(single->update_landmark(0, c.z));
  ASSERT_TRUE(iterated->update_landmark(0, c.z));
  const Eigen::VectorXd x = iterated->state();
  EXPECT_LT(gradient_norm(x), 1e-6);
  EXPECT_GT(gradient_norm(single->state()), 1e3 * gradient_norm(x));

  Eigen::Matrix<double, 2, Eigen::Dynamic> h(2, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::VectorXd step = Eigen::VectorXd::Unit(n, j) * 1e-6;
    const Eigen::VectorXd plus = retract(x, step), minus = retract(x, -step);
    const Vector2 d = c.observation->predict(plus.head<3>(), plus.tail<2>()) -
                      c.observation->predict(minus.head<3>(), minus.tail<2>());
    h.col(j) = Vector2(d[0], wrap_angle(d[1])) / 2e-6;
  }
  EXPECT_LT(h.col(2).cwiseAbs().maxCoeff(), 1e-6);  // the turn of the whole scene stays unobserved
  const Eigen::MatrixXd s = h * p_xi * h.transpose() + c.observation->noise();
  const Eigen::MatrixXd p_xi_plus = p_xi - p_xi * h.transpose() * s.inverse() * h * p_xi;
  const Eigen::MatrixXd t_inv = to_invariant(x).inverse();
  const Eigen::MatrixXd expected = t_inv * p_xi_plus * t_inv.transpose();
  EXPECT_LT((iterated->covariance() - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
}

// What the association gates, landmark initialisation and the existence rule's removals read or
// write is kept in the standard coordinates too; each must be what the invariant error's own
// linearisation gives, or the variant would gate, start or drop landmarks with a covariance of
// another error. Redone here in xi, with Jacobians by central differences through the exponential.
namespace {

// Central differences of f (a vector of m rows) at 0 over n coordinates, steps 1e-6.
template <class F>
Eigen::MatrixXd central_differences(F f, Eigen::Index m, Eigen::Index n) {
  Eigen::MatrixXd j(m, n);
  for (Eigen::Index c = 0; c < n; ++c) {
    const Eigen::VectorXd step = Eigen::VectorXd::Unit(n, c) * 1e-6;
    j.col(c) = (f(step) - f(-step)) / 2e-6;
  }
  return j;
}

}  // namespace

TEST(InvariantEkf, GateInnovationCovarianceIsTheInvariantErrors) {
  Fixture f;
  f.filter.predict(f.u, 0.5);
  const Eigen::VectorXd x = f.filter.state();
  const Eigen::MatrixXd p_xi = to_invariant(x) * f.filter.covariance() * to_invariant(x).transpose();
  for (std::size_t i = 0; i < 2; ++i) {
    const auto at = static_cast<Eigen::Index>(3 + 2 * i);
    const Vector2 zhat = f.observation->predict(x.head<3>(), x.segment<2>(at));
    const Eigen::MatrixXd h = central_differences(
        [&](const Eigen::VectorXd& xi) -> Eigen::VectorXd {
          const Eigen::VectorXd moved = retract(x, xi);
          return f.observation->residual(f.observation->predict(moved.head<3>(), moved.segment<2>(at)), zhat);
        },
        2, x.size());
    Measurement gate_zhat;
    MeasurementCovariance gate_s;
    f.filter.innovation(i, gate_zhat, gate_s);
    const Matrix2 expected = h * p_xi * h.transpose() + f.observation->noise();
    EXPECT_LT((gate_s - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff()) << "landmark " << i;
  }
}

TEST(InvariantEkf, NewLandmarkAndRemovalAreTheInvariantErrorsAugmentationAndMarginal) {
  Fixture f;
  f.filter.predict(f.u, 0.5);
  const Eigen::VectorXd x = f.filter.state();
  const Eigen::Index n = x.size();
  const Eigen::MatrixXd p_xi = to_invariant(x) * f.filter.covariance() * to_invariant(x).transpose();

  // A new landmark seen as z: in xi, the landmark's error is the inverse model's through the vehicle's
  // error and the measurement noise v, xi_new = A xi + B v.
  const Vector2 z(10.0, 0.9);
  f.filter.add_landmark(z);
  const Eigen::VectorXd x_aug = f.filter.state();
  ASSERT_EQ(x_aug.size(), n + 2);
  const auto augmented_error = [&](const Eigen::VectorXd& xi, const Vector2& v) -> Eigen::VectorXd {
    const Eigen::VectorXd moved = retract(x, xi);
    Eigen::VectorXd y(n + 2);
    y << moved, f.observation->invert(moved.head<3>(), z + v)->position;
    return unretract(x_aug, y);
  };
  const Eigen::MatrixXd a = central_differences(
      [&](const Eigen::VectorXd& xi) { return augmented_error(xi, Vector2::Zero()); }, n + 2, n);
  const Eigen::MatrixXd b = central_differences(
      [&](const Eigen::VectorXd& v) { return augmented_error(Eigen::VectorXd::Zero(n), v); }, n + 2, 2);
  Eigen::MatrixXd p_xi_aug = a * p_xi * a.transpose() + b * f.observation->noise() * b.transpose();
  Eigen::MatrixXd t_inv = to_invariant(x_aug).inverse();
  Eigen::MatrixXd expected = t_inv * p_xi_aug * t_inv.transpose();
  EXPECT_LT((f.filter.covariance() - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());

  // Removing the middle landmark (rows 5-6) is the marginal of the invariant error without it.
  p_xi_aug = to_invariant(x_aug) * f.filter.covariance() * to_invariant(x_aug).transpose();
  f.filter.remove_landmark(1);
  const std::vector<Eigen::Index> kept{0, 1, 2, 3, 4, 7, 8};
  const Eigen::MatrixXd marginal = p_xi_aug(kept, kept);
  const Eigen::VectorXd x_kept = x_aug(kept);
  ASSERT_EQ(f.filter.state(), x_kept);
  t_inv = to_invariant(x_kept).inverse();
  expected = t_inv * marginal * t_inv.transpose();
  EXPECT_LT((f.filter.covariance() - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
}
