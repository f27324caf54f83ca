#pragma once
// The pictures of a run, drawn from what the run wrote and its evaluation:
//   map.svg           true and estimated trajectories, dead reckoning, true landmarks and the
//                     estimated map with 2-sigma ellipses (estimates SE(2)-aligned onto the truth)
//   landmark_std.svg  landmark standard deviations over time (the tutorial's Figure 3)
//   nees.svg          pose NEES over time with its 95% interval (where the truth has headings)
//   information.svg   an information filter's information matrix at the end (SEIF: before and
//                     after a sparsification), each link's normalised magnitude
#include <string>
#include <vector>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/core/run_result.hpp"

namespace slamkit {

/// Writes map.svg, landmark_std.svg, nees.svg and (an information filter's) information.svg into `dir`.
void write_run_plots(const std::string& dir, const RunResult& run, const GroundTruth& truth,
                     const Metrics& metrics);

/// The Monte Carlo picture of consistency: the pose NEES of `runs` (the evaluations of one filter on
/// logs that differ only in their noise seed) averaged step by step, with the 95% interval of an
/// N-run mean, written to `path`, over the step times all runs have. Throws std::invalid_argument if
/// a run has no NEES series or the runs have no step time in common.
void write_monte_carlo_nees(const std::string& path, const std::vector<Metrics>& runs, const std::string& title);

}  // namespace slamkit
