// The performance page's plots come from Google Benchmark's JSON: medians are taken where the file
// has repetitions, bare NaN (which Google Benchmark writes for some counters) does not break the
// reader, and a file that is not benchmark output is a clear error.
#include "slamkit/plot/benchmark_plots.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "slamkit/core/error.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

using test_data::read_text;
using test_data::ScratchDir;
using test_data::write_text;

std::string entry(const std::string& name, const std::string& type, const std::string& aggregate, double cpu,
                  const std::string& unit) {
  return "{\"name\": \"" + name + (aggregate.empty() ? "" : "_" + aggregate) + "\", \"run_name\": \"" + name +
         "\", \"run_type\": \"" + type + "\", \"aggregate_name\": \"" + aggregate + "\", \"cpu_time\": " +
         std::to_string(cpu) + ", \"real_time\": " + std::to_string(cpu) + ", \"time_unit\": \"" + unit +
         "\", \"flushes\": NaN}";
}

TEST(BenchmarkPlots, DrawsMediansOfThePresentSeries) {
  ScratchDir dir;
  const std::string json =
      "{\"context\": {}, \"benchmarks\": [" + entry("BM_EkfObservationUpdate/100", "aggregate", "mean", 999.0, "us") +
      ", " + entry("BM_EkfObservationUpdate/100", "aggregate", "median", 15.0, "us") + ", " +
      entry("BM_EkfObservationUpdate/1000", "aggregate", "median", 1.2, "ms") + ", " +
      entry("BM_AssociationJcbb/100", "iteration", "", 20000.0, "ns") + ", " +
      entry("BM_AssociationJcbb/5000", "iteration", "", 21000.0, "ns") + "]}";
  write_text(dir.file("bench.json"), json);
  const auto files = plot::write_benchmark_plots({dir.file("bench.json")}, dir.file("plots"));
  ASSERT_EQ(files.size(), 2U);  // no FastSLAM benchmarks in the file, so no FastSLAM plots
  const std::string ekf = read_text(dir.file("plots/ekf_vs_landmarks.svg"));
  EXPECT_NE(ekf.find("observation update (one landmark)"), std::string::npos);
  EXPECT_EQ(ekf.find("scan of 15 observations"), std::string::npos);
  // The log axis spans the medians, 15 us to 1.2 ms; had it taken the 999 us mean, 10^-4 would be off it.
  EXPECT_NE(ekf.find(">10⁻⁴<"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir.file("plots/association_vs_landmarks.svg")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("plots/fastslam_vs_particles.svg")));
}

// The information filters' steps span decades of landmarks: their x is drawn as its logarithm, so
// 100 and 30,000 landmarks sit at 2 and 4.48 of an axis that says what its numbers mean.
TEST(BenchmarkPlots, DrawsTheInformationFiltersAgainstTheLogarithmOfTheLandmarks) {
  ScratchDir dir;
  const std::string json = "{\"context\": {}, \"benchmarks\": [" +
                           entry("BM_InformationStep/seif/100", "iteration", "", 150.0, "us") + ", " +
                           entry("BM_InformationStep/seif/30000", "iteration", "", 4.5, "ms") + ", " +
                           entry("BM_InformationStep/seif_ungated/30000", "iteration", "", 40.0, "us") + ", " +
                           entry("BM_InformationStep/ekf/100", "iteration", "", 30.0, "us") + ", " +
                           entry("BM_InformationStep/ekf/3000", "iteration", "", 15.0, "ms") + ", " +
                           entry("BM_InformationStep/tjtf_ungated/1000", "iteration", "", 9.0, "ms") + "]}";
  write_text(dir.file("bench.json"), json);
  const auto files = plot::write_benchmark_plots({dir.file("bench.json")}, dir.file("plots"));
  ASSERT_EQ(files.size(), 1U);  // no other benchmarks in the file, so no other plots
  const std::string svg = read_text(dir.file("plots/information_vs_landmarks.svg"));
  EXPECT_NE(svg.find("SEIF (known-identity gate on)"), std::string::npos);
  EXPECT_NE(svg.find("SEIF, gate off"), std::string::npos);
  EXPECT_NE(svg.find("full EKF"), std::string::npos);
  EXPECT_NE(svg.find("TJTF, gate off"), std::string::npos);
  EXPECT_EQ(svg.find(">EIF<"), std::string::npos);  // no EIF benchmarks, no EIF series
  EXPECT_NE(svg.find("log\u2081\u2080 landmarks"), std::string::npos);
  // Ticks of the logarithm: had x been the landmarks themselves, the axis would read thousands.
  EXPECT_NE(svg.find(">3.0<"), std::string::npos);
  EXPECT_EQ(svg.find("000<"), std::string::npos);
}

TEST(BenchmarkPlots, RejectsWhatIsNotBenchmarkOutput) {
  ScratchDir dir;
  write_text(dir.file("bad.json"), "{\"benchmarks\": 3}");
  try {
    plot::write_benchmark_plots({dir.file("bad.json")}, dir.file("plots"));
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
  }
  EXPECT_THROW(plot::write_benchmark_plots({dir.file("missing.json")}, dir.file("plots")), InputError);
}

}  // namespace
}  // namespace slamkit
