#include "slamkit/assoc/association.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "slamkit/assoc/sensor_view.hpp"
#include "slamkit/core/chi_square.hpp"

namespace slamkit {

Gates Gates::from(const AssociationConfig& config) {
  validate(config);
  return Gates{eval::chi_square_quantile(config.accept_probability, 2.0),
               eval::chi_square_quantile(config.new_landmark_probability, 2.0)};
}

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// One observation-landmark pair with everything the individual and joint tests need.
struct PairTerms {
  std::size_t observation = 0;
  std::size_t landmark = 0;
  Vector2 innovation = Vector2::Zero();
  Matrix2 s = Matrix2::Zero();  // individual innovation covariance
  double d2 = kInfinity;
  double likelihood = 0.0;  // of the innovation, N(innovation; 0, s)
  Matrix23 hx = Matrix23::Zero();
  Matrix2 hm = Matrix2::Zero();
  Matrix23 a = Matrix23::Zero();  // hx Pvv + hm P(m, v): the vehicle part of this pair's row of H P
};

}  // namespace

struct AssociationWorkspace::Impl {
  // The compatibility table.
  std::vector<PairTerms> pairs;
  std::vector<double> min_d2;  // per observation, the smallest distance to any candidate
  std::vector<double> explained;  // per observation, the sum of every candidate's likelihood
  // Pairs inside the acceptance gate: by distance (NN), or by observation then distance (JCBB).
  std::vector<const PairTerms*> accepted;
  std::vector<std::size_t> used_landmarks;
  // JCBB: observation i's options are accepted[option_begin[i], option_begin[i + 1]).
  std::vector<std::size_t> option_begin, order;
  std::vector<const PairTerms*> current, best;  // the search's hypothesis stacks
  Eigen::MatrixXd l;                             // Cholesky factor of the current hypothesis
  Eigen::VectorXd y;
  Eigen::Matrix<double, Eigen::Dynamic, 2> w;  // the new pair's rows of the factor, transposed
  // Gates, recomputed only when the configured probabilities change.
  double accept_probability = std::numeric_limits<double>::quiet_NaN();
  double new_landmark_probability = std::numeric_limits<double>::quiet_NaN();
  Gates gates;
  std::vector<double> joint_gate;  // for k pairings, k >= 1 (index 0 unused)

  const Gates& gates_for(const AssociationConfig& config) {
    if (config.accept_probability != accept_probability ||
        config.new_landmark_probability != new_landmark_probability) {
      gates = Gates::from(config);
      accept_probability = config.accept_probability;
      new_landmark_probability = config.new_landmark_probability;
      joint_gate.assign(1, 0.0);
    }
    return gates;
  }

  /// The joint gates up to k_max pairings (after gates_for).
  void extend_joint_gates(std::size_t k_max) {
    for (std::size_t k = joint_gate.size(); k <= k_max; ++k)
      joint_gate.push_back(eval::chi_square_quantile(accept_probability, 2.0 * double(k)));
  }
};

AssociationWorkspace::AssociationWorkspace() : impl_(std::make_unique<Impl>()) {}
AssociationWorkspace::AssociationWorkspace(const AssociationWorkspace&) : AssociationWorkspace() {}
AssociationWorkspace& AssociationWorkspace::operator=(const AssociationWorkspace&) { return *this; }
AssociationWorkspace::AssociationWorkspace(AssociationWorkspace&&) noexcept = default;
AssociationWorkspace& AssociationWorkspace::operator=(AssociationWorkspace&&) noexcept = default;
AssociationWorkspace::~AssociationWorkspace() = default;

