#include "slamkit/pipeline/run_memory.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_set>
#include <variant>

#include "slamkit/core/memory_budget.hpp"
#include "slamkit/core/run_result.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/fastslam.hpp"
#include "slamkit/filters/sparse_extended_information_filter.hpp"

namespace slamkit {
namespace {

bool particle_filter(FilterKind kind) {
  return kind == FilterKind::kFastSlam1 || kind == FilterKind::kFastSlam2 || kind == FilterKind::kGridFastSlam;
}

std::size_t expected_landmarks(const Dataset& dataset) {
  std::unordered_set<int> ids;
  for (const Event& event : dataset.events)
    if (const auto* scan = std::get_if<ScanEvent>(&event))
      for (const Observation& o : scan->observations)
        if (o.id != kUnknownId) ids.insert(o.id);
  return ids.empty() ? dataset.truth.landmarks.size() : ids.size();
}

constexpr double kGiB = 0x1p30;

double filter_bytes(const FilterConfig& config, std::size_t landmarks) {
  switch (config.filter) {
    case FilterKind::kFastSlam1:
    case FilterKind::kFastSlam2:
      return FastSlam::memory_estimate(static_cast<std::size_t>(config.particles), landmarks);
    // The exact information matrix fills in (every landmark linked with every other), and its
    // Cholesky factor is as large again.
    case FilterKind::kEif: return 2.0 * EkfSlam::memory_estimate(landmarks);
    case FilterKind::kSeif: return SparseInformationFilter::memory_estimate(landmarks, config.seif);
    case FilterKind::kEseif: return SparseInformationFilter::memory_estimate(landmarks, config.eseif);
    case FilterKind::kTjtf: return ThinJunctionTreeFilter::memory_estimate(landmarks, config.tjtf);
    // A grid holds the tiles its scans touched, and particles share the tiles their maps have in
    // common: what that comes to depends on the building and the route, not on anything known before
    // the run, so it is not estimated (grid_bytes_per_particle reports it afterwards).
    case FilterKind::kScanMatching:
    case FilterKind::kGridFastSlam: return 0.0;
    default: return EkfSlam::memory_estimate(landmarks);
  }
}

}  // namespace

RunMemoryEstimate estimate_run_memory(const FilterConfig& config, const Dataset& dataset, const RunOptions& options) {
  RunMemoryEstimate estimate;
  estimate.landmarks = expected_landmarks(dataset);
  const bool particles = particle_filter(config.filter);
  estimate.filter_bytes = filter_bytes(config, estimate.landmarks);
  if (options.history == History::kNone) return estimate;

  double scans = 0.0, observations = 0.0;
  for (const Event& event : dataset.events)
    if (const auto* scan = std::get_if<ScanEvent>(&event)) {
      scans += 1.0;
      observations += static_cast<double>(scan->observations.size());
    }
  const double duration =
      dataset.events.empty() ? 0.0 : event_time(dataset.events.back()) - event_time(dataset.events.front());
  // Landmark and particle samples are taken at most once per std_interval_s, at scans.
  double samples = options.std_interval_s > 0.0 ? std::min(scans, std::floor(duration / options.std_interval_s) + 1.0)
                                                : scans;
  double steps = static_cast<double>(dataset.events.size()) + 1.0;
  if (options.history == History::kDecimated) {
    const auto cap = static_cast<double>(options.decimated_samples);
    samples = std::min(samples, cap);
    steps = std::min(steps, cap);
  } else {
    estimate.history_bytes += observations * sizeof(AssociationRecord);
  }
  estimate.history_bytes += steps * (sizeof(StampedPose) + sizeof(Matrix3));
  estimate.history_bytes += samples * static_cast<double>(estimate.landmarks) * sizeof(LandmarkStdSample);
  if (particles) estimate.history_bytes += samples * config.particles * sizeof(ParticleSample);
  return estimate;
}

void require_run_memory(const FilterConfig& config, const Dataset& dataset, const RunOptions& options,
                        double budget_bytes) {
  const RunMemoryEstimate estimate = estimate_run_memory(config, dataset, options);
  const std::string filter =
      config.filter == FilterKind::kGridFastSlam
          ? fmt::format("{} with {} particles (--particles)", to_string(config.filter), config.particles)
      : particle_filter(config.filter)
          ? fmt::format("{} with {} particles (--particles) and maps of about {} landmarks ({:.3g} GiB)",
                        to_string(config.filter), config.particles, estimate.landmarks, estimate.filter_bytes / kGiB)
          : fmt::format("{} with a map of about {} landmarks ({:.3g} GiB for its {})", to_string(config.filter),
                        estimate.landmarks, estimate.filter_bytes / kGiB,
                        config.filter == FilterKind::kEif || config.filter == FilterKind::kSeif ||
                                config.filter == FilterKind::kEseif
                            ? "information matrix"
                        : config.filter == FilterKind::kTjtf ? "junction tree"
                                                             : "covariance");
  const std::string what = fmt::format("{} and the history --history {} keeps ({:.3g} GiB)", filter,
                                      to_string(options.history), estimate.history_bytes / kGiB);
  if (budget_bytes > 0.0 && estimate.total_bytes() > budget_bytes)
    throw std::length_error(fmt::format("{} need about {:.3g} GiB, more than the {:.3g} GiB each run may use "
                                        "(a campaign's memory_per_run_mb)",
                                        what, estimate.total_bytes() / kGiB, budget_bytes / kGiB));
  require_memory(estimate.total_bytes(), what);
}

}  // namespace slamkit
