#include "slamkit/eval/evaluation.hpp"

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <unordered_map>
#include <unordered_set>
#include <nlohmann/json.hpp>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/version.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/names.hpp"

namespace slamkit {

namespace {

template <typename T>
nlohmann::json optional_json(const std::optional<T>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

struct OriginTable {
  std::unordered_map<int, int> origin;  // filter landmark id -> true id of the observation that started it
  AssociationMetrics metrics;
};

/// Scores the run's association decisions against the truth's identities (see the header).
std::optional<OriginTable> score_associations(const RunResult& run, const GroundTruth& truth, double revisit_gap_s) {
  if (truth.observation_ids.size() != run.associations.size()) return std::nullopt;
  const bool timed = run.scan_times.size() == run.associations.size();
  OriginTable table;
  AssociationMetrics& m = table.metrics;
  std::unordered_set<int> seen, mapped;
  std::unordered_map<int, double> last_seen;      // true id -> time of its latest observation
  std::unordered_map<int, std::size_t> started_at;  // filter landmark id -> the scan that started it
  std::unordered_map<int, std::size_t> return_at;   // true id -> the scan of its first return
  // The origins the filter reported: a particle filter's records are the best particle's of each
  // scan, so a landmark may have been started where no record shows it.
  for (const auto& [id, origin] : run.landmark_origins) {
    if (origin.scan >= truth.observation_ids.size() || origin.observation >= truth.observation_ids[origin.scan].size())
      return std::nullopt;
    table.origin[id] = truth.observation_ids[origin.scan][origin.observation];
    started_at[id] = origin.scan;
  }
  for (std::size_t k = 0; k < run.associations.size(); ++k) {
    const auto& records = run.associations[k];
    const auto& ids = truth.observation_ids[k];
    if (ids.size() != records.size()) return std::nullopt;
    for (std::size_t i = 0; i < records.size(); ++i) {
      const int true_id = ids[i];
      const AssociationRecord& r = records[i];
      if (true_id == kUnknownId) ++m.clutter_observations;
      else seen.insert(true_id);
      if (true_id != kUnknownId && timed) {
        const double t = run.scan_times[k];
        const auto [last, first_time] = last_seen.try_emplace(true_id, t);
        if (!first_time && t - last->second > revisit_gap_s) return_at.try_emplace(true_id, k);
        last->second = t;
        if (const auto back = return_at.find(true_id); back != return_at.end()) {
          ++m.return_observations;
          const auto origin = table.origin.find(r.landmark_id);
          const auto started = started_at.find(r.landmark_id);
          if (r.decision == AssociationDecision::kUpdate && origin != table.origin.end() && origin->second == true_id &&
              started != started_at.end() && started->second < back->second)
            ++m.return_observations_closed;
        }
      }
      switch (r.decision) {
        case AssociationDecision::kNew:
          table.origin[r.landmark_id] = true_id;
          started_at[r.landmark_id] = k;
          if (true_id != kUnknownId && !mapped.insert(true_id).second) ++m.missed;
          break;
        case AssociationDecision::kUpdate: {
          const auto it = table.origin.find(r.landmark_id);
          if (true_id != kUnknownId && it != table.origin.end() && it->second == true_id) ++m.correct;
          else ++m.wrong;
          break;
        }
        case AssociationDecision::kDiscard:
          if (true_id == kUnknownId) ++m.clutter_discarded;
          else if (mapped.count(true_id)) ++m.missed;
          break;
        case AssociationDecision::kPending:
          // Kept towards a landmark's start: neither used nor lost.
          break;
      }
    }
  }
  m.landmarks_true_seen = seen.size();
  std::unordered_set<int> origins_in_map;
  for (const Landmark& lm : run.map) {
    const auto it = table.origin.find(lm.id);
    if (it == table.origin.end() || it->second == kUnknownId || !origins_in_map.insert(it->second).second)
      ++m.spurious_landmarks;
  }
  return table;
}

/// The estimated map relabelled with the true ids of the landmarks' origins (the first landmark of
/// each origin; clutter-born landmarks dropped), for pairing with the true map.
std::vector<Landmark> relabel_by_origin(const std::vector<Landmark>& map, const OriginTable& table) {
  std::vector<Landmark> out;
  std::unordered_set<int> used;
  for (const Landmark& lm : map) {
    const auto it = table.origin.find(lm.id);
    if (it == table.origin.end() || it->second == kUnknownId || !used.insert(it->second).second) continue;
    Landmark relabelled = lm;
    relabelled.id = it->second;
    out.push_back(relabelled);
  }
  return out;
}

/// The estimated map with the true ids it is paired by (see the header), or nothing when it cannot
/// be paired: without known association a filter numbers its landmarks itself, and only their
/// origins link them to the truth.
std::optional<std::vector<Landmark>> map_with_true_ids(const RunResult& run, const std::optional<OriginTable>& origins) {
  if (origins) return relabel_by_origin(run.map, *origins);
  if (run.association == "known") return run.map;
  return std::nullopt;
}

/// The map's error with no trajectory truth to align it by: aligned onto the true landmarks it is
/// paired with, when there are enough of them.
void score_map_alone(const std::vector<Landmark>& map, const std::vector<Landmark>& truth, Metrics& m) {
  std::unordered_map<int, Vector2> true_position;
  for (const Landmark& l : truth) true_position.emplace(l.id, l.position);
  std::vector<Vector2> estimated, actual;
  for (const Landmark& l : map)
    if (const auto match = true_position.find(l.id); l.id != kUnknownId && match != true_position.end()) {
      estimated.push_back(l.position);
      actual.push_back(match->second);
    }
  m.map_landmarks_paired = estimated.size();
  if (estimated.size() < kMinLandmarksToAlign) return;
  m.alignment = eval::align_se2(estimated, actual);
  m.map_rmse_m = eval::map_rmse(map, truth, m.alignment).rmse;
  m.map_alignment = "landmarks";
}

}  // namespace

TimeMatching parse_time_matching(const std::string& name) {
  if (name == "interpolate") return TimeMatching::kInterpolate;
  if (name == "evo") return TimeMatching::kEvo;
  throw std::invalid_argument(unknown_name_message("time matching", name, {"interpolate", "evo"}));
}

std::string to_string(TimeMatching matching) {
  return matching == TimeMatching::kEvo ? "evo" : "interpolate";
}

Metrics evaluate_run(const RunResult& run, const GroundTruth& truth, const EvaluationOptions& options) {
  Metrics m;
  m.filter = run.filter;
  m.dataset = run.dataset;
  m.steps = run.steps;
  m.scans = run.scans;
  m.observations = run.observations;
  m.landmarks = run.map.size();
  m.wall_time_s = run.wall_time_s;
  m.association_method = run.association;
  m.revisit_gap_s = options.revisit_gap_s;
  m.smoothed = run.smoothed;
  m.filter_statistics = run.statistics;
  const std::optional<OriginTable> origins = score_associations(run, truth, options.revisit_gap_s);
  if (origins) m.association = origins->metrics;
  const std::optional<std::vector<Landmark>> map = map_with_true_ids(run, origins);
  m.history = run.history;
  m.time_matching = to_string(options.time_matching);
  if (options.time_matching == TimeMatching::kEvo) m.max_time_difference_s = options.max_time_difference_s;
  if (run.history == "none") return m;
  if (truth.poses.empty()) {
    // A truth of landmarks only (MRCLAM Dataset1, a surveyed map): the run's frame is its start,
    // which nothing ties to the truth's.
    if (!truth.landmarks.empty() && map) score_map_alone(*map, truth.landmarks, m);
    return m;
  }

  const auto match = [&](const std::vector<StampedPose>& estimate) {
    return options.time_matching == TimeMatching::kEvo
               ? eval::match_nearest(estimate, truth.poses, options.max_time_difference_s)
               : eval::match_by_time(estimate, truth.poses, options.max_interpolation_gap_s);
  };
  // ate_rmse_m scores what every filter knew at each step (comparable across filters); a smoothed
  // trajectory (FastSLAM's best particle's path, revised by later scans) is scored on its own.
  const auto filtered_pairs = match(run.filtered);
  if (filtered_pairs.size() >= 2) {
    const eval::AteResult ate = eval::absolute_trajectory_error(filtered_pairs);
    m.ate_rmse_m = ate.rmse;
    m.final_position_error_m = ate.final_error;
  }
  // The map and the pictures go with the trajectory written as the estimate.
  const auto pairs = match(run.trajectory);
  m.matched_poses = pairs.size();
  m.relative_error = eval::relative_pose_error(pairs);
  if (pairs.size() >= 2) {
    const eval::AteResult ate = eval::absolute_trajectory_error(pairs);
    if (run.smoothed) m.smoothed_ate_rmse_m = ate.rmse;
    m.alignment = ate.align;
    if (!truth.landmarks.empty() && map) {
      const eval::MapError map_error = eval::map_rmse(*map, truth.landmarks, ate.align);
      m.map_rmse_m = map_error.rmse;
      m.map_landmarks_paired = map_error.paired;
      if (m.map_rmse_m) m.map_alignment = "trajectory";
    }
  }
  const auto dr_pairs = match(run.dead_reckoning);
  if (dr_pairs.size() >= 2) {
    const eval::AteResult dr = eval::absolute_trajectory_error(dr_pairs);
    m.dead_reckoning_ate_rmse_m = dr.rmse;
    m.dead_reckoning_final_position_error_m = dr.final_error;
    m.dead_reckoning_alignment = dr.align;
  }
  if (truth.poses_have_heading) {
    // Only where the estimate has a sample at the truth time: an interpolated covariance would be a
    // guess, and NEES is about the filter's own claims. So it does not depend on the time matching.
    std::vector<double> nees;
    const auto exact_pairs = eval::match_by_time(run.filtered, truth.poses, options.max_interpolation_gap_s);
    nees.reserve(exact_pairs.size());
    double squares = 0.0;
    for (const auto& pair : exact_pairs) squares += (pair.estimate.head<2>() - pair.truth.head<2>()).squaredNorm();
    if (!exact_pairs.empty())
      m.unaligned_position_rmse_m = std::sqrt(squares / static_cast<double>(exact_pairs.size()));
    for (const auto& pair : exact_pairs) {
      const auto i = static_cast<std::size_t>(pair.estimate_index);
      if (run.filtered[i].t != pair.t) continue;
      const double value = eval::pose_nees(run.filtered[i].pose, run.pose_covariances[i], pair.truth);
      // The first samples are usually the exactly known start pose, whose covariance is zero.
      if (!std::isfinite(value)) continue;
      nees.push_back(value);
      m.nees_pose_series.emplace_back(pair.t, value);
    }
    if (!nees.empty()) m.nees_pose = eval::summarize_nees(nees, 3, 0.95);
  }
  return m;
}

bool pose_nees_of_particle_cloud(const std::string& filter) { return filter.starts_with("fastslam"); }

nlohmann::json to_json(const Metrics& m) {
  nlohmann::json j = {
      {"slamkit_version", version()},
      {"filter", m.filter},
      {"dataset", m.dataset},
      {"steps", m.steps},
      {"scans", m.scans},
      {"observations", m.observations},
      {"landmarks", m.landmarks},
      {"wall_time_s", m.wall_time_s},
      {"matched_poses", m.matched_poses},
      {"ate_rmse_m", optional_json(m.ate_rmse_m)},
      {"unaligned_position_rmse_m", optional_json(m.unaligned_position_rmse_m)},
      {"final_position_error_m", optional_json(m.final_position_error_m)},
      {"dead_reckoning_ate_rmse_m", optional_json(m.dead_reckoning_ate_rmse_m)},
      {"dead_reckoning_final_position_error_m", optional_json(m.dead_reckoning_final_position_error_m)},
      {"map_rmse_m", optional_json(m.map_rmse_m)},
      {"map_landmarks_paired", m.map_landmarks_paired},
      {"map_alignment", m.map_alignment.empty() ? nlohmann::json(nullptr) : nlohmann::json(m.map_alignment)},
      {"time_matching", m.time_matching},
      {"alignment", {{"theta_rad", m.alignment.theta},
                     {"tx_m", m.alignment.translation.x()},
                     {"ty_m", m.alignment.translation.y()}}},
  };
  if (m.time_matching == "evo") j["time_matching_max_difference_s"] = m.max_time_difference_s;
  if (m.nees_pose) {
    j["nees_pose_mean"] = m.nees_pose->mean;
    j["nees_pose_in_95_fraction"] = m.nees_pose->in_interval_fraction;
    j["nees_pose_95_interval"] = {m.nees_pose->interval.lo, m.nees_pose->interval.hi};
    j["nees_pose_steps"] = m.nees_pose->steps;
  } else {
    j["nees_pose_mean"] = nullptr;
    j["nees_pose_in_95_fraction"] = nullptr;
  }
  if (m.smoothed) j["smoothed_ate_rmse_m"] = optional_json(m.smoothed_ate_rmse_m);
  if (const std::optional<eval::RelativePoseError>& r = m.relative_error) {
    j["relative_translation_error_m"] = r->translation_mean_m;
    j["relative_translation_error_std_m"] = r->translation_std_m;
    j["relative_rotation_error_deg"] = rad2deg(r->rotation_mean_rad);
    j["relative_rotation_error_std_deg"] = rad2deg(r->rotation_std_rad);
    j["relative_error_pairs"] = r->pairs;
  }
  if (m.grid_map_agreement) {
    j["grid_map_precision"] = optional_json(m.grid_map_precision);
    j["grid_map_recall"] = optional_json(m.grid_map_recall);
    j["grid_map_agreement"] = optional_json(m.grid_map_agreement);
  }
  // By the filter, not by the smoothed trajectory, which a run without full history does not keep.
  if (pose_nees_of_particle_cloud(m.filter)) j["nees_pose_note"] = std::string(kParticleCloudNeesNote);
  j["history"] = m.history;
  if (m.history == "none")
    j["history_note"] =
        "run with --history none: only the start and the final estimate were kept, so the trajectory metrics "
        "(ATE, NEES, map RMSE after alignment) are not computed; rerun with --history full or decimated";
  j["association"] = m.association_method;
  if (m.association) {
    const AssociationMetrics& a = *m.association;
    j["association_correct"] = a.correct;
    j["association_wrong"] = a.wrong;
    j["association_missed"] = a.missed;
    j["clutter_observations"] = a.clutter_observations;
    j["clutter_discarded"] = a.clutter_discarded;
    j["spurious_landmarks"] = a.spurious_landmarks;
    j["landmarks_true_seen"] = a.landmarks_true_seen;
    j["loop_closure_fraction"] = optional_json(a.loop_closure_fraction());
    j["loop_closure_observations"] = a.return_observations;
    j["loop_closed"] = a.loop_closure_fraction() ? nlohmann::json(*a.loop_closure_fraction() >= kLoopClosedFraction)
                                                 : nlohmann::json(nullptr);
  }
  for (const auto& [key, value] : m.filter_statistics) j[key] = value;
  j["metric_definitions"] = {
      {"ate_rmse_m",
       "position RMSE of the per-step (filtered) estimates over time-matched truth samples after SE(2) "
       "least-squares alignment"},
      {"time_matching",
       "interpolate: the estimate interpolated at every truth time inside its span; evo: as evo pairs them, each "
       "sample of the shorter trajectory with the other's nearest sample at most time_matching_max_difference_s "
       "away, nothing interpolated"},
      {"smoothed_ate_rmse_m", "the same for the smoothed trajectory (FastSLAM: the final best particle's path)"},
      {"unaligned_position_rmse_m",
       "the same without the alignment, where the truth has headings: its frame is the map's, the start pose "
       "being known in it (as for pose NEES)"},
      {"history",
       "what the run kept (--history): full, decimated (trajectory metrics over at most 10,000 evenly spread "
       "samples) or none (no trajectory metrics)"},
      {"final_position_error_m", "position error at the last matched truth sample, same alignment"},
      {"map_rmse_m", "landmark position RMSE over landmarks paired with the truth, after map_alignment"},
      {"relative_translation_error_m",
       fmt::format("Kuemmerle et al. 2009's relative error of the trajectory written (smoothed where there is one): "
                   "for consecutive pose pairs along the truth ({:g} m or {:g} rad apart), the mean translation "
                   "(and relative_rotation_error_deg, rotation) of the estimate's motion between them relative to "
                   "the truth's; no alignment",
                   eval::kRelativePairDistance, eval::kRelativePairRotation)},
      {"grid_map_precision",
       "occupancy grid runs: share of the map's occupied cells within a cell of an occupied cell of the map the "
       "dataset's scans draw from the true poses (doubled walls lower it); grid_map_recall the converse; "
       "grid_map_agreement the share of cells observed in both that agree (occupied, free or unknown)"},
      {"map_alignment",
       "trajectory: the trajectory's alignment; landmarks: with no trajectory truth, the SE(2) least-squares "
       "alignment of the paired landmarks onto the true ones (the map's shape only)"},
      {"nees_pose_in_95_fraction",
       "share of steps whose pose NEES (3 dof, unaligned) lies in the two-sided 95% chi-square interval"},
      {"association_correct", "pairings whose observation's true landmark started the landmark it updated"},
      {"association_wrong", "pairings of an observation with a landmark another true landmark (or clutter) started"},
      {"association_missed", "observations of an already mapped true landmark left unpaired or starting a duplicate"},
      {"spurious_landmarks", "final-map landmarks started by clutter or duplicating another landmark"},
      {"loop_closure_fraction",
       fmt::format("share of returns (observations of a true landmark unobserved for more than {:g} s, and the "
                   "observations of it that follow) paired with a landmark that true landmark started before its "
                   "return; loop_closed when at least {:g}",
                   m.revisit_gap_s, kLoopClosedFraction)}};
  return j;
}

std::optional<double> AssociationMetrics::loop_closure_fraction() const {
  if (return_observations == 0) return std::nullopt;
  return static_cast<double>(return_observations_closed) / static_cast<double>(return_observations);
}

void write_metrics(const std::string& dir, const Metrics& metrics) {
  const std::string path = (std::filesystem::path(dir) / "metrics.json").string();
  write_file_atomically(path, to_json(metrics).dump(2) + "\n");
}

std::string headline(const Metrics& m) {
  std::string s;
  auto add = [&s](const std::string& part) { s += (s.empty() ? "" : " | ") + part; };
  if (m.ate_rmse_m) {
    std::string ate = fmt::format("ATE RMSE {:.3g} m", *m.ate_rmse_m);
    if (m.dead_reckoning_ate_rmse_m) ate += fmt::format(" (dead reckoning {:.3g} m)", *m.dead_reckoning_ate_rmse_m);
    if (m.time_matching == "evo") ate += fmt::format(" [evo's time matching, within {:g} s]", m.max_time_difference_s);
    add(ate);
  }
  if (m.history == "none") add("no trajectory metrics (--history none kept only the start and the end)");
  if (m.map_rmse_m && m.map_alignment == "landmarks")
    add(fmt::format("map RMSE {:.3g} m (aligned on its {} paired landmarks: no trajectory truth)", *m.map_rmse_m,
                    m.map_landmarks_paired));
  else if (m.map_rmse_m)
    add(fmt::format("map RMSE {:.3g} m", *m.map_rmse_m));
  if (m.grid_map_agreement && m.relative_error)
    add(fmt::format("relative error {:.3g} m, {:.2g} deg", m.relative_error->translation_mean_m,
                    rad2deg(m.relative_error->rotation_mean_rad)));
  if (m.grid_map_precision && m.grid_map_recall)
    add(fmt::format("grid map precision {:.0f}%, recall {:.0f}%", 100.0 * *m.grid_map_precision,
                    100.0 * *m.grid_map_recall));
  if (m.association && m.association_method != "known")
    add(fmt::format("{} association: {} correct, {} wrong", m.association_method, m.association->correct,
                    m.association->wrong));
  if (m.nees_pose && pose_nees_of_particle_cloud(m.filter))
    add(fmt::format("pose NEES in 95% bounds {:.0f}% of steps (of the particle cloud, which resampling "
                    "collapses; judge accuracy by the ATE)",
                    100.0 * m.nees_pose->in_interval_fraction));
  else if (m.nees_pose)
    add(fmt::format("pose NEES in 95% bounds {:.0f}% of steps", 100.0 * m.nees_pose->in_interval_fraction));
  add(fmt::format("{} landmarks", m.landmarks));
  add(fmt::format("{:.3g} s", m.wall_time_s));
  return s;
}

}  // namespace slamkit
