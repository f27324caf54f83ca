#include "slamkit/assoc/association.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "slamkit/assoc/sensor_view.hpp"
#include "slamkit/core/chi_square.hpp"

namespace slamkit {

Gates Gates::from(const AssociationConfig& config, int dof) {
  validate(config);
  return Gates{eval::chi_square_quantile(config.accept_probability, double(dof)),
               eval::chi_square_quantile(config.new_landmark_probability, double(dof))};
}

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// One observation-landmark pair with everything the individual and joint tests need, for a
/// measurement of dimension D.
template <int D>
struct PairTerms {
  using Vector = MeasurementVector<D>;
  using Square = MeasurementSquare<D>;
  using PoseRows = slamkit::PoseRows<D>;
  using LandmarkRows = slamkit::LandmarkRows<D>;
  std::size_t observation = 0;
  std::size_t landmark = 0;
  Vector innovation = Vector::Zero();
  Square s = Square::Zero();  // individual innovation covariance
  double d2 = kInfinity;
  double likelihood = 0.0;  // of the innovation, N(innovation; 0, s)
  PoseRows hx = PoseRows::Zero();
  LandmarkRows hm = LandmarkRows::Zero();
  PoseRows a = PoseRows::Zero();  // hx Pvv + hm P(m, v): the vehicle part of this pair's row of H P
};

/// The tables and search state of measurements of dimension D.
template <int D>
struct Tables {
  std::vector<PairTerms<D>> pairs;  // inside the acceptance gate
  // Of those, the probable enough: by distance (NN), or by observation then distance (JCBB).
  std::vector<const PairTerms<D>*> accepted;
  std::vector<const PairTerms<D>*> current, best;  // JCBB's hypothesis stacks
  Eigen::Matrix<double, Eigen::Dynamic, D> w;     // the new pair's rows of the factor, transposed
};

}  // namespace

struct AssociationWorkspace::Impl {
  PerMeasurementDim<Tables> per_dim;
  template <int D>
  Tables<D>& tables() {
    return per_dim.get<D>();
  }
  std::vector<double> min_d2;  // per observation, the smallest distance to any candidate
  std::vector<double> explained;  // per observation, the sum of every candidate's likelihood
  std::vector<std::size_t> used_landmarks;
  // JCBB: observation i's options are accepted[option_begin[i], option_begin[i + 1]).
  std::vector<std::size_t> option_begin, order;
  Eigen::MatrixXd l;  // Cholesky factor of the current hypothesis
  Eigen::VectorXd y;
  // Gates, recomputed only when the configured probabilities or the dimension change.
  double accept_probability = std::numeric_limits<double>::quiet_NaN();
  double new_landmark_probability = std::numeric_limits<double>::quiet_NaN();
  int dof = 0;
  Gates gates;
  std::vector<double> joint_gate;  // for k pairings, k >= 1 (index 0 unused)

  const Gates& gates_for(const AssociationConfig& config, int measurement_dim) {
    if (config.accept_probability != accept_probability ||
        config.new_landmark_probability != new_landmark_probability || measurement_dim != dof) {
      gates = Gates::from(config, measurement_dim);
      accept_probability = config.accept_probability;
      new_landmark_probability = config.new_landmark_probability;
      dof = measurement_dim;
      joint_gate.assign(1, 0.0);
    }
    return gates;
  }

