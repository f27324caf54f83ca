#pragma once
// Map matching: which landmarks of a joint Gaussian map are the same landmark mapped twice. At a loop
// closure after a long drift a filter that cannot recognise its old landmarks from single
// observations (they lie beyond its gates, or clutter lies inside them) maps them again; once a few
// of those duplicates are confirmed, their positions relative to each other are known well enough to
// be matched against the old map as a whole. The joint Gaussian holds the exact correlations of the
// discrepancies m_duplicate - m_original (through the vehicle's path between the two mappings), so
// the search is JCBB (Neira and Tardos) over landmark pairs instead of observation-landmark pairs:
// the hypothesis with the most pairs whose joint discrepancy passes the chi-square gate (2k dof),
// ties broken by the smaller joint Mahalanobis distance.
#include <cstddef>
#include <span>
#include <vector>

#include "slamkit/assoc/association.hpp"

namespace slamkit {

/// Two map indices taken for one landmark: `duplicate` mapped again, `original` mapped before.
struct LandmarkPair {
  std::size_t duplicate = 0;
  std::size_t original = 0;
};

struct MapMatchStats {
  std::size_t pairs_tested = 0;  // individual compatibility tests
  std::size_t nodes = 0;         // search nodes expanded
};

/// The search, with storage kept from one call to the next: a search no larger than those before it
/// allocates nothing.
class MapMatcher {
 public:
  /// The largest jointly compatible set of pairs between `recent` and `old` map indices (disjoint
  /// sets; each landmark in at most one pair), ties broken by the smaller joint distance; empty if
  /// no pair passes. A pair is a candidate if its own discrepancy passes the 2-dof gate of
  /// `probability`, and a hypothesis of k pairs must pass the 2k-dof gate. At most `max_nodes`
  /// search nodes; past that, the best hypothesis found so far. Valid until the next call.
  const std::vector<LandmarkPair>& match(std::span<const std::size_t> recent, std::span<const std::size_t> old,
                                         const GaussianMapView& map, double probability, std::size_t max_nodes,
                                         MapMatchStats* stats = nullptr);

 private:
  struct Option {
    LandmarkPair pair;
    double d2 = 0.0;
  };
  Vector2 discrepancy(const LandmarkPair& p) const;
  Matrix2 covariance(const LandmarkPair& a, const LandmarkPair& b) const;
  double joint_d2();
  bool better(std::size_t pairs, double d2) const;
  void search(std::size_t depth);

  const GaussianMapView* map_ = nullptr;
  std::size_t max_nodes_ = 0, nodes_ = 0;
  // Recent landmark i's options (nearest first) are options_[begin_[order_[i]], begin_[order_[i] + 1]).
  std::vector<Option> options_;
  std::vector<std::size_t> begin_, order_;
  std::vector<double> joint_gate_;  // for k pairs
  double gate_probability_ = -1.0;  // the probability joint_gate_ was computed for
  std::vector<LandmarkPair> current_, best_;
  std::vector<double> current_d2_;  // the joint distance of current_'s first 1, 2, ... pairs
  double best_d2_ = 0.0;
  Eigen::MatrixXd s_;
  Eigen::VectorXd nu_;
};

}  // namespace slamkit
