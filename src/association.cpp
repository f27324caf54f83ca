#include "slamkit/assoc/association.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <limits>
#include <stdexcept>

#include "slamkit/eval/chi_square.hpp"

namespace slamkit {

Gates Gates::from(const AssociationConfig& config) {
  if (!(config.accept_probability > 0.0 && config.accept_probability < config.new_landmark_probability &&
        config.new_landmark_probability < 1.0))
    throw std::invalid_argument("association gates need 0 < accept_probability < new_landmark_probability < 1");
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
  Matrix23 hx = Matrix23::Zero();
  Matrix2 hm = Matrix2::Zero();
  Matrix23 a = Matrix23::Zero();  // hx Pvv + hm P(m, v): the vehicle part of this pair's row of H P
};

/// Individual compatibility of every observation with every candidate.
class CompatibilityTable {
 public:
  CompatibilityTable(std::span<const Observation> observations, std::span<const std::size_t> candidates,
                     const GaussianMapView& belief, const ObservationModel& model)
      : min_d2_(observations.size(), kInfinity) {
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
      for (std::size_t i = 0; i < observations.size(); ++i) {
        t.observation = i;
        t.innovation = model.residual(observations[i].z, zhat);
        t.s = s_sym;
        t.d2 = t.innovation.dot(llt.solve(t.innovation));
        min_d2_[i] = std::min(min_d2_[i], t.d2);
        pairs_.push_back(t);
      }
    }
  }

  const std::vector<PairTerms>& pairs() const { return pairs_; }
  /// The smallest distance of observation i to any candidate.
  double min_d2(std::size_t i) const { return min_d2_[i]; }

 private:
  std::vector<PairTerms> pairs_;
  std::vector<double> min_d2_;
};

/// Observations left unpaired are new if far from every candidate, else ambiguous.
void decide_unpaired(std::vector<Pairing>& out, const CompatibilityTable& table, const Gates& gates) {
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i].decision != AssociationDecision::kUpdate)
      out[i].decision =
          table.min_d2(i) > gates.new_landmark ? AssociationDecision::kNew : AssociationDecision::kDiscard;
}

std::vector<Pairing> nearest_neighbour(std::size_t n_obs, const CompatibilityTable& table, const Gates& gates) {
  std::vector<const PairTerms*> order;
  for (const PairTerms& p : table.pairs())
    if (p.d2 < gates.accept) order.push_back(&p);
  std::sort(order.begin(), order.end(), [](const PairTerms* a, const PairTerms* b) { return a->d2 < b->d2; });
  std::vector<Pairing> out(n_obs);
  std::vector<std::size_t> used_landmarks;
  for (const PairTerms* p : order) {
    if (out[p->observation].decision == AssociationDecision::kUpdate) continue;
    if (std::find(used_landmarks.begin(), used_landmarks.end(), p->landmark) != used_landmarks.end()) continue;
    out[p->observation] = {AssociationDecision::kUpdate, p->landmark};
    used_landmarks.push_back(p->landmark);
  }
  decide_unpaired(out, table, gates);
  return out;
}

/// Depth-first joint compatibility search with an incrementally extended Cholesky factor.
class Jcbb {
 public:
  Jcbb(std::size_t n_obs, const CompatibilityTable& table, const GaussianMapView& belief, const Gates& gates,
       double confidence, std::size_t max_nodes)
      : belief_(belief), max_nodes_(max_nodes), options_(n_obs) {
    for (const PairTerms& p : table.pairs())
      if (p.d2 < gates.accept) options_[p.observation].push_back(&p);
    for (auto& o : options_)
      std::sort(o.begin(), o.end(), [](const PairTerms* a, const PairTerms* b) { return a->d2 < b->d2; });
    // Observations with fewer options first: their branches are decided early and prune the most.
    for (std::size_t i = 0; i < n_obs; ++i)
      if (!options_[i].empty()) order_.push_back(i);
    std::stable_sort(order_.begin(), order_.end(),
                     [&](std::size_t a, std::size_t b) { return options_[a].size() < options_[b].size(); });
    const std::size_t k_max = order_.size();
    gate_.resize(k_max + 1, 0.0);
    for (std::size_t k = 1; k <= k_max; ++k) gate_[k] = eval::chi_square_quantile(confidence, 2.0 * double(k));
    l_ = Eigen::MatrixXd::Zero(2 * static_cast<Eigen::Index>(k_max), 2 * static_cast<Eigen::Index>(k_max));
    y_ = Eigen::VectorXd::Zero(2 * static_cast<Eigen::Index>(k_max));
  }

  std::vector<Pairing> solve(std::size_t n_obs, AssociationStats* stats) {
    search(0, 0.0);
    if (stats) {
      stats->jcbb_nodes += nodes_;
      stats->jcbb_budget_exhausted = stats->jcbb_budget_exhausted || nodes_ >= max_nodes_;
    }
    std::vector<Pairing> out(n_obs);
    for (const PairTerms* p : best_) out[p->observation] = {AssociationDecision::kUpdate, p->landmark};
    return out;
  }