  /// The joint gates up to k_max pairings (after gates_for).
  void extend_joint_gates(std::size_t k_max) {
    for (std::size_t k = joint_gate.size(); k <= k_max; ++k)
      joint_gate.push_back(eval::chi_square_quantile(accept_probability, double(dof) * double(k)));
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

/// Individual compatibility of every observation with every candidate: ws.min_d2, with
/// weigh_pairings also each pair's likelihood and ws.explained (one exp per pair, which the default
/// min_pairing_probability of 0 does not need), and into ws.pairs the pairs inside the acceptance
/// gate, the only ones a search may take. Returns the number of pairs evaluated.
template <int D>
std::size_t build_compatibility(std::span<const Observation> observations, std::span<const std::size_t> candidates,
                                const GaussianMapView& belief, const ObservationModel& model, bool weigh_pairings,
                                double accept_gate, Workspace& ws) {
  using Terms = PairTerms<D>;
  using Square = typename Terms::Square;
  std::vector<Terms>& pairs = ws.tables<D>().pairs;
  pairs.clear();
  ws.min_d2.assign(observations.size(), kInfinity);
  ws.explained.assign(observations.size(), 0.0);
  const Pose2 x = belief.pose();
  const Matrix3 pvv = belief.pose_covariance();
  const Square r = model.noise();
  PoseJacobian hx;
  LandmarkJacobian hm;
  std::size_t evaluated = 0;
  for (const std::size_t j : candidates) {
    const Vector2 m = belief.landmark_position(j);
    const Measurement zhat = model.predict(x, m);
    Terms t;
    t.landmark = j;
    model.jacobians(x, m, hx, hm);
    t.hx = hx;
    t.hm = hm;
    const Matrix23 pmv = belief.landmark_pose_covariance(j);
    t.a = t.hx * pvv + t.hm * pmv;
    // S = H P H^T + R over the vehicle and landmark blocks.
    const typename Terms::LandmarkRows hm_pmm = t.hm * belief.landmark_cross_covariance(j, j);
    const Square s = t.a * t.hx.transpose() + (t.hx * pmv.transpose() + hm_pmm) * t.hm.transpose() + r;
    const Square s_sym = 0.5 * (s + s.transpose());
    const Eigen::LLT<Square> llt(s_sym);
    if (llt.info() != Eigen::Success) continue;
    // (2 pi)^(D/2) sqrt(det S)
    const double normaliser = std::pow(2.0 * std::numbers::pi, 0.5 * D) * llt.matrixL().determinant();
    t.s = s_sym;
    // Inverted once per candidate (in closed form at these sizes), so that each observation's
    // distance is a product, not two triangular solves: most pairs lie far outside the gates.
    const Square s_inverse = s_sym.inverse();
    evaluated += observations.size();
    for (std::size_t i = 0; i < observations.size(); ++i) {
      t.observation = i;
      t.innovation = model.residual(observations[i].z, zhat);
      t.d2 = t.innovation.dot(s_inverse * t.innovation);
      ws.min_d2[i] = std::min(ws.min_d2[i], t.d2);
      if (weigh_pairings) {
        t.likelihood = std::exp(-0.5 * t.d2) / normaliser;
        ws.explained[i] += t.likelihood;
      }
      if (t.d2 < accept_gate) pairs.push_back(t);
    }
  }
  return evaluated;
}

/// The pairs (all inside the acceptance gate) that are probable enough (see
/// AssociationConfig::min_pairing_probability), into the tables' accepted, in table order.
template <int D>
void collect_accepted(Workspace& ws, double min_probability, double clutter) {
  Tables<D>& tables = ws.tables<D>();
  tables.accepted.clear();
  for (const PairTerms<D>& p : tables.pairs)
    if (p.likelihood >= min_probability * (clutter + ws.explained[p.observation]))
      tables.accepted.push_back(&p);
}

/// Observations left unpaired are new if far from every candidate, else ambiguous.
void decide_unpaired(std::vector<Pairing>& out, const Workspace& ws, const Gates& gates) {
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i].decision != AssociationDecision::kUpdate)
      out[i].decision =
          ws.min_d2[i] > gates.new_landmark ? AssociationDecision::kNew : AssociationDecision::kDiscard;
}

template <int D>
void nearest_neighbour(Workspace& ws, const Gates& gates, double min_probability, double clutter,
                       std::vector<Pairing>& out) {
  collect_accepted<D>(ws, min_probability, clutter);
  auto& accepted = ws.tables<D>().accepted;
  std::sort(accepted.begin(), accepted.end(),
            [](const PairTerms<D>* a, const PairTerms<D>* b) { return a->d2 < b->d2; });
  ws.used_landmarks.clear();
  for (const PairTerms<D>* p : accepted) {
    if (out[p->observation].decision == AssociationDecision::kUpdate) continue;
    if (std::find(ws.used_landmarks.begin(), ws.used_landmarks.end(), p->landmark) != ws.used_landmarks.end()) continue;
    out[p->observation] = {AssociationDecision::kUpdate, p->landmark};
    ws.used_landmarks.push_back(p->landmark);
  }
  decide_unpaired(out, ws, gates);
}

/// Depth-first joint compatibility search with an incrementally extended Cholesky factor. Its stacks
/// and factor live in the workspace, sized for the largest scan so far.
template <int D>
class Jcbb {
 public:
  using Terms = PairTerms<D>;
  using Square = typename Terms::Square;
  using Vector = typename Terms::Vector;

  Jcbb(std::size_t n_obs, Workspace& ws, const GaussianMapView& belief, std::size_t max_nodes,
       double min_probability, double clutter)
      : ws_(ws), tables_(ws.tables<D>()), belief_(belief), max_nodes_(max_nodes) {
    collect_accepted<D>(ws, min_probability, clutter);
    // Grouped by observation, each group by distance: the nearest options are tried first.
    std::sort(tables_.accepted.begin(), tables_.accepted.end(), [](const Terms* a, const Terms* b) {
      return a->observation != b->observation ? a->observation < b->observation : a->d2 < b->d2;
    });
    ws.option_begin.assign(n_obs + 1, 0);
    for (const Terms* p : tables_.accepted) ++ws.option_begin[p->observation + 1];
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
    const auto rows = D * static_cast<Eigen::Index>(k_max);
    if (ws.l.rows() < rows) {
      ws.l.resize(rows, rows);
      ws.y.resize(rows);
    }
    if (tables_.w.rows() < rows) tables_.w.resize(rows, D);
    tables_.current.clear();
    tables_.best.clear();
  }

  void solve(AssociationStats* stats, std::vector<Pairing>& out) {
    search(0, 0.0);
    if (stats) {
      stats->jcbb_nodes += nodes_;
      stats->jcbb_budget_exhausted = stats->jcbb_budget_exhausted || nodes_ >= max_nodes_;
    }
    for (const Terms* p : tables_.best) out[p->observation] = {AssociationDecision::kUpdate, p->landmark};
  }

