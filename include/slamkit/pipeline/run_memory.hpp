#pragma once
// The memory a run will need, estimated from its settings and the dataset before the filter is
// built: settings no machine can hold (a million particles, an EKF over a hundred thousand
// landmarks) are refused up front, naming the setting, rather than ending in std::bad_alloc or in
// swapping hours into the run. The estimates count what dominates and err low: a run they refuse
// would not have fitted.
#include <cstddef>

#include "slamkit/core/dataset.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"

namespace slamkit {

struct RunMemoryEstimate {
  /// The map size assumed: the distinct landmark ids the observations carry, else the number of
  /// true landmarks, else 0 (nothing is known of it, e.g. Victoria Park).
  std::size_t landmarks = 0;
  double filter_bytes = 0.0;   // FastSlam::memory_estimate or EkfSlam::memory_estimate
  double history_bytes = 0.0;  // what the run records (RunOptions::history): per-step estimates,
                               // associations, landmark and particle samples
  double total_bytes() const { return filter_bytes + history_bytes; }
};

RunMemoryEstimate estimate_run_memory(const FilterConfig& config, const Dataset& dataset, const RunOptions& options);

/// Throws std::length_error (core/memory_budget.hpp) naming the filter, its particles or map size,
/// the history and the estimate when the estimate exceeds the memory this process may use, or
/// `budget_bytes` where that is given (> 0): a campaign's share of the machine for each of the runs
/// it holds at once.
void require_run_memory(const FilterConfig& config, const Dataset& dataset, const RunOptions& options,
                        double budget_bytes = 0.0);

}  // namespace slamkit
