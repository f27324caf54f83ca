#include <stdexcept>

#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/filters/fastslam.hpp"

namespace slamkit {

std::vector<std::string> filter_names() { return {"ekf", "fastslam1", "fastslam2"}; }

namespace {

EkfVariant parse_ekf_variant(const std::string& name) {
  if (name == "full") return EkfVariant::kFull;
  if (name == "compressed") return EkfVariant::kCompressed;
  throw std::invalid_argument("unknown EKF variant '" + name + "'; expected one of: full, compressed");
}

}  // namespace

std::unique_ptr<SlamFilter> make_filter(const FilterConfig& config, const Dataset& dataset) {
  if (config.name == "ekf") {
    EkfSlamOptions options;
    options.initial_pose = dataset.initial_pose;
    options.association = config.association;
    options.sensor = dataset.sensor;
    options.variant = parse_ekf_variant(config.ekf_variant);
    if (config.ekf_update != "sequential" && config.ekf_update != "joint")
      throw std::invalid_argument("unknown EKF update '" + config.ekf_update + "'; expected one of: sequential, joint");
    // The compressed variant works on a local state one observation at a time; it equals the full
    // EKF with sequential updates.
    options.joint_scan_update = config.ekf_update == "joint" && options.variant == EkfVariant::kFull;
    return std::make_unique<EkfSlam>(dataset.motion, dataset.observation, options);
  }
  if (config.name == "fastslam1" || config.name == "fastslam2") {
    FastSlamConfig fs;
    fs.version = config.name == "fastslam1" ? 1 : 2;
    fs.particles = config.particles;
    fs.resample = parse_resample_method(config.resample);
    fs.policy = parse_resample_policy(config.resample_when);
    fs.association = config.association;
    fs.seed = config.seed;
    fs.threads = config.threads;
    fs.initial_pose = dataset.initial_pose;
    fs.sensor = dataset.sensor;
    return std::make_unique<FastSlam>(dataset.motion, dataset.observation, fs);
  }
  std::string names;
  for (const auto& n : filter_names()) names += (names.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown filter '" + config.name + "'; expected one of: " + names);
}

}  // namespace slamkit
