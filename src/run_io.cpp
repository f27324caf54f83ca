#include "slamkit/io/run_io.hpp"

#include <fmt/format.h>
#include <fmt/os.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "slamkit/error.hpp"
#include "slamkit/io/text_reader.hpp"
#include "slamkit/io/trajectory_io.hpp"

namespace slamkit {

namespace fs = std::filesystem;

namespace {

std::string path_in(const std::string& dir, const char* file) { return (fs::path(dir) / file).string(); }

void write_landmark_std(const std::string& path, const std::vector<LandmarkStdSample>& samples) {
  std::ofstream out(path);
  if (!out) throw InputError(path, 0, "cannot open file for writing");
  out << "# t id std_x std_y  (landmark standard deviations [m] over time)\n";
  for (const auto& s : samples) out << fmt::format("{:.6f} {} {:.6g} {:.6g}\n", s.t, s.id, s.std_x, s.std_y);
  if (!out) throw InputError(path, 0, "write failed");
}

std::vector<LandmarkStdSample> read_landmark_std(const std::string& path) {
  std::vector<LandmarkStdSample> samples;
  TextReader in(path);
  while (in.next()) {
    in.expect_fields(4, "t id std_x std_y");
    LandmarkStdSample s{in.number(0, "t"), static_cast<int>(in.integer(1, "id")), in.number(2, "std_x"),
                        in.number(3, "std_y")};
    if (s.std_x < 0 || s.std_y < 0) in.fail("expected non-negative standard deviations");
    samples.push_back(s);
  }
  return samples;
}

}  // namespace

void write_run(const std::string& dir, const RunResult& run) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(dir, 0, "cannot create output directory: " + ec.message());

  write_tum(path_in(dir, "trajectory.tum"), run.trajectory);
  std::vector<double> times(run.trajectory.size());
  for (std::size_t i = 0; i < times.size(); ++i) times[i] = run.trajectory[i].t;
  write_pose_covariances(path_in(dir, "pose_covariance.txt"), times, run.pose_covariances);
  write_tum(path_in(dir, "dead_reckoning.tum"), run.dead_reckoning);
  write_map(path_in(dir, "map.txt"), run.map);
  write_landmark_std(path_in(dir, "landmark_std.txt"), run.landmark_std);

  const nlohmann::json info = {{"filter", run.filter},     {"dataset", run.dataset},
                               {"steps", run.steps},       {"scans", run.scans},
                               {"observations", run.observations}, {"wall_time_s", run.wall_time_s}};
  const std::string info_path = path_in(dir, "run.json");
  std::ofstream out(info_path);
  out << info.dump(2) << "\n";
  if (!out) throw InputError(info_path, 0, "write failed");
}

RunResult read_run(const std::string& dir) {
  RunResult run;
  const std::string info_path = path_in(dir, "run.json");
  std::ifstream in(info_path);
  if (!in) throw InputError(info_path, 0, "cannot open file for reading (is this a slamkit run folder?)");
  nlohmann::json info;
  try {
    info = nlohmann::json::parse(in);
    run.filter = info.at("filter").get<std::string>();
    run.dataset = info.at("dataset").get<std::string>();
    run.steps = info.at("steps").get<std::size_t>();
    run.scans = info.at("scans").get<std::size_t>();
    run.observations = info.at("observations").get<std::size_t>();
    run.wall_time_s = info.at("wall_time_s").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(info_path, 0, std::string("expected a run description: ") + e.what());
  }

  run.trajectory = read_tum(path_in(dir, "trajectory.tum"));
  const std::string cov_path = path_in(dir, "pose_covariance.txt");
  PoseCovariances covs = read_pose_covariances(cov_path);
  if (covs.t.size() != run.trajectory.size())
    throw InputError(cov_path, 0,
                     fmt::format("expected one covariance per trajectory sample ({}), found {}",
                                 run.trajectory.size(), covs.t.size()));
  run.pose_covariances = std::move(covs.covariance);
  run.dead_reckoning = read_tum(path_in(dir, "dead_reckoning.tum"));
  run.map = read_map(path_in(dir, "map.txt"));
  run.landmark_std = read_landmark_std(path_in(dir, "landmark_std.txt"));
  return run;
}

}  // namespace slamkit
