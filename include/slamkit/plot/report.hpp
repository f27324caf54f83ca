#pragma once
// The pictures of a run, drawn from what the run wrote and its evaluation:
//   map.svg           true and estimated trajectories, dead reckoning, true landmarks and the
//                     estimated map with 2-sigma ellipses (estimates SE(2)-aligned onto the truth)
//   landmark_std.svg  landmark standard deviations over time (the tutorial's Figure 3)
#include <string>

#include "slamkit/eval/evaluation.hpp"
#include "slamkit/core/dataset.hpp"
#include "slamkit/core/run_result.hpp"

namespace slamkit {

/// Writes map.svg and landmark_std.svg into `dir`.
void write_run_plots(const std::string& dir, const RunResult& run, const GroundTruth& truth,
                     const Metrics& metrics);

}  // namespace slamkit