 private:
  std::span<const Terms* const> options(std::size_t observation) const {
    return std::span(tables_.accepted).subspan(ws_.option_begin[observation],
                                           ws_.option_begin[observation + 1] - ws_.option_begin[observation]);
  }

  void search(std::size_t depth, double d2) {
    if (nodes_ >= max_nodes_) return;
    ++nodes_;
    std::vector<const Terms*>& current = tables_.current;
    const std::size_t k = current.size();
    if (depth == ws_.order.size()) {
      if (k > tables_.best.size() || (k == tables_.best.size() && k > 0 && d2 < best_d2_)) {
        tables_.best = current;
        best_d2_ = d2;
      }
      return;
    }
    const std::size_t remaining = ws_.order.size() - depth - 1;
    for (const Terms* p : options(ws_.order[depth])) {
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
    return potential > tables_.best.size() || (potential == tables_.best.size() && potential > 0 && d2 < best_d2_);
  }

  bool uses(std::size_t landmark) const {
    return std::any_of(tables_.current.begin(), tables_.current.end(),
                       [&](const Terms* q) { return q->landmark == landmark; });
  }

  /// Appends pair p to the factor of the current hypothesis' joint innovation covariance and
  /// returns the increase of the joint Mahalanobis distance.
  bool extend(const Terms& p, double& increase) {
    const auto k = static_cast<Eigen::Index>(tables_.current.size());
    Square c = p.s;
    Vector v = p.innovation;
    if (k > 0) {
      auto wt = tables_.w.topRows(D * k);
      for (Eigen::Index a = 0; a < k; ++a) wt.template middleRows<D>(D * a) = cross(*tables_.current[a], p);
      ws_.l.topLeftCorner(D * k, D * k).triangularView<Eigen::Lower>().solveInPlace(wt);  // W^T = L^-1 B
      c -= wt.transpose() * wt;
      v -= wt.transpose() * ws_.y.head(D * k);
      ws_.l.block(D * k, 0, D, D * k) = wt.transpose();
    }
    const Eigen::LLT<Square> llt(0.5 * (c + c.transpose()));
    if (llt.info() != Eigen::Success) return false;
    ws_.l.template block<D, D>(D * k, D * k) = llt.matrixL();
    const Vector y_new = llt.matrixL().solve(v);
    ws_.y.template segment<D>(D * k) = y_new;
    increase = y_new.squaredNorm();
    return true;
  }

  /// cov(innovation of a, innovation of b) = H_a P H_b^T (different observations: no R term).
  Square cross(const Terms& a, const Terms& b) const {
    const Matrix23 pbv = belief_.landmark_pose_covariance(b.landmark);
    const Matrix2 pab = belief_.landmark_cross_covariance(a.landmark, b.landmark);
    return a.a * b.hx.transpose() + (a.hx * pbv.transpose() + a.hm * pab) * b.hm.transpose();
  }

  Workspace& ws_;
  Tables<D>& tables_;
  const GaussianMapView& belief_;
  std::size_t max_nodes_;
  std::size_t nodes_ = 0;
  double best_d2_ = kInfinity;
};

}  // namespace

double clutter_density(const AssociationConfig& config, const SensorLimits& sensor, const ObservationModel& model) {
  validate(sensor);
  return config.clutter_per_scan / model.measurement_volume(sensor);
}

void require_searchable(const AssociationConfig& config, const ObservationModel& model) {
  if (config.method == AssociationMethod::kKnown || model.invertible()) return;
  throw std::invalid_argument(
      "association '" + to_string(config.method) + "' needs a " +
      "measurement that places a landmark, and a " + model.name() + " measurement does not: its landmarks start " +
      "from several observations of one landmark, which only known identities gather; use association 'known'");
}

void associate(std::span<const Observation> observations, std::span<const std::size_t> candidates,
               const GaussianMapView& belief, const ObservationModel& model, const AssociationConfig& config,
               AssociationWorkspace& workspace, std::vector<Pairing>& out, AssociationStats* stats, double clutter) {
  if (config.method != AssociationMethod::kNearestNeighbour && config.method != AssociationMethod::kJcbb)
    throw std::invalid_argument("associate() needs the nn or jcbb method; known identities need no search");
  Workspace& ws = workspace.impl();
  const Gates& gates = ws.gates_for(config, model.dim());
  with_measurement_dim(model.dim(), [&]<int D>(std::integral_constant<int, D>) {
    const std::size_t evaluated = build_compatibility<D>(observations, candidates, belief, model,
                                                         config.min_pairing_probability > 0.0, gates.accept, ws);
    if (stats) stats->candidate_pairs += evaluated;
    out.assign(observations.size(), Pairing{});
    if (config.method == AssociationMethod::kNearestNeighbour) {
      nearest_neighbour<D>(ws, gates, config.min_pairing_probability, clutter, out);
      return;
    }
    Jcbb<D>(observations.size(), ws, belief, config.jcbb_max_nodes, config.min_pairing_probability, clutter)
        .solve(stats, out);
    decide_unpaired(out, ws, gates);
  });
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
