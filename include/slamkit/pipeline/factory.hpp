#pragma once
// Builds a filter by name for a dataset, so the CLI and tests choose filters the same way.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "slamkit/assoc/association_config.hpp"
#include "slamkit/filters/slam_filter.hpp"
#include "slamkit/core/dataset.hpp"

namespace slamkit {

struct FilterConfig {
  std::string name = "ekf";
  std::uint64_t seed = 1;
  AssociationConfig association;
  // EKF only.
  std::string ekf_update = "joint";  // joint (a scan's observations at once) | sequential
  std::string ekf_variant = "full";  // full | compressed (same estimate, local-area updates)
  // Particle filters only.
  int particles = 100;
  std::string resample = "systematic";  // multinomial | stratified | systematic | residual
  std::string resample_when = "ess:0.5";  // always | every:K | ess:F
  unsigned threads = 0;                   // 0: all cores
};

/// The filter names make_filter accepts.
std::vector<std::string> filter_names();

/// Throws std::invalid_argument naming the accepted values for an unknown filter name or EKF
/// variant.
std::unique_ptr<SlamFilter> make_filter(const FilterConfig& config, const Dataset& dataset);

}  // namespace slamkit
