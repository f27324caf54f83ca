#include <stdexcept>

#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/filters/factory.hpp"

namespace slamkit {

std::vector<std::string> filter_names() { return {"ekf"}; }

std::unique_ptr<SlamFilter> make_filter(const FilterConfig& config, const Dataset& dataset) {
  if (config.name == "ekf") {
    EkfSlamOptions options;
    options.initial_pose = dataset.initial_pose;
    options.association = config.association;
    options.sensor = dataset.sensor;
    return std::make_unique<EkfSlam>(dataset.motion, dataset.observation, options);
  }
  std::string names;
  for (const auto& n : filter_names()) names += (names.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown filter '" + config.name + "'; expected one of: " + names);
}

}  // namespace slamkit