namespace {

using Workspace = AssociationWorkspace::Impl;

/// Individual compatibility of every observation with every candidate, into ws.pairs and ws.min_d2;
/// with weigh_pairings also each pair's likelihood and ws.explained (one exp per pair, which the
/// default min_pairing_probability of 0 does not need).
void build_compatibility(std::span<const Observation> observations, std::span<const std::size_t> candidates,
                         const GaussianMapView& belief, const ObservationModel& model, bool weigh_pairings,
                         Workspace& ws) {
  ws.pairs.clear();
  ws.min_d2.assign(observations.size(), kInfinity);
  ws.explained.assign(observations.size(), 0.0);
  const Pose2 x = belief.pose();
  const Matrix3 pvv = belief.pose_covariance();
  const Matrix2 r = model.noise();
  for (const std::size_t j : candidates) {
    const Vector2 m = belief.landmark_position(j);
    const Vector2 zhat = model.predict(x, m);
    PairTerms t;
    t.landmark = j;
    model.jacobians(x, m, t.hx, t.hm);
    const Matrix23 pmv = belief.landmark_pose_covariance(j);
    t.a = t.hx * pvv + t.hm * pmv;
    // S = H P H^T + R over the vehicle and landmark blocks.
    const Matrix2 hm_pmm = t.hm * belief.landmark_cross_covariance(j, j);
    const Matrix2 s = t.a * t.hx.transpose() + (t.hx * pmv.transpose() + hm_pmm) * t.hm.transpose() + r;
    const Matrix2 s_sym = 0.5 * (s + s.transpose());
    const Eigen::LLT<Matrix2> llt(s_sym);
    if (llt.info() != Eigen::Success) continue;
    const double normaliser = 2.0 * std::numbers::pi * llt.matrixL().determinant();  // 2 pi sqrt(det S)
    for (std::size_t i = 0; i < observations.size(); ++i) {
      t.observation = i;
      t.innovation = model.residual(observations[i].z, zhat);
      t.s = s_sym;
      t.d2 = t.innovation.dot(llt.solve(t.innovation));
      ws.min_d2[i] = std::min(ws.min_d2[i], t.d2);
      if (weigh_pairings) {
        t.likelihood = std::exp(-0.5 * t.d2) / normaliser;
        ws.explained[i] += t.likelihood;
      }
      ws.pairs.push_back(t);
    }
  }
}

/// The pairs inside the acceptance gate that are probable enough (see
/// AssociationConfig::min_pairing_probability), into ws.accepted, in table order.
void collect_accepted(Workspace& ws, const Gates& gates, double min_probability, double clutter) {
  ws.accepted.clear();
  for (const PairTerms& p : ws.pairs)
    if (p.d2 < gates.accept && p.likelihood >= min_probability * (clutter + ws.explained[p.observation]))
      ws.accepted.push_back(&p);
}

/// Observations left unpaired are new if far from every candidate, else ambiguous.
void decide_unpaired(std::vector<Pairing>& out, const Workspace& ws, const Gates& gates) {
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i].decision != AssociationDecision::kUpdate)
      out[i].decision =
          ws.min_d2[i] > gates.new_landmark ? AssociationDecision::kNew : AssociationDecision::kDiscard;
}

void nearest_neighbour(Workspace& ws, const Gates& gates, double min_probability, double clutter,
                       std::vector<Pairing>& out) {
  collect_accepted(ws, gates, min_probability, clutter);
  std::sort(ws.accepted.begin(), ws.accepted.end(),
            [](const PairTerms* a, const PairTerms* b) { return a->d2 < b->d2; });
  ws.used_landmarks.clear();
  for (const PairTerms* p : ws.accepted) {
    if (out[p->observation].decision == AssociationDecision::kUpdate) continue;
    if (std::find(ws.used_landmarks.begin(), ws.used_landmarks.end(), p->landmark) != ws.used_landmarks.end()) continue;
    out[p->observation] = {AssociationDecision::kUpdate, p->landmark};
    ws.used_landmarks.push_back(p->landmark);
  }
  decide_unpaired(out, ws, gates);
}

