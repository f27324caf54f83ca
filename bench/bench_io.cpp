// Reading Victoria Park's laser log, against the floor any reader of that file has: inflating it.
//
// LASER.txt.gz is 1.2 MB of gzip holding 15.5 MB of text (7,230 scans of 361 ranges). From the page
// cache, reading the compressed bytes costs next to nothing, so "disk speed" for this file is the
// speed of zlib's inflate; each stage of the reader is measured against it in the same run, as
// uncompressed bytes per second:
//   inflate only -> TextReader (lines split into fields) -> every field parsed as a checked number ->
//   the whole dataset reader (DR, GPS, laser, tree detection, event merge).
// Skipped, with the reason, when the dataset is not found ($SLAMKIT_DATA or ../shared/datasets).
#include <benchmark/benchmark.h>
#include <zlib.h>

#include <filesystem>
#include <string>
#include <vector>

#include "slamkit/io/load_dataset.hpp"
#include "slamkit/core/text_reader.hpp"
#include "slamkit/io/victoria_park.hpp"

namespace {

using namespace slamkit;

std::string victoria_park_folder() {
  return (std::filesystem::path(datasets_folder()) / "victoria_park").string();
}

std::string laser_file() { return victoria_park_folder() + "/acfr_ascii/LASER.txt.gz"; }

// Inflates the whole file into a reused buffer; returns the uncompressed size.
std::size_t inflate_all(const std::string& path) {
  gzFile file = gzopen(path.c_str(), "rb");
  if (file == nullptr) return 0;
  gzbuffer(file, 1 << 17);
  std::vector<char> buffer(1 << 17);
  std::size_t total = 0;
  int got = 0;
  while ((got = gzread(file, buffer.data(), static_cast<unsigned>(buffer.size()))) > 0)
    total += static_cast<std::size_t>(got);
  gzclose(file);
  return total;
}

bool skip_without_data(benchmark::State& state) {
  if (std::filesystem::exists(laser_file())) return false;
  state.SkipWithError(("Victoria Park not found at " + laser_file() + "; set SLAMKIT_DATA").c_str());
  return true;
}

void report_bytes(benchmark::State& state) {
  static const std::size_t uncompressed = inflate_all(laser_file());
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * uncompressed));
}

void BM_VictoriaParkLaserInflate(benchmark::State& state) {
  if (skip_without_data(state)) return;
  for (auto _ : state) benchmark::DoNotOptimize(inflate_all(laser_file()));
  report_bytes(state);
}

void BM_VictoriaParkLaserSplitFields(benchmark::State& state) {
  if (skip_without_data(state)) return;
  for (auto _ : state) {
    TextReader in(laser_file());
    std::size_t fields = 0;
    while (in.next()) fields += in.size();
    benchmark::DoNotOptimize(fields);
  }
  report_bytes(state);
}

void BM_VictoriaParkLaserParseNumbers(benchmark::State& state) {
  if (skip_without_data(state)) return;
  for (auto _ : state) {
    TextReader in(laser_file());
    double sum = 0.0;
    while (in.next())
      for (std::size_t i = 0; i < in.size(); ++i) sum += in.number(i, "a range");
    benchmark::DoNotOptimize(sum);
  }
  report_bytes(state);
}

// The whole reader, as `slamkit run --data victoria-park` calls it: the laser dominates.
void BM_VictoriaParkReadDataset(benchmark::State& state) {
  if (skip_without_data(state)) return;
  for (auto _ : state) benchmark::DoNotOptimize(read_victoria_park(victoria_park_folder()));
  report_bytes(state);
}

BENCHMARK(BM_VictoriaParkLaserInflate)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_VictoriaParkLaserSplitFields)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_VictoriaParkLaserParseNumbers)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_VictoriaParkReadDataset)->Unit(benchmark::kMillisecond);

}  // namespace
