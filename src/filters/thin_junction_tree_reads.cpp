// The thin junction tree filter's reads: cliques brought up to date from the root, covariances
// between cliques along the tree's paths, and what a run reports.
#include "slamkit/filters/thin_junction_tree_filter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "thin_junction_tree_support.hpp"

namespace slamkit {

using namespace tjtf_detail;

ThinJunctionTreeFilter::Separator ThinJunctionTreeFilter::separator(const Clique& a, const Clique& b) const {
  Separator s;
  for (const std::size_t l : a.landmarks)
    if (const Eigen::Index rb = b.row_of(l); rb >= 0) {
      s.landmarks.push_back(l);
      s.rows_a.push_back(a.row_of(l));
      s.rows_b.push_back(rb);
    }
  return s;
}

std::vector<std::size_t> ThinJunctionTreeFilter::neighbours(std::size_t c) const {
  std::vector<std::size_t> out = cliques_[c].children;
  if (cliques_[c].parent != kNone) out.push_back(cliques_[c].parent);
  return out;
}

// ---- keeping the cliques current ----------------------------------------------------------------

void ThinJunctionTreeFilter::make_current(std::size_t c) const {
  // The root is always current, and so is every ancestor of a current clique.
  std::vector<std::size_t> behind;
  for (; cliques_[c].epoch != epoch_; c = cliques_[c].parent) behind.push_back(c);
  for (auto it = behind.rbegin(); it != behind.rend(); ++it) propagate(cliques_[*it].parent, *it);
}

void ThinJunctionTreeFilter::propagate(std::size_t parent, std::size_t c) const {
  Clique& child = cliques_[c];
  const Clique& above = cliques_[parent];
  child.epoch = epoch_;
  const Separator s = separator(child, above);
  if (s.landmarks.empty()) return;  // independent of everything the evidence touched
  const Rows in_child = both_rows(s.rows_a), in_parent = both_rows(s.rows_b);
  const Eigen::MatrixXd old_separator = child.covariance(in_child, in_child);
  // c = mu_c + G (S - mu_S) + e with G = Sigma_cS Sigma_SS^-1 is what the separator leaves unchanged.
  const Eigen::MatrixXd gain =
      positive_definite(old_separator, "a separator's covariance")
          .solve(child.covariance(in_child, Eigen::all))
          .transpose();
  const Eigen::VectorXd mean_change = above.mean(in_parent) - child.mean(in_child);
  const Eigen::MatrixXd covariance_change = above.covariance(in_parent, in_parent) - old_separator;
  child.mean += gain * mean_change;
  child.covariance += gain * covariance_change * gain.transpose();
  symmetrise(child.covariance);
}

void ThinJunctionTreeFilter::calibrate_all() const {
  std::vector<std::size_t> queue{kRoot};
  for (std::size_t k = 0; k < queue.size(); ++k)
    for (const std::size_t child : cliques_[queue[k]].children) {
      if (cliques_[child].epoch != epoch_) propagate(queue[k], child);
      queue.push_back(child);
    }
}

const ThinJunctionTreeFilter::Clique& ThinJunctionTreeFilter::current_home(std::size_t index) const {
  make_current(home_[index]);
  return cliques_[home_[index]];
}

const Eigen::MatrixXd& ThinJunctionTreeFilter::vehicle_cross(std::size_t c) const {
  make_current(c);
  std::vector<std::size_t> behind;
  std::size_t a = c;
  for (; a != kRoot && cliques_[a].cross_version != version_; a = cliques_[a].parent) behind.push_back(a);
  if (a == kRoot && cliques_[kRoot].cross_version != version_) {
    cliques_[kRoot].vehicle_cross = cliques_[kRoot].covariance.topRows<3>();
    cliques_[kRoot].cross_version = version_;
  }
  // Down the path: the vehicle is independent of a clique's other variables given its separator.
  for (auto it = behind.rbegin(); it != behind.rend(); ++it) {
    Clique& q = cliques_[*it];
    const Clique& p = cliques_[q.parent];
    const Separator s = separator(q, p);
    if (s.landmarks.empty()) {
      q.vehicle_cross = Eigen::MatrixXd::Zero(3, q.rows());
    } else {
      const Rows in_q = both_rows(s.rows_a), in_p = both_rows(s.rows_b);
      q.vehicle_cross = p.vehicle_cross(Eigen::all, in_p) *
                        positive_definite(q.covariance(in_q, in_q), "a separator's covariance")
                            .solve(q.covariance(in_q, Eigen::all));
    }
    q.cross_version = version_;
  }
  return cliques_[c].vehicle_cross;
}

Eigen::MatrixXd ThinJunctionTreeFilter::landmark_cross(std::size_t index, std::size_t to) const {
  const std::size_t from = home_[index];
  make_current(from);
  make_current(to);
  // The path from -> lowest common ancestor -> to.
  std::vector<std::size_t> up_from, up_to;
  for (std::size_t a = from; a != kNone; a = cliques_[a].parent) up_from.push_back(a);
  for (std::size_t a = to; a != kNone; a = cliques_[a].parent) up_to.push_back(a);
  while (up_from.size() > 1 && up_to.size() > 1 && up_from[up_from.size() - 2] == up_to[up_to.size() - 2]) {
    up_from.pop_back();
    up_to.pop_back();
  }
  std::vector<std::size_t> path = up_from;  // ends at the common ancestor
  path.insert(path.end(), up_to.rbegin() + 1, up_to.rend());
  const Clique& start = cliques_[from];
  const Eigen::Index r = start.row_of(index);
  Eigen::MatrixXd cross = start.covariance.middleRows<2>(r);
  for (std::size_t k = 1; k < path.size(); ++k) {
    const Clique& p = cliques_[path[k - 1]];
    const Clique& q = cliques_[path[k]];
    const Separator s = separator(q, p);
    if (s.landmarks.empty()) return Eigen::MatrixXd::Zero(2, cliques_[to].rows());
    const Rows in_q = both_rows(s.rows_a), in_p = both_rows(s.rows_b);
    cross = (cross(Eigen::all, in_p) * positive_definite(q.covariance(in_q, in_q), "a separator's covariance")
                                           .solve(q.covariance(in_q, Eigen::all)))
                .eval();
  }
  return cross;
}

// ---- reads ---------------------------------------------------------------------------------------

Matrix3 ThinJunctionTreeFilter::pose_covariance() const { return cliques_[kRoot].covariance.topLeftCorner<3, 3>(); }

Vector2 ThinJunctionTreeFilter::landmark_position(std::size_t index) const {
  const Clique& c = current_home(index);
  return c.mean.segment<2>(c.row_of(index));
}

Matrix2 ThinJunctionTreeFilter::landmark_covariance(std::size_t index) const {
  const Clique& c = current_home(index);
  const Eigen::Index r = c.row_of(index);
  return c.covariance.block<2, 2>(r, r);
}

const Eigen::Index* ThinJunctionTreeFilter::prepared_row(std::size_t index) const {
  if (prepared_.version != version_) return nullptr;
  const auto it = prepared_.rows.find(index);
  return it == prepared_.rows.end() ? nullptr : &it->second;
}

Matrix23 ThinJunctionTreeFilter::landmark_pose_covariance(std::size_t index) const {
  if (const Eigen::Index* r = prepared_row(index)) return prepared_.covariance.block<2, 3>(*r, 0);
  const std::size_t c = home_[index];
  return vehicle_cross(c).middleCols<2>(cliques_[c].row_of(index)).transpose();
}

Matrix2 ThinJunctionTreeFilter::landmark_cross_covariance(std::size_t i, std::size_t j) const {
  if (i == j) return landmark_covariance(i);
  if (const Eigen::Index *ri = prepared_row(i), *rj = prepared_row(j); ri && rj)
    return prepared_.covariance.block<2, 2>(*ri, *rj);
  for (const std::size_t c : {home_[i], home_[j], kRoot}) {
    const Clique& clique = cliques_[c];
    const Eigen::Index ri = clique.row_of(i), rj = clique.row_of(j);
    if (ri >= 0 && rj >= 0) {
      make_current(c);
      return clique.covariance.block<2, 2>(ri, rj);
    }
  }
  // Map matching asks about many pairs in one search: one walk answers for all of j's clique.
  if (cross_cache_version_ != version_) {
    cross_cache_.clear();
    cross_cache_version_ = version_;
  }
  const std::size_t to = home_[j];
  const std::uint64_t key = (static_cast<std::uint64_t>(i) << 32) | static_cast<std::uint64_t>(to);
  auto it = cross_cache_.find(key);
  if (it == cross_cache_.end()) it = cross_cache_.emplace(key, landmark_cross(i, to)).first;
  return it->second.middleCols<2>(cliques_[to].row_of(j));
}

void ThinJunctionTreeFilter::landmark_marginals(std::vector<Vector2>& means, std::vector<Matrix2>& covariances) const {
  calibrate_all();
  EkfEstimator::landmark_marginals(means, covariances);
}

Eigen::VectorXd ThinJunctionTreeFilter::state() const {
  calibrate_all();
  Eigen::VectorXd x(static_cast<Eigen::Index>(dim_));
  x.head<3>() = cliques_[kRoot].mean.head<3>();
  for (std::size_t i = 0; i < num_landmarks(); ++i)
    x.segment<2>(static_cast<Eigen::Index>(landmark_offset(i))) = landmark_position(i);
  return x;
}

ThinJunctionTreeFilter::Joint ThinJunctionTreeFilter::joint(const std::vector<char>& included) const {
  // Breadth first from the root: each clique's landmarks not in its parent are independent of
  // everything placed before, given the separator, so they are regressed on it.
  std::vector<std::size_t> queue{kRoot};
  for (std::size_t k = 0; k < queue.size(); ++k)
    for (const std::size_t child : cliques_[queue[k]].children)
      if (included[child]) {
        make_current(child);
        queue.push_back(child);
      }
  Joint out;
  std::size_t rows = 0;
  for (const std::size_t c : queue) rows += cliques_[c].landmarks.size();  // an upper bound
  out.covariance.resize(static_cast<Eigen::Index>(3 + 2 * rows), static_cast<Eigen::Index>(3 + 2 * rows));
  const Clique& root = cliques_[kRoot];
  out.covariance.topLeftCorner(root.rows(), root.rows()) = root.covariance;
  Eigen::Index placed = root.rows();
  for (std::size_t k = 0; k < root.landmarks.size(); ++k)
    out.rows[root.landmarks[k]] = 3 + 2 * static_cast<Eigen::Index>(k);
  for (std::size_t k = 1; k < queue.size(); ++k) {
    const Clique& c = cliques_[queue[k]];
    const Separator s = separator(c, cliques_[c.parent]);
    Rows fresh_in_c;
    for (const std::size_t l : c.landmarks)
      if (std::find(s.landmarks.begin(), s.landmarks.end(), l) == s.landmarks.end()) {
        fresh_in_c.push_back(c.row_of(l));
        out.rows[l] = placed + 2 * static_cast<Eigen::Index>(fresh_in_c.size() - 1);
      }
    if (fresh_in_c.empty()) continue;
    const Rows in_c = both_rows(fresh_in_c);
    const auto fresh = static_cast<Eigen::Index>(in_c.size());
    auto before = out.covariance.block(placed, 0, fresh, placed);
    if (s.landmarks.empty()) {
      before.setZero();
    } else {
      Rows separator_rows;
      for (const std::size_t l : s.landmarks) separator_rows.push_back(out.rows.at(l));
      const Rows sep_c = both_rows(s.rows_a);
      const Eigen::MatrixXd gain = positive_definite(c.covariance(sep_c, sep_c), "a separator's covariance")
                                       .solve(c.covariance(sep_c, in_c))
                                       .transpose();
      before = gain * out.covariance(both_rows(separator_rows), Eigen::seqN(0, placed));
    }
    out.covariance.block(0, placed, placed, fresh) = before.transpose();
    out.covariance.block(placed, placed, fresh, fresh) = c.covariance(in_c, in_c);
    placed += fresh;
  }
  out.covariance.conservativeResize(placed, placed);
  out.version = version_;
  return out;
}

Eigen::MatrixXd ThinJunctionTreeFilter::covariance() const {
  const Joint all = joint(std::vector<char>(cliques_.size(), 1));
  Rows state_order{0, 1, 2};
  for (std::size_t i = 0; i < num_landmarks(); ++i) state_order.push_back(all.rows.at(i));
  const Rows rows = both_rows(Rows(state_order.begin() + 3, state_order.end()));
  Rows order{0, 1, 2};
  order.insert(order.end(), rows.begin(), rows.end());
  return all.covariance(order, order);
}

void ThinJunctionTreeFilter::prepare_covariances(std::span<const std::size_t> landmarks) const {
  // The cliques on the paths from the landmarks up to the root: their joint holds every covariance
  // association will read, each pair's at once rather than along its own path.
  std::vector<char> included(cliques_.size(), 0);
  included[kRoot] = 1;
  for (const std::size_t l : landmarks)
    for (std::size_t a = home_[l]; !included[a]; a = cliques_[a].parent) included[a] = 1;
  prepared_ = joint(included);
}

// ---- what a run reports ------------------------------------------------------------------------------

std::vector<InformationMatrixPanel> ThinJunctionTreeFilter::information_panels() const {
  calibrate_all();
  std::vector<Eigen::Triplet<double>> triplets;
  const auto add = [&](const Clique& c, const Rows& local, bool vehicle, const std::vector<std::size_t>& landmarks,
                       double sign) {
    Rows rows;
    if (vehicle) rows = {0, 1, 2};
    for (const std::size_t l : landmarks) {
      rows.push_back(static_cast<Eigen::Index>(landmark_offset(l)));
      rows.push_back(static_cast<Eigen::Index>(landmark_offset(l)) + 1);
    }
    Eigen::MatrixXd block = c.covariance(local, local);
    block.diagonal().array() += kInformationJitter;
    const Eigen::MatrixXd inverse = block.ldlt().solve(Eigen::MatrixXd::Identity(block.rows(), block.cols()));
    for (Eigen::Index j = 0; j < inverse.cols(); ++j)
      for (Eigen::Index i = 0; i < inverse.rows(); ++i) triplets.emplace_back(rows[i], rows[j], sign * inverse(i, j));
  };
  std::size_t count = 0;
  for (std::size_t c = 0; c < cliques_.size(); ++c) {
    const Clique& clique = cliques_[c];
    if (!clique.alive) continue;
    ++count;
    Rows all(static_cast<std::size_t>(clique.rows()));
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<Eigen::Index>(i);
    add(clique, all, clique.vehicle, clique.landmarks, 1.0);
    if (c == kRoot) continue;
    const Separator s = separator(clique, cliques_[clique.parent]);
    if (!s.landmarks.empty()) add(clique, both_rows(s.rows_a), false, s.landmarks, -1.0);
  }
  const auto n = static_cast<Eigen::Index>(dim_);
  Eigen::SparseMatrix<double> information(n, n);
  information.setFromTriplets(triplets.begin(), triplets.end());
  information.prune(0.0);
  return {{fmt::format("TJTF: the information its junction tree stands for, {} cliques (tjtf_max_clique_landmarks "
                       "{})",
                       count, options_.max_clique_landmarks),
           information}};
}

void ThinJunctionTreeFilter::add_statistics(std::map<std::string, double>& statistics) const {
  std::size_t cliques = 0, widest = 0;
  for (const Clique& c : cliques_)
    if (c.alive) {
      ++cliques;
      widest = std::max(widest, c.landmarks.size());
    }
  statistics["tjtf_cliques"] = static_cast<double>(cliques);
  statistics["tjtf_widest_clique"] = static_cast<double>(widest);
  statistics["tjtf_contractions"] = static_cast<double>(contractions_);
  statistics["tjtf_pushes"] = static_cast<double>(pushes_);
  statistics["tjtf_path_extensions"] = static_cast<double>(path_extensions_);
  statistics["tjtf_projection_nats"] = projection_nats_;
}

double ThinJunctionTreeFilter::memory_estimate(std::size_t landmarks, const TjtfOptions& options) {
  const double k = static_cast<double>(options.max_clique_landmarks);
  const double rows = 3.0 + 2.0 * k;
  const double cliques = static_cast<double>(landmarks) / std::max(1.0, std::floor(k / 2.0)) + 1.0;
  return 2.0 * cliques * (rows * rows + rows) * sizeof(double) + 32.0 * static_cast<double>(landmarks);
}

std::vector<std::vector<std::size_t>> ThinJunctionTreeFilter::cliques() const {
  std::vector<std::vector<std::size_t>> out;
  for (const Clique& c : cliques_)
    if (c.alive) out.push_back(c.landmarks);
  return out;
}

}  // namespace slamkit