/// Depth-first joint compatibility search with an incrementally extended Cholesky factor. Its stacks
/// and factor live in the workspace, sized for the largest scan so far.
class Jcbb {
 public:
  Jcbb(std::size_t n_obs, Workspace& ws, const GaussianMapView& belief, std::size_t max_nodes,
       double min_probability, double clutter)
      : ws_(ws), belief_(belief), max_nodes_(max_nodes) {
    collect_accepted(ws, ws.gates, min_probability, clutter);
    // Grouped by observation, each group by distance: the nearest options are tried first.
    std::sort(ws.accepted.begin(), ws.accepted.end(), [](const PairTerms* a, const PairTerms* b) {
      return a->observation != b->observation ? a->observation < b->observation : a->d2 < b->d2;
    });
    ws.option_begin.assign(n_obs + 1, 0);
    for (const PairTerms* p : ws.accepted) ++ws.option_begin[p->observation + 1];
    for (std::size_t i = 0; i < n_obs; ++i) ws.option_begin[i + 1] += ws.option_begin[i];
    // Observations with fewer options first: their branches are decided early and prune the most.
    // Ties keep the observations' order (what a stable sort by option count would give).
    ws.order.clear();
    for (std::size_t i = 0; i < n_obs; ++i)
      if (options(i).size() > 0) ws.order.push_back(i);
    std::sort(ws.order.begin(), ws.order.end(), [&](std::size_t a, std::size_t b) {
      return options(a).size() != options(b).size() ? options(a).size() < options(b).size() : a < b;
    });
    const std::size_t k_max = ws.order.size();
    ws.extend_joint_gates(k_max);
    const auto rows = 2 * static_cast<Eigen::Index>(k_max);
    if (ws.l.rows() < rows) {
      ws.l.resize(rows, rows);
      ws.y.resize(rows);
      ws.w.resize(rows, 2);
    }
    ws.current.clear();
    ws.best.clear();
  }

  void solve(AssociationStats* stats, std::vector<Pairing>& out) {
    search(0, 0.0);
    if (stats) {
      stats->jcbb_nodes += nodes_;
      stats->jcbb_budget_exhausted = stats->jcbb_budget_exhausted || nodes_ >= max_nodes_;
    }
    for (const PairTerms* p : ws_.best) out[p->observation] = {AssociationDecision::kUpdate, p->landmark};
  }

 private:
  std::span<const PairTerms* const> options(std::size_t observation) const {
    return std::span(ws_.accepted).subspan(ws_.option_begin[observation],
                                           ws_.option_begin[observation + 1] - ws_.option_begin[observation]);
  }

  void search(std::size_t depth, double d2) {
    if (nodes_ >= max_nodes_) return;
    ++nodes_;
    std::vector<const PairTerms*>& current = ws_.current;
    const std::size_t k = current.size();
    if (depth == ws_.order.size()) {
      if (k > ws_.best.size() || (k == ws_.best.size() && k > 0 && d2 < best_d2_)) {
        ws_.best = current;
        best_d2_ = d2;
      }
      return;
    }
    const std::size_t remaining = ws_.order.size() - depth - 1;
    for (const PairTerms* p : options(ws_.order[depth])) {
      if (!can_improve(k + 1 + remaining, d2)) break;
      if (uses(p->landmark)) continue;
      double extended = 0.0;
      if (!extend(*p, extended) || d2 + extended > ws_.joint_gate[k + 1]) continue;
      current.push_back(p);
      search(depth + 1, d2 + extended);
      current.pop_back();
    }
    if (can_improve(k + remaining, d2)) search(depth + 1, d2);  // this observation left unpaired
  }

  /// Whether a branch that can reach `potential` pairings at distance >= d2 may beat the best.
  bool can_improve(std::size_t potential, double d2) const {
    return potential > ws_.best.size() || (potential == ws_.best.size() && potential > 0 && d2 < best_d2_);
  }

  bool uses(std::size_t landmark) const {
    return std::any_of(ws_.current.begin(), ws_.current.end(),
                       [&](const PairTerms* q) { return q->landmark == landmark; });
  }