 private:
  void search(std::size_t depth, double d2) {
    if (nodes_ >= max_nodes_) return;
    ++nodes_;
    const std::size_t k = current_.size();
    if (depth == order_.size()) {
      if (k > best_.size() || (k == best_.size() && k > 0 && d2 < best_d2_)) {
        best_ = current_;
        best_d2_ = d2;
      }
      return;
    }
    const std::size_t remaining = order_.size() - depth - 1;
    for (const PairTerms* p : options_[order_[depth]]) {
      if (!can_improve(k + 1 + remaining, d2)) break;
      if (uses(p->landmark)) continue;
      double extended = 0.0;
      if (!extend(*p, extended) || d2 + extended > gate_[k + 1]) continue;
      current_.push_back(p);
      search(depth + 1, d2 + extended);
      current_.pop_back();
    }
    if (can_improve(k + remaining, d2)) search(depth + 1, d2);  // this observation left unpaired
  }

  /// Whether a branch that can reach `potential` pairings at distance >= d2 may beat the best.
  bool can_improve(std::size_t potential, double d2) const {
    return potential > best_.size() || (potential == best_.size() && potential > 0 && d2 < best_d2_);
  }

  bool uses(std::size_t landmark) const {
    return std::any_of(current_.begin(), current_.end(), [&](const PairTerms* q) { return q->landmark == landmark; });
  }

  /// Appends pair p to the factor of the current hypothesis' joint innovation covariance and
  /// returns the increase of the joint Mahalanobis distance.
  bool extend(const PairTerms& p, double& increase) {
    const auto k = static_cast<Eigen::Index>(current_.size());
    Eigen::Matrix<double, Eigen::Dynamic, 2, 0, Eigen::Dynamic, 2> b(2 * k, 2);
    for (Eigen::Index a = 0; a < k; ++a) b.middleRows<2>(2 * a) = cross(*current_[a], p);
    Matrix2 c = p.s;
    Vector2 v = p.innovation;
    if (k > 0) {
      const auto lk = l_.topLeftCorner(2 * k, 2 * k).triangularView<Eigen::Lower>();
      const Eigen::Matrix<double, Eigen::Dynamic, 2> wt = lk.solve(b);  // W^T = L^-1 B
      c -= wt.transpose() * wt;
      v -= wt.transpose() * y_.head(2 * k);
      l_.block(2 * k, 0, 2, 2 * k) = wt.transpose();
    }
    const Eigen::LLT<Matrix2> llt(0.5 * (c + c.transpose()));
    if (llt.info() != Eigen::Success) return false;
    l_.block<2, 2>(2 * k, 2 * k) = llt.matrixL();
    const Vector2 y_new = llt.matrixL().solve(v);
    y_.segment<2>(2 * k) = y_new;
    increase = y_new.squaredNorm();
    return true;
  }

  /// cov(innovation of a, innovation of b) = H_a P H_b^T (different observations: no R term).
  Matrix2 cross(const PairTerms& a, const PairTerms& b) const {
    const Matrix23 pbv = belief_.landmark_pose_covariance(b.landmark);
    const Matrix2 pab = belief_.landmark_cross_covariance(a.landmark, b.landmark);
    return a.a * b.hx.transpose() + (a.hx * pbv.transpose() + a.hm * pab) * b.hm.transpose();
  }

  const GaussianMapView& belief_;
  std::size_t max_nodes_;
  std::size_t nodes_ = 0;
  std::vector<std::vector<const PairTerms*>> options_;
  std::vector<std::size_t> order_;
  std::vector<double> gate_;  // joint gate for k pairings
  std::vector<const PairTerms*> current_, best_;
  double best_d2_ = kInfinity;
  Eigen::MatrixXd l_;
  Eigen::VectorXd y_;
};

}  // namespace

std::vector<Pairing> associate(std::span<const Observation> observations, std::span<const std::size_t> candidates,
                               const GaussianMapView& belief, const ObservationModel& model,
                               const AssociationConfig& config, AssociationStats* stats) {
  const Gates gates = Gates::from(config);
  const CompatibilityTable table(observations, candidates, belief, model);
  if (stats) stats->candidate_pairs += table.pairs().size();
  switch (config.method) {
    case AssociationMethod::kNearestNeighbour:
      return nearest_neighbour(observations.size(), table, gates);
    case AssociationMethod::kJcbb: {
      Jcbb jcbb(observations.size(), table, belief, gates, config.accept_probability, config.jcbb_max_nodes);
      std::vector<Pairing> out = jcbb.solve(observations.size(), stats);
      decide_unpaired(out, table, gates);
      return out;
    }
    case AssociationMethod::kKnown:
      break;
  }
  throw std::invalid_argument("associate() needs the nn or jcbb method; known identities need no search");
}

}  // namespace slamkit
