#pragma once
// The plots of docs/performance.md, drawn from Google Benchmark's JSON output (`make bench`):
// what each operation costs against the map's size and against the particles.

#include <string>
#include <vector>

namespace slamkit::plot {

/// Reads the benchmark results in `json_paths` (Google Benchmark's --benchmark_out JSON; with
/// repetitions, their medians are used, otherwise the single runs) and writes into `out_dir`:
/// ekf_vs_landmarks.svg, fastslam_vs_particles.svg, fastslam_vs_landmarks.svg,
/// association_vs_landmarks.svg and information_vs_landmarks.svg (SEIF, EIF and EKF steps against
/// the landmarks' logarithm), each with the series whose benchmarks are present (CPU time, log
/// scale). Returns the files written. Throws InputError on a file that is not such output.
std::vector<std::string> write_benchmark_plots(const std::vector<std::string>& json_paths, const std::string& out_dir);

}  // namespace slamkit::plot
