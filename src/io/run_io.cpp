#include "slamkit/io/run_io.hpp"

#include <fmt/format.h>
#include <fmt/os.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>

#include "slamkit/core/error.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/text_reader.hpp"
#include "slamkit/grid/grid_snapshot.hpp"
#include "slamkit/grid/map_files.hpp"
#include "slamkit/io/trajectory_io.hpp"
#include "line_writer.hpp"

namespace slamkit {

namespace fs = std::filesystem;

namespace {

std::string path_in(const std::string& dir, const char* file) { return (fs::path(dir) / file).string(); }

void write_landmark_std(const std::string& path, const std::vector<LandmarkStdSample>& samples) {
  LineWriter out(path);
  out.text("# t id std_x std_y  (landmark standard deviations [m] over time)");
  out.end_line();
  for (const auto& s : samples) {
    out.fixed(s.t, 6).text(" ").integer(s.id).text(" ").general(s.std_x, 6).text(" ").general(s.std_y, 6);
    out.end_line();
  }
  out.finish();
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

void write_associations(const std::string& path, const std::vector<double>& times,
                        const std::vector<std::vector<AssociationRecord>>& associations) {
  LineWriter out(path);
  out.text("# scan t observation decision landmark_id  (decision: update | new | discard | pending)\n"
           "# a scan without observations is one line: scan t none");
  out.end_line();
  for (std::size_t k = 0; k < associations.size(); ++k) {
    const auto scan = static_cast<long long>(k);
    if (associations[k].empty()) {
      out.integer(scan).text(" ").fixed(times[k], 6).text(" none");
      out.end_line();
    }
    for (std::size_t i = 0; i < associations[k].size(); ++i) {
      out.integer(scan).text(" ").fixed(times[k], 6).text(" ").integer(static_cast<long long>(i)).text(" ");
      out.text(to_string(associations[k][i].decision)).text(" ").integer(associations[k][i].landmark_id);
      out.end_line();
    }
  }
  out.finish();
}

void read_associations(const std::string& path, RunResult& run) {
  TextReader in(path);
  while (in.next()) {
    const bool empty_scan = in.size() == 3 && in.field(2) == "none";
    if (!empty_scan) in.expect_fields(5, "scan t observation decision landmark_id");
    const long scan = in.integer(0, "scan");
    const double t = in.number(1, "t");
    // Each line continues the current scan or starts the next: a line of an earlier scan would
    // otherwise be filed under the current one.
    const std::size_t next = run.associations.size();
    const bool starts_scan = scan >= 0 && static_cast<std::size_t>(scan) == next;
    const bool continues_scan = next > 0 && scan >= 0 && static_cast<std::size_t>(scan) == next - 1;
    if (!starts_scan && !continues_scan)
      in.fail(fmt::format("expected scan {}{}, found scan {}", next, next > 0 ? fmt::format(" or {}", next - 1) : "",
                          scan));
    if (starts_scan) {
      run.associations.emplace_back();
      run.scan_times.push_back(t);
    } else if (empty_scan || run.associations.back().empty()) {
      in.fail(fmt::format("scan {} was already given as having no observations", scan));
    } else if (t != run.scan_times.back()) {
      in.fail(fmt::format("scan {} has time {} here and {} on the lines before", scan, t, run.scan_times.back()));
    }
    if (empty_scan) continue;
    const long obs = in.integer(2, "observation");
    auto& records = run.associations.back();
    if (obs != static_cast<long>(records.size()))
      in.fail("expected observation " + std::to_string(records.size()) + ", found " + std::to_string(obs));
    AssociationRecord r;
    const std::string_view d = in.field(3);
    if (d == "update")
      r.decision = AssociationDecision::kUpdate;
    else if (d == "new")
      r.decision = AssociationDecision::kNew;
    else if (d == "discard")
      r.decision = AssociationDecision::kDiscard;
    else if (d == "pending")
      r.decision = AssociationDecision::kPending;
    else
      in.fail("expected a decision (update, new, discard or pending), found '" + std::string(d) + "'");
    const long id = in.integer(4, "landmark_id");
    if (id < -1 || id > std::numeric_limits<int>::max())
      in.fail(fmt::format("expected a landmark id from -1 to {}, found {}", std::numeric_limits<int>::max(), id));
    r.landmark_id = static_cast<int>(id);
    records.push_back(r);
  }
}

void write_landmark_origins(const std::string& path, const std::map<int, LandmarkOrigin>& origins) {
  LineWriter out(path);
  out.text("# landmark_id scan observation  (the observation each landmark was started from, 0-based)");
  out.end_line();
  for (const auto& [id, origin] : origins) {
    out.integer(id).text(" ").integer(static_cast<long long>(origin.scan)).text(" ");
    out.integer(static_cast<long long>(origin.observation));
    out.end_line();
  }
  out.finish();
}

std::map<int, LandmarkOrigin> read_landmark_origins(const std::string& path, std::size_t scans) {
  std::map<int, LandmarkOrigin> origins;
  TextReader in(path);
  while (in.next()) {
    in.expect_fields(3, "landmark_id scan observation");
    const long id = in.integer(0, "landmark_id");
    const long scan = in.integer(1, "scan");
    const long observation = in.integer(2, "observation");
    if (id < 0 || id > std::numeric_limits<int>::max())
      in.fail(fmt::format("expected a landmark id from 0 to {}, found {}", std::numeric_limits<int>::max(), id));
    if (scan < 0 || static_cast<std::size_t>(scan) >= scans)
      in.fail(fmt::format("expected a scan from 0 to {}, found {}", scans == 0 ? 0 : scans - 1, scan));
    if (observation < 0) in.fail(fmt::format("expected an observation index >= 0, found {}", observation));
    if (!origins.try_emplace(static_cast<int>(id), LandmarkOrigin{static_cast<std::size_t>(scan),
                                                                  static_cast<std::size_t>(observation)})
             .second)
      in.fail(fmt::format("landmark {} is given twice", id));
  }
  return origins;
}

void write_particles(const std::string& path, const std::vector<ParticleSample>& samples) {
  LineWriter out(path);
  out.text("# t x y theta weight  (particle clouds over time)");
  out.end_line();
  for (const auto& s : samples) {
    out.fixed(s.t, 6).text(" ").fixed(s.particle.pose.x(), 6).text(" ").fixed(s.particle.pose.y(), 6).text(" ");
    out.fixed(s.particle.pose.z(), 6).text(" ").general(s.particle.weight, 6);
    out.end_line();
  }
  out.finish();
}

std::vector<ParticleSample> read_particles(const std::string& path) {
  std::vector<ParticleSample> samples;
  TextReader in(path);
  while (in.next()) {
    in.expect_fields(5, "t x y theta weight");
    ParticleSample s;
    s.t = in.number(0, "t");
    s.particle.pose = Pose2(in.number(1, "x"), in.number(2, "y"), in.number(3, "theta"));
    s.particle.weight = in.number(4, "weight");
    if (s.particle.weight < 0) in.fail("expected a non-negative weight");
    samples.push_back(s);
  }
  return samples;
}

}  // namespace

AtomicFolder stage_run_folder(const std::string& dir) { return AtomicFolder(dir, "run.json"); }

void write_run_files(const std::string& dir, const RunResult& run) {
  write_tum(path_in(dir, "trajectory.tum"), run.trajectory);
  // The per-step estimates get their own file only where they differ from the trajectory.
  const bool separate_filtered = !std::equal(run.filtered.begin(), run.filtered.end(), run.trajectory.begin(),
                                             run.trajectory.end(), [](const StampedPose& a, const StampedPose& b) {
                                               return a.t == b.t && a.pose == b.pose;
                                             });
  if (separate_filtered) write_tum(path_in(dir, "filtered.tum"), run.filtered);
  std::vector<double> times(run.filtered.size());
  for (std::size_t i = 0; i < times.size(); ++i) times[i] = run.filtered[i].t;
  write_pose_covariances(path_in(dir, "pose_covariance.txt"), times, run.pose_covariances);
  write_tum(path_in(dir, "dead_reckoning.tum"), run.dead_reckoning);
  write_map(path_in(dir, "map.txt"), run.map);
  if (!run.grid.empty())
    write_map_server(from_grid_map(run.grid), path_in(dir, "map.pgm"), path_in(dir, "map.yaml"));
  write_landmark_std(path_in(dir, "landmark_std.txt"), run.landmark_std);
  write_associations(path_in(dir, "associations.txt"), run.scan_times, run.associations);
  if (!run.landmark_origins.empty()) write_landmark_origins(path_in(dir, "landmark_origins.txt"), run.landmark_origins);
  if (!run.particles.empty()) write_particles(path_in(dir, "particles.txt"), run.particles);
  write_run_json(dir, run);
}

void write_run_json(const std::string& dir, const RunResult& run) {
  nlohmann::json info = run.provenance;
  info.update({{"filter", run.filter},
               {"dataset", run.dataset},
               {"dataset_settings", run.dataset_settings},
               {"association", run.association},
               {"partial", run.partial},
               {"diverged_at_s", run.diverged_at_s ? nlohmann::json(*run.diverged_at_s) : nlohmann::json()},
               {"divergence", run.diverged_at_s ? nlohmann::json(run.divergence) : nlohmann::json()},
               {"history", run.history},
               {"steps", run.steps},
               {"scans", run.scans},
               {"observations", run.observations},
               {"wall_time_s", run.wall_time_s},
               {"statistics", run.statistics}});
  write_file_atomically(path_in(dir, "run.json"), info.dump(2) + "\n");
}

void write_run(const std::string& dir, const RunResult& run) {
  AtomicFolder folder = stage_run_folder(dir);
  write_run_files(folder.path(), run);
  folder.commit();
}

void require_run_folder(const std::string& dir) {
  if (!std::filesystem::is_directory(dir))
    throw InputError(dir, 0, std::filesystem::exists(dir) ? "not a folder; expected a run folder written by 'slamkit run'"
                                                          : "no such folder; expected a run folder written by 'slamkit run'");
  require_complete_folder(dir);
}

RunResult read_run(const std::string& dir) {
  require_run_folder(dir);
  RunResult run;
  const std::string info_path = path_in(dir, "run.json");
  if (!fs::exists(info_path))
    throw InputError(info_path, 0, "cannot open file for reading (is this a slamkit run folder?)");
  const nlohmann::json info = read_json_file(info_path);
  try {
    run.filter = info.at("filter").get<std::string>();
    run.dataset = info.at("dataset").get<std::string>();
    // nlohmann converts a float to an integer type unchecked (undefined beyond its range: a fuzzer
    // found "scans": 2.2e25), so counts are taken only as integers that fit.
    const auto count = [&](const char* key) {
      std::size_t n = 0;
      if (!option_detail::integer_in(info.at(key), std::size_t{0}, std::numeric_limits<std::size_t>::max(), n))
        throw InputError(info_path, 0, fmt::format("expected '{}' to be a count (an integer >= 0), found {}", key,
                                                   info.at(key).dump()));
      return n;
    };
    run.steps = count("steps");
    run.scans = count("scans");
    run.observations = count("observations");
    run.wall_time_s = info.at("wall_time_s").get<double>();
    run.association = info.value("association", "known");
    run.dataset_settings = info.value("dataset_settings", "");
    run.statistics = info.value("statistics", std::map<std::string, double>{});
    run.partial = info.value("partial", false);
    if (const auto at = info.find("diverged_at_s"); at != info.end() && !at->is_null()) {
      if (!at->is_number()) throw InputError(info_path, 0, "expected 'diverged_at_s' to be a time or null, found " + at->dump());
      run.diverged_at_s = at->get<double>();
      if (const auto why = info.find("divergence"); why != info.end() && why->is_string())
        run.divergence = why->get<std::string>();
    }
    run.history = info.value("history", "full");
    if (run.history != "full" && run.history != "decimated" && run.history != "none")
      throw InputError(info_path, 0, "expected 'history' to be full, decimated or none, found '" + run.history + "'");
    run.provenance = info;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(info_path, 0, std::string("expected a run description: ") + e.what());
  }

  run.trajectory = read_tum(path_in(dir, "trajectory.tum"));
  const std::string filtered_path = path_in(dir, "filtered.tum");
  run.smoothed = fs::exists(filtered_path);  // written only when the trajectory is not the filtered one
  run.filtered = run.smoothed ? read_tum(filtered_path) : run.trajectory;
  const std::string cov_path = path_in(dir, "pose_covariance.txt");
  PoseCovariances covs = read_pose_covariances(cov_path);
  if (covs.t.size() != run.filtered.size())
    throw InputError(cov_path, 0,
                     fmt::format("expected one covariance per filtered pose ({}), found {}", run.filtered.size(),
                                 covs.t.size()));
  run.pose_covariances = std::move(covs.covariance);
  run.dead_reckoning = read_tum(path_in(dir, "dead_reckoning.tum"));
  run.map = read_map(path_in(dir, "map.txt"));
  // The grid as the map server files hold it: occupied, free or unknown per cell.
  if (fs::exists(path_in(dir, "map.yaml"))) run.grid = to_grid_map(read_map_server(path_in(dir, "map.yaml")));
  run.landmark_std = read_landmark_std(path_in(dir, "landmark_std.txt"));
  read_associations(path_in(dir, "associations.txt"), run);
  if (fs::exists(path_in(dir, "landmark_origins.txt")))
    run.landmark_origins = read_landmark_origins(path_in(dir, "landmark_origins.txt"), run.scans);
  if (fs::exists(path_in(dir, "particles.txt"))) run.particles = read_particles(path_in(dir, "particles.txt"));
  // Only a run that kept its full history has every scan's associations.
  if (run.history == "full" && run.associations.size() != run.scans)
    throw InputError(path_in(dir, "associations.txt"), 0,
                     fmt::format("expected the associations of {} scans, found {}", run.scans, run.associations.size()));
  return run;
}

}  // namespace slamkit