  /// Appends pair p to the factor of the current hypothesis' joint innovation covariance and
  /// returns the increase of the joint Mahalanobis distance.
  bool extend(const PairTerms& p, double& increase) {
    const auto k = static_cast<Eigen::Index>(ws_.current.size());
    Matrix2 c = p.s;
    Vector2 v = p.innovation;
    if (k > 0) {
      auto wt = ws_.w.topRows(2 * k);
      for (Eigen::Index a = 0; a < k; ++a) wt.middleRows<2>(2 * a) = cross(*ws_.current[a], p);
      ws_.l.topLeftCorner(2 * k, 2 * k).triangularView<Eigen::Lower>().solveInPlace(wt);  // W^T = L^-1 B
      c -= wt.transpose() * wt;
      v -= wt.transpose() * ws_.y.head(2 * k);
      ws_.l.block(2 * k, 0, 2, 2 * k) = wt.transpose();
    }
    const Eigen::LLT<Matrix2> llt(0.5 * (c + c.transpose()));
    if (llt.info() != Eigen::Success) return false;
    ws_.l.block<2, 2>(2 * k, 2 * k) = llt.matrixL();
    const Vector2 y_new = llt.matrixL().solve(v);
    ws_.y.segment<2>(2 * k) = y_new;
    increase = y_new.squaredNorm();
    return true;
  }

  /// cov(innovation of a, innovation of b) = H_a P H_b^T (different observations: no R term).
  Matrix2 cross(const PairTerms& a, const PairTerms& b) const {
    const Matrix23 pbv = belief_.landmark_pose_covariance(b.landmark);
    const Matrix2 pab = belief_.landmark_cross_covariance(a.landmark, b.landmark);
    return a.a * b.hx.transpose() + (a.hx * pbv.transpose() + a.hm * pab) * b.hm.transpose();
  }

  Workspace& ws_;
  const GaussianMapView& belief_;
  std::size_t max_nodes_;
  std::size_t nodes_ = 0;
  double best_d2_ = kInfinity;
};

}  // namespace

double clutter_density(const AssociationConfig& config, const SensorLimits& sensor) {
  validate(sensor);
  return config.clutter_per_scan / (sensor.max_range * sensor.fov);
}

void associate(std::span<const Observation> observations, std::span<const std::size_t> candidates,
               const GaussianMapView& belief, const ObservationModel& model, const AssociationConfig& config,
               AssociationWorkspace& workspace, std::vector<Pairing>& out, AssociationStats* stats, double clutter) {
  if (config.method != AssociationMethod::kNearestNeighbour && config.method != AssociationMethod::kJcbb)
    throw std::invalid_argument("associate() needs the nn or jcbb method; known identities need no search");
  Workspace& ws = workspace.impl();
  const Gates& gates = ws.gates_for(config);
  build_compatibility(observations, candidates, belief, model, config.min_pairing_probability > 0.0, ws);
  if (stats) stats->candidate_pairs += ws.pairs.size();
  out.assign(observations.size(), Pairing{});
  if (config.method == AssociationMethod::kNearestNeighbour) {
    nearest_neighbour(ws, gates, config.min_pairing_probability, clutter, out);
    return;
  }
  Jcbb(observations.size(), ws, belief, config.jcbb_max_nodes, config.min_pairing_probability, clutter)
      .solve(stats, out);
  decide_unpaired(out, ws, gates);
}

std::vector<Pairing> associate(std::span<const Observation> observations, std::span<const std::size_t> candidates,
                               const GaussianMapView& belief, const ObservationModel& model,
                               const AssociationConfig& config, AssociationStats* stats, double clutter) {
  AssociationWorkspace workspace;
  std::vector<Pairing> out;
  associate(observations, candidates, belief, model, config, workspace, out, stats, clutter);
  return out;
}

}  // namespace slamkit
