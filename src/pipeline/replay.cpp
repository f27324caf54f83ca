#include "slamkit/pipeline/replay.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <Eigen/Geometry>
#include <optional>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/base64.hpp"
#include "slamkit/grid/map_files.hpp"
#include "slamkit/models/observation_model.hpp"

namespace slamkit {

namespace {

/// Millimetre (milliradian) precision is plenty for a picture and keeps the page small.
double rounded(double v) { return std::round(v * 1000.0) / 1000.0; }
/// Covariances span many magnitudes; four significant digits draw the same ellipse.
double significant(double v) { return std::stod(fmt::format("{:.4g}", v)); }

/// What every frame starts with: its time, the pose and the pose covariance (xx, xy, yy, theta theta).
nlohmann::json frame_head(double t, const Pose2& pose, const Matrix3& cov) {
  return {{"t", rounded(t)},
          {"pose", {rounded(pose.x()), rounded(pose.y()), rounded(pose.z())}},
          {"cov", {significant(cov(0, 0)), significant(cov(0, 1)), significant(cov(1, 1)), significant(cov(2, 2))}}};
}

/// Truth samples further apart than this are not interpolated between (as in the evaluation): a
/// GPS gap of a minute hides tens of metres of driving.
constexpr double kMaxTruthGapS = 1.0;

/// The truth pose at `t`, linearly interpolated (heading along the shorter arc); none outside the
/// truth's time span or inside a gap.
std::optional<Pose2> truth_at(const std::vector<StampedPose>& truth, double t) {
  if (truth.empty() || t < truth.front().t || t > truth.back().t) return std::nullopt;
  const auto after = std::lower_bound(truth.begin(), truth.end(), t,
                                      [](const StampedPose& p, double time) { return p.t < time; });
  if (after == truth.begin() || after->t == t) return after->pose;
  const StampedPose& before = *(after - 1);
  if (after->t - before.t > kMaxTruthGapS) return std::nullopt;
  const double f = (t - before.t) / (after->t - before.t);
  Pose2 pose = before.pose + f * (after->pose - before.pose);
  pose.z() = wrap_angle(before.pose.z() + f * wrap_angle(after->pose.z() - before.pose.z()));
  return pose;
}

}  // namespace

ReplayRecorder::ReplayRecorder(const Dataset& dataset, ReplayOptions options, bool range_scans)
    : dataset_(dataset), options_(options) {
  for (const Event& e : dataset.events)
    scans_total_ += range_scans ? std::holds_alternative<RangeScanEvent>(e) : std::holds_alternative<ScanEvent>(e);
  stride_ = std::max<std::size_t>(1, (scans_total_ + options_.max_frames - 1) / std::max<std::size_t>(1, options_.max_frames));
  const std::size_t frames = (scans_total_ + stride_ - 1) / stride_;
  grid_frame_stride_ = std::max<std::size_t>(
      1, (frames + options_.max_grid_images - 1) / std::max<std::size_t>(1, options_.max_grid_images));
}

void ReplayRecorder::on_range_scan(const SlamFilter& filter, const RangeScanEvent& scan, std::size_t, std::size_t) {
  const std::size_t k = scan_index_++;
  const bool last = k + 1 == scans_total_;
  if (k % stride_ != 0 && !last) return;

  const Pose2 pose = filter.pose();
  nlohmann::json frame = frame_head(scan.t, pose, filter.pose_covariance());
  frame["landmarks"] = nlohmann::json::array();
  frame["rays"] = nlohmann::json::array();
  nlohmann::json& ends = frame["beam_ends"] = nlohmann::json::array();
  const Pose2 sensor = sensor_pose(pose, scan.sensor_offset);
  const std::size_t step = std::max<std::size_t>(1, (scan.ranges.size() + options_.max_beam_ends - 1) /
                                                        std::max<std::size_t>(1, options_.max_beam_ends));
  for (std::size_t b = 0; b < scan.ranges.size(); b += step) {
    const double range = scan.ranges[b];
    if (!(std::isfinite(range) && range > 0.0 && range < scan.max_range)) continue;
    const double angle = sensor.z() + scan.bearing(b);
    for (double v : {rounded(sensor.x() + range * std::cos(angle)), rounded(sensor.y() + range * std::sin(angle))})
      ends.push_back(v);
  }
  if (frames_.size() % grid_frame_stride_ == 0 || last) {
    const GridImage image = grid_png(filter.grid_map(), options_.grid_image_side);
    frame["grid"] = {{"png", base64(image.png)},
                     {"x", rounded(image.origin_x)},
                     {"y", rounded(image.origin_y)},
                     {"w", rounded(image.width_m)},
                     {"h", rounded(image.height_m)}};
  }
  keep_frame(filter, scan.t, pose, std::move(frame));
}

void ReplayRecorder::on_scan(const SlamFilter& filter, const ScanEvent& scan, std::size_t, std::size_t) {
  const std::size_t k = scan_index_++;
  const std::vector<AssociationRecord>& records = filter.last_associations();
  const std::vector<int>* true_ids =
      k < dataset_.truth.observation_ids.size() ? &dataset_.truth.observation_ids[k] : nullptr;
  // Origins are tracked on every scan, drawn or not, so a later frame can tell a wrong update.
  std::vector<bool> wrong(records.size(), false);
  if (true_ids != nullptr && true_ids->size() == records.size()) {
    for (std::size_t i = 0; i < records.size(); ++i) {
      if (records[i].decision == AssociationDecision::kNew) origin_[records[i].landmark_id] = (*true_ids)[i];
      if (records[i].decision == AssociationDecision::kUpdate) {
        const auto origin = origin_.find(records[i].landmark_id);
        wrong[i] = origin != origin_.end() && origin->second != (*true_ids)[i];
      }
    }
  }
  if (k % stride_ != 0 && k + 1 != scans_total_) return;

  const Pose2 pose = filter.pose();
  nlohmann::json frame = frame_head(scan.t, pose, filter.pose_covariance());
  nlohmann::json& landmarks = frame["landmarks"] = nlohmann::json::array();
  for (const Landmark& lm : filter.landmarks())
    for (double v : {double(lm.id), rounded(lm.position.x()), rounded(lm.position.y()),
                     significant(lm.covariance(0, 0)), significant(lm.covariance(0, 1)),
                     significant(lm.covariance(1, 1))})
      landmarks.push_back(v);
  nlohmann::json& rays = frame["rays"] = nlohmann::json::array();
  nlohmann::json rings = nlohmann::json::array();
  for (std::size_t i = 0; i < scan.observations.size() && i < records.size(); ++i) {
    const MeasurementShape shape = dataset_.observation->shape(pose, scan.observations[i].z, dataset_.sensor.max_range);
    // The page's codes: update, new, discard, wrong pairing, pending.
    const int decision = wrong[i] ? 3 : records[i].decision == AssociationDecision::kPending ? 4
                                                                                           : static_cast<int>(records[i].decision);
    if (shape.radius > 0.0)
      for (double v : {rounded(shape.sensor.x()), rounded(shape.sensor.y()), rounded(shape.radius), double(decision)})
        rings.push_back(v);
    else
      for (double v : {rounded(shape.end.x()), rounded(shape.end.y()), double(decision)}) rays.push_back(v);
  }
  if (!rings.empty()) frame["rings"] = std::move(rings);
  const std::vector<LandmarkHypothesis> hypotheses = filter.landmark_hypotheses();
  if (!hypotheses.empty()) {
    nlohmann::json& held = frame["hypotheses"] = nlohmann::json::array();
    for (const LandmarkHypothesis& h : hypotheses) {
      const Landmark& lm = h.landmark;
      for (double v : {double(lm.id), rounded(lm.position.x()), rounded(lm.position.y()),
                       significant(lm.covariance(0, 0)), significant(lm.covariance(0, 1)),
                       significant(lm.covariance(1, 1)), significant(h.weight)})
        held.push_back(v);
    }
  }
  keep_frame(filter, scan.t, pose, std::move(frame));
}

void ReplayRecorder::keep_frame(const SlamFilter& filter, double t, const Pose2& pose, nlohmann::json frame) {
  const std::vector<WeightedPose> samples = filter.pose_samples();
  if (!samples.empty()) {
    nlohmann::json& particles = frame["particles"] = nlohmann::json::array();
    const std::size_t step = std::max<std::size_t>(1, samples.size() / options_.max_particles);
    for (std::size_t i = 0; i < samples.size(); i += step)
      for (double v : {rounded(samples[i].pose.x()), rounded(samples[i].pose.y())}) particles.push_back(v);
  }
  frames_.push_back(std::move(frame));
  frame_poses_.push_back({t, pose});
}

nlohmann::json ReplayRecorder::to_json(const std::string& filter_name,
                                       const std::optional<Pose2>& truth_from_estimate) const {
  const Pose2 alignment = truth_from_estimate.value_or(Pose2::Zero());
  const Eigen::Rotation2Dd rotation(alignment.z());
  const Vector2 translation = alignment.head<2>();
  const auto to_estimate_frame = [&](const Vector2& p) -> Vector2 { return rotation.inverse() * (p - translation); };

  nlohmann::json truth = nlohmann::json::array();
  const std::vector<StampedPose>& poses = dataset_.truth.poses;
  // The true path is drawn as one line; a few thousand points are as good as all of them.
  const std::size_t truth_step = std::max<std::size_t>(1, poses.size() / 4000);
  for (std::size_t i = 0; i < poses.size(); i += truth_step) {
    const Vector2 p = to_estimate_frame(poses[i].pose.head<2>());
    truth.push_back({rounded(poses[i].t), rounded(p.x()), rounded(p.y())});
  }
  nlohmann::json true_landmarks = nlohmann::json::array();
  for (const Landmark& lm : dataset_.truth.landmarks) {
    const Vector2 p = to_estimate_frame(lm.position);
    true_landmarks.push_back({rounded(p.x()), rounded(p.y())});
  }
  nlohmann::json frames = frames_;
  for (std::size_t f = 0; f < frame_poses_.size(); ++f) {
    const auto true_pose = truth_at(poses, frame_poses_[f].t);
    if (!true_pose) continue;
    // The error in the estimate's frame, where the filter's covariance (the band) lives.
    const Vector2 position_error = frame_poses_[f].pose.head<2>() - to_estimate_frame(true_pose->head<2>());
    const double heading_error =
        dataset_.truth.poses_have_heading
            ? wrap_angle(frame_poses_[f].pose.z() + alignment.z() - true_pose->z())
            : 0.0;
    frames[f]["error"] = {rounded(position_error.x()), rounded(position_error.y()), rounded(heading_error)};
  }
  const std::string decimation =
      stride_ == 1 ? fmt::format("every scan of {}", scans_total_)
                   : fmt::format("one scan in {} of {} (decimated for smooth playback)", stride_, scans_total_);
  return {{"meta",
           {{"filter", filter_name},
            {"dataset", dataset_.spec},
            {"scans", scans_total_},
            {"stride", stride_},
            {"decimation", decimation},
            {"truth_has_headings", dataset_.truth.poses_have_heading},
            {"error_aligned", truth_from_estimate.has_value()},
            {"wrong_known", !dataset_.truth.observation_ids.empty()}}},
          {"truth", std::move(truth)},
          {"true_landmarks", std::move(true_landmarks)},
          {"frames", std::move(frames)}};
}

}  // namespace slamkit
