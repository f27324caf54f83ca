#include "slamkit/filters/thin_junction_tree_filter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "slamkit/core/angles.hpp"
#include "thin_junction_tree_support.hpp"

namespace slamkit {

using namespace tjtf_detail;

void validate(const TjtfOptions& options) {
  if (options.max_clique_landmarks < TjtfOptions::kMinCliqueLandmarks ||
      options.max_clique_landmarks > TjtfOptions::kMaxCliqueLandmarks)
    throw std::invalid_argument(fmt::format("tjtf_max_clique_landmarks must be an integer from {} to {}, found {}",
                                            TjtfOptions::kMinCliqueLandmarks, TjtfOptions::kMaxCliqueLandmarks,
                                            options.max_clique_landmarks));
}

Eigen::Index ThinJunctionTreeFilter::Clique::row_of(std::size_t landmark) const {
  const auto it = std::find(landmarks.begin(), landmarks.end(), landmark);
  if (it == landmarks.end()) return -1;
  return (vehicle ? 3 : 0) + 2 * static_cast<Eigen::Index>(it - landmarks.begin());
}

ThinJunctionTreeFilter::ThinJunctionTreeFilter(std::shared_ptr<const MotionModel> motion,
                                               std::shared_ptr<const ObservationModel> observation,
                                               const Pose2& initial_pose, const Matrix3& initial_covariance,
                                               const TjtfOptions& options)
    : EkfEstimator(std::move(motion), std::move(observation), initial_pose), options_(options) {
  validate(options_);
  if (!initial_covariance.allFinite()) throw std::invalid_argument("the initial pose covariance must be finite");
  Clique root;
  root.vehicle = true;
  root.mean = x_.head<3>();
  root.covariance = 0.5 * (initial_covariance + initial_covariance.transpose());
  root.epoch = epoch_;
  cliques_.push_back(std::move(root));
}

// ---- the filter's steps ----------------------------------------------------------------------------

void ThinJunctionTreeFilter::root_changed() {
  cliques_[kRoot].epoch = ++epoch_;
  ++version_;
  x_.head<3>() = cliques_[kRoot].mean.head<3>();
}

void ThinJunctionTreeFilter::predict(const Control& u, double dt) {
  Clique& root = cliques_[kRoot];
  const Pose2 xv = root.mean.head<3>();
  const Matrix3 f = motion_->jacobian_state(xv, u, dt);
  root.mean.head<3>() = motion_->predict(xv, u, dt);
  root.mean[2] = wrap_angle(root.mean[2]);
  root.covariance.topRows<3>() = (f * root.covariance.topRows<3>()).eval();
  root.covariance.leftCols<3>() = (root.covariance.leftCols<3>() * f.transpose()).eval();
  root.covariance.topLeftCorner<3, 3>() += motion_->process_noise(xv, u, dt);
  symmetrise(root.covariance);
  // No separator holds the vehicle: the other cliques stay current.
  ++version_;
  x_.head<3>() = root.mean.head<3>();
}

void ThinJunctionTreeFilter::inflate_pose(const Matrix3& q) {
  cliques_[kRoot].covariance.topLeftCorner<3, 3>() += 0.5 * (q + q.transpose());
  ++version_;
}

bool ThinJunctionTreeFilter::update_root(const Eigen::MatrixXd& h, const Eigen::VectorXd& innovation,
                                         const Eigen::MatrixXd& noise) {
  Clique& root = cliques_[kRoot];
  const Eigen::MatrixXd ph = root.covariance * h.transpose();
  Eigen::MatrixXd s = h * ph + noise;
  symmetrise(s);
  const Eigen::LLT<Eigen::MatrixXd> llt(s);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::MatrixXd gain = llt.solve(ph.transpose()).transpose();
  root.mean += gain * innovation;
  root.mean[2] = wrap_angle(root.mean[2]);
  root.covariance -= gain * ph.transpose();
  symmetrise(root.covariance);
  root_changed();
  return true;
}

void ThinJunctionTreeFilter::begin_scan() { ++scans_; }

bool ThinJunctionTreeFilter::update_landmark(const LandmarkObservation& observation) {
  last_observed_[observation.index] = scans_;
  admit(observation.index, {observation.index});
  const Clique& root = cliques_[kRoot];
  const Pose2 xv = root.mean.head<3>();
  const Eigen::Index r = root.row_of(observation.index);
  const Vector2 m = root.mean.segment<2>(r);
  PoseJacobian hx;
  LandmarkJacobian hm;
  observation_->jacobians(xv, m, hx, hm);
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(hx.rows(), root.rows());
  h.leftCols<3>() = hx;
  h.middleCols<2>(r) = hm;
  const Eigen::VectorXd innovation = observation_->residual(observation.z, observation_->predict(xv, m));
  const bool updated =
      update_root(h, innovation, observation.noise_scale * Eigen::MatrixXd(observation_->noise()));
  thin(kRoot, {});
  return updated;
}

bool ThinJunctionTreeFilter::update_landmarks(std::span<const LandmarkObservation> batch) {
  bool all = true;
  for (const LandmarkObservation& o : batch) all = update_landmark(o) && all;
  return all;
}

std::size_t ThinJunctionTreeFilter::add_landmark(const InitialLandmark& landmark) {
  make_room_in_root({});
  Clique& root = cliques_[kRoot];
  const Eigen::MatrixXd cross = landmark.gx * root.covariance.topRows<3>();
  Matrix2 own = landmark.gx * root.covariance.topLeftCorner<3, 3>() * landmark.gx.transpose() + landmark.covariance;
  own = (0.5 * (own + own.transpose())).eval();
  const std::size_t index = num_landmarks();
  append(root, index, landmark.mean, cross, own);
  home_.push_back(kRoot);
  last_observed_.push_back(scans_);
  reserve(dim_ + 2);
  x_.segment<2>(static_cast<Eigen::Index>(dim_)) = landmark.mean;
  append_landmark_rows(2);
  ++version_;  // a new variable in the root alone leaves every other clique's distribution as it was
  thin(kRoot, {index});
  return index;
}

void ThinJunctionTreeFilter::remove_landmark(std::size_t index) {
  const std::vector<std::size_t> holders = current_holders(index, home_[index], kNone);
  for (const std::size_t c : holders) drop(c, index);
  for (Clique& c : cliques_)
    for (std::size_t& l : c.landmarks)
      if (l > index) --l;
  home_.erase(home_.begin() + static_cast<std::ptrdiff_t>(index));
  last_observed_.erase(last_observed_.begin() + static_cast<std::ptrdiff_t>(index));
  remove_stored_landmark(index);
  ++version_;
  for (const std::size_t c : holders) {
    if (!cliques_[c].alive) continue;
    const std::vector<std::size_t> children = cliques_[c].children;
    for (const std::size_t child : children) dissolve_if_redundant(child);
    if (c != kRoot) dissolve_if_redundant(c);
  }
}

bool ThinJunctionTreeFilter::fuse_landmarks(std::span<const LandmarkPair> pairs) {
  for (const LandmarkPair& pair : pairs) {
    admit(pair.original, {pair.original});
    admit(pair.duplicate, {pair.original, pair.duplicate});
    const Clique& root = cliques_[kRoot];
    const Eigen::Index ro = root.row_of(pair.original), rd = root.row_of(pair.duplicate);
    // The noiseless measurement m_original - m_duplicate = 0.
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(2, root.rows());
    h.middleCols<2>(ro).setIdentity();
    h.middleCols<2>(rd) = -Matrix2::Identity();
    const Eigen::VectorXd innovation = root.mean.segment<2>(rd) - root.mean.segment<2>(ro);
    if (!update_root(h, innovation, Eigen::MatrixXd::Zero(2, 2))) return false;
    set_duplicate_aside(pair);
    thin(kRoot, {});
  }
  return true;
}

void ThinJunctionTreeFilter::set_duplicate_aside(const LandmarkPair& pair) {
  // The duplicate now equals the original: where a clique holds both it is dropped, where it holds
  // the duplicate alone the original takes its rows (the same numbers), so the original keeps the
  // duplicate's links to its neighbours, and no separator holds two copies of one point (a singular
  // covariance). The duplicate stays, until it is removed, as a clique of its own, independent.
  const std::vector<std::size_t> holders = current_holders(pair.duplicate, kRoot, kNone);
  const Clique& root = cliques_[kRoot];
  const Eigen::Index rd = root.row_of(pair.duplicate);
  const Vector2 mean = root.mean.segment<2>(rd);
  const Matrix2 covariance = root.covariance.block<2, 2>(rd, rd);
  for (const std::size_t c : holders) {
    if (cliques_[c].holds(pair.original))
      drop(c, pair.duplicate);
    else
      *std::find(cliques_[c].landmarks.begin(), cliques_[c].landmarks.end(), pair.duplicate) = pair.original;
  }
  const std::size_t aside = new_clique();
  cliques_[aside].landmarks = {pair.duplicate};
  cliques_[aside].mean = mean;
  cliques_[aside].covariance = covariance;
  cliques_[aside].parent = kRoot;
  cliques_[kRoot].children.push_back(aside);
  home_[pair.duplicate] = aside;
  ++version_;
}

// ---- the tree's shape ------------------------------------------------------------------------------

std::size_t ThinJunctionTreeFilter::new_clique() {
  std::size_t c;
  if (!free_.empty()) {
    c = free_.back();
    free_.pop_back();
    cliques_[c] = Clique{};
  } else {
    c = cliques_.size();
    cliques_.emplace_back();
  }
  cliques_[c].epoch = epoch_;
  return c;
}

void ThinJunctionTreeFilter::admit(std::size_t index, const std::vector<std::size_t>& pinned) {
  if (cliques_[kRoot].holds(index)) return;
  make_room_in_root(pinned);
  make_current(home_[index]);
  std::vector<std::size_t> path;  // from the home up to the root
  for (std::size_t a = home_[index]; a != kNone; a = cliques_[a].parent) path.push_back(a);
  for (std::size_t k = 1; k < path.size(); ++k)
    if (!cliques_[path[k]].holds(index)) extend(path[k], path[k - 1], index);
  home_[index] = kRoot;
  ++path_extensions_;
  ++version_;
  // The cliques between grew by one: thin them from the root down. Where one cannot lose another
  // landmark, the landmark's link below it is cut instead (it stays in the cliques above).
  for (std::size_t k = path.size() - 1; k-- > 1;) {
    const std::size_t c = path[k];
    if (!cliques_[c].alive || !cliques_[c].holds(index)) continue;
    if (cliques_[c].landmarks.size() <= options_.max_clique_landmarks) continue;
    if (!thin(c, {index})) {
      cut(index, c, cliques_[c].parent);
      break;
    }
  }
}

void ThinJunctionTreeFilter::extend(std::size_t target, std::size_t source, std::size_t index) {
  const Clique& from = cliques_[source];
  Clique& to = cliques_[target];
  const Separator s = separator(from, to);
  const Eigen::Index n = to.rows(), r = from.row_of(index);
  // The landmark is independent of the target's other variables given the separator.
  Eigen::MatrixXd cross = Eigen::MatrixXd::Zero(2, n);
  if (!s.landmarks.empty()) {
    const Rows in_from = both_rows(s.rows_a), in_to = both_rows(s.rows_b);
    const Eigen::MatrixXd gain = positive_definite(from.covariance(in_from, in_from), "a separator's covariance")
                                     .solve(from.covariance(in_from, Eigen::seqN(r, 2)))
                                     .transpose();
    cross = gain * to.covariance(in_to, Eigen::all);
  }
  append(to, index, from.mean.segment<2>(r), cross, from.covariance.block<2, 2>(r, r));
}

void ThinJunctionTreeFilter::append(Clique& c, std::size_t index, const Vector2& mean, const Eigen::MatrixXd& cross,
                                    const Matrix2& own) {
  const Eigen::Index n = c.rows();
  c.mean.conservativeResize(n + 2);
  c.mean.tail<2>() = mean;
  c.covariance.conservativeResize(n + 2, n + 2);
  c.covariance.bottomRows<2>().leftCols(n) = cross;
  c.covariance.rightCols<2>().topRows(n) = cross.transpose();
  c.covariance.bottomRightCorner<2, 2>() = own;
  c.landmarks.push_back(index);
}

void ThinJunctionTreeFilter::push_root() {
  const std::size_t l = new_clique();
  Clique& root = cliques_[kRoot];
  Clique& copy = cliques_[l];
  const Eigen::Index n = root.rows() - 3;
  copy.landmarks = root.landmarks;
  copy.mean = root.mean.tail(n);
  copy.covariance = root.covariance.bottomRightCorner(n, n);
  copy.parent = kRoot;
  copy.children = root.children;
  for (const std::size_t child : copy.children) cliques_[child].parent = l;
  root.children = {l};
  ++pushes_;
  ++version_;
}

std::vector<std::size_t> ThinJunctionTreeFilter::current_holders(std::size_t index, std::size_t from,
                                                                 std::size_t excluded) const {
  std::vector<std::size_t> holders{from};
  for (std::size_t k = 0; k < holders.size(); ++k)
    for (const std::size_t n : neighbours(holders[k]))
      if (n != excluded && cliques_[n].holds(index) && std::find(holders.begin(), holders.end(), n) == holders.end())
        holders.push_back(n);
  for (const std::size_t c : holders) make_current(c);
  return holders;
}

void ThinJunctionTreeFilter::make_room_in_root(const std::vector<std::size_t>& pinned) {
  const std::size_t bridge = std::max<std::size_t>(1, options_.max_clique_landmarks / 2);
  if (cliques_[kRoot].landmarks.size() >= options_.max_clique_landmarks && contractible_in_root(pinned) < bridge)
    push_root();
}

std::size_t ThinJunctionTreeFilter::contractible_in_root(const std::vector<std::size_t>& pinned) const {
  const Clique& root = cliques_[kRoot];
  std::size_t count = 0;
  for (const std::size_t l : root.landmarks) {
    if (std::find(pinned.begin(), pinned.end(), l) != pinned.end()) continue;
    std::size_t holders = 0;
    for (const std::size_t child : root.children) holders += cliques_[child].holds(l) ? 1 : 0;
    count += holders == 1 ? 1 : 0;
  }
  return count;
}

double ThinJunctionTreeFilter::contraction_cost(const Clique& c, const Eigen::MatrixXd& information,
                                                std::size_t landmark, const Clique& keeper) const {
  // I(u; R | Z), u the landmark, Z what else the keeper shares with c, R the rest of c. Given Z,
  // (u, R) has the information Lambda(uR, uR) of c's information matrix, so that
  // I = (log det Lambda(uR) - log det of its Schur complement on u - that on R) / 2.
  Rows u = both_rows({c.row_of(landmark)}), rest;
  if (c.vehicle) rest = {0, 1, 2};
  for (const std::size_t l : c.landmarks)
    if (l != landmark && !keeper.holds(l)) {
      const Eigen::Index r = c.row_of(l);
      rest.insert(rest.end(), {r, r + 1});
    }
  if (rest.empty()) return 0.0;
  const Eigen::Index nu = 2, nr = static_cast<Eigen::Index>(rest.size());
  Rows both = u;
  both.insert(both.end(), rest.begin(), rest.end());
  const Eigen::MatrixXd joint = information(both, both);
  const Eigen::MatrixXd uu = joint.topLeftCorner(nu, nu), rr = joint.bottomRightCorner(nr, nr);
  const Eigen::MatrixXd ur = joint.topRightCorner(nu, nr);
  const Eigen::MatrixXd on_u = uu - ur * rr.ldlt().solve(ur.transpose());
  const Eigen::MatrixXd on_rest = rr - ur.transpose() * uu.ldlt().solve(ur);
  return std::max(0.0, 0.5 * (log_determinant(joint) - log_determinant(on_u) - log_determinant(on_rest)));
}

bool ThinJunctionTreeFilter::thin(std::size_t c, const std::vector<std::size_t>& pinned) {
  while (cliques_[c].landmarks.size() > options_.max_clique_landmarks) {
    make_current(c);
    const Clique& clique = cliques_[c];
    // The jitter stands in for the exactly known start pose, far below any noise.
    Eigen::MatrixXd jittered = clique.covariance;
    jittered.diagonal().array() += kInformationJitter;
    const Eigen::MatrixXd information =
        jittered.ldlt().solve(Eigen::MatrixXd::Identity(clique.rows(), clique.rows()));
    const std::vector<std::size_t> around = neighbours(c);
    std::size_t best = kNone, keeper = kNone;
    // A landmark this scan observed goes only if no other can: it would come back at the next one.
    std::pair<bool, double> cheapest{true, std::numeric_limits<double>::infinity()};
    for (const std::size_t l : clique.landmarks) {
      if (std::find(pinned.begin(), pinned.end(), l) != pinned.end()) continue;
      std::size_t holder = kNone, holders = 0;
      for (const std::size_t n : around)
        if (cliques_[n].holds(l)) {
          holder = n;
          ++holders;
        }
      if (holders != 1) continue;
      const std::pair<bool, double> cost{last_observed_[l] == scans_,
                                         contraction_cost(clique, information, l, cliques_[holder])};
      if (cost < cheapest) {
        cheapest = cost;
        best = l;
        keeper = holder;
      }
    }
    if (best == kNone) return false;
    make_current(keeper);  // its separator with c changes
    drop(c, best);
    if (home_[best] == c) home_[best] = keeper;
    projection_nats_ += cheapest.second;
    ++contractions_;
    ++version_;
  }
  if (c != kRoot) dissolve_if_redundant(c);
  return true;
}

void ThinJunctionTreeFilter::drop(std::size_t c, std::size_t index) {
  Clique& clique = cliques_[c];
  const Eigen::Index r = clique.row_of(index);
  Rows keep;
  for (Eigen::Index i = 0; i < clique.rows(); ++i)
    if (i != r && i != r + 1) keep.push_back(i);
  clique.mean = clique.mean(keep).eval();
  clique.covariance = clique.covariance(keep, keep).eval();
  std::erase(clique.landmarks, index);
  clique.cross_version = 0;
}

void ThinJunctionTreeFilter::cut(std::size_t index, std::size_t c, std::size_t kept) {
  for (const std::size_t b : current_holders(index, c, kept)) drop(b, index);
  home_[index] = kept;
  ++version_;
}

void ThinJunctionTreeFilter::dissolve_if_redundant(std::size_t c) {
  Clique& clique = cliques_[c];
  if (c == kRoot || !clique.alive) return;
  Clique& parent = cliques_[clique.parent];
  for (const std::size_t l : clique.landmarks)
    if (!parent.holds(l)) return;
  // Whatever a child shares with c, the parent holds too: the child's separator is unchanged.
  for (const std::size_t child : clique.children) {
    cliques_[child].parent = clique.parent;
    parent.children.push_back(child);
  }
  std::erase(parent.children, c);
  for (const std::size_t l : clique.landmarks)
    if (home_[l] == c) home_[l] = clique.parent;
  clique = Clique{};
  clique.alive = false;
  free_.push_back(c);
}

}  // namespace slamkit
