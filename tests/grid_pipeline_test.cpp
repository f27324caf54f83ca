// How laser scans travel through the pipeline: the runner gives range scans to the filters that map
// with them and refuses a dataset a filter has nothing to map with; the grid settings are validated
// and round-trip through run.json; a map picture embeds its grid image.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "slamkit/core/error.hpp"
#include "slamkit/gridslam/scan_matching_filter.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/plot/svg_plot.hpp"

using namespace slamkit;

namespace {

RangeScanEvent wall_ahead(double t, double distance) {
  RangeScanEvent scan;
  scan.t = t;
  scan.angle_min = -0.5;
  scan.angle_increment = 0.01;
  scan.max_range = 30.0;
  for (int i = 0; i <= 100; ++i) scan.ranges.push_back(static_cast<float>(distance / std::cos(scan.bearing(i))));
  return scan;
}

Dataset laser_log() {
  Dataset d;
  d.spec = "test:laser";
  d.motion = std::make_shared<OdometryModel>();
  d.events.push_back(wall_ahead(0.0, 5.0));
  d.events.push_back(ControlEvent{1.0, 1.0, Control(Eigen::Vector3d(0.0, 0.5, 0.0))});
  d.events.push_back(wall_ahead(1.0, 4.5));
  return d;
}

}  // namespace

TEST(GridPipeline, TheRunnerGivesRangeScansToTheFilterThatMapsThem) {
  const Dataset d = laser_log();
  ScanMatchingFilter filter(d.motion, d.initial_pose);
  const RunResult run = run_filter(filter, d);
  EXPECT_EQ(run.scans, 2u);
  EXPECT_EQ(run.associations.size(), 2u);  // one empty record per scan, as the run folder expects
  ASSERT_FALSE(run.grid.empty());
  EXPECT_NEAR(run.filtered.back().pose.x(), 0.5, 0.05);
}

TEST(GridPipeline, ADatasetWithNothingTheFilterMapsWithIsRefusedBeforeRunning) {
  Dataset lasers = laser_log();
  EXPECT_THROW(make_filter(FilterConfig{}, lasers), InputError);  // a laser log has no observation model
  lasers.observation = std::make_shared<RangeBearingModel>();
  const std::unique_ptr<SlamFilter> ekf = make_filter(FilterConfig{}, lasers);
  try {
    run_filter(*ekf, lasers);
    FAIL() << "an EKF ran on laser scans alone";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scan-matching or grid-fastslam"), std::string::npos) << e.what();
  }

  Dataset landmarks;
  landmarks.spec = "test:landmarks";
  landmarks.motion = std::make_shared<OdometryModel>();
  landmarks.observation = std::make_shared<RangeBearingModel>();
  landmarks.events.push_back(ScanEvent{0.0, {}});
  ScanMatchingFilter matcher(landmarks.motion, landmarks.initial_pose);
  try {
    run_filter(matcher, landmarks);
    FAIL() << "scan matching ran without laser scans";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("holds none"), std::string::npos) << e.what();
  }
}

// Odometry that jumps 100 km between two scans: the map cannot span both, and the run is refused
// as bad input naming the event, not left to allocate a table for the space between.
TEST(GridPipeline, AScanFarBeyondTheMapsBoundIsBadInputNamingTheEvent) {
  Dataset d = laser_log();
  d.events.push_back(ControlEvent{2.0, 1.0, Control(Eigen::Vector3d(0.0, 1e5, 0.0))});
  d.events.push_back(wall_ahead(2.0, 5.0));
  GridSlamOptions options;
  options.grid.max_cells = 1e6;
  ScanMatchingFilter filter(d.motion, d.initial_pose, options);
  try {
    run_filter(filter, d);
    FAIL() << "a map 100 km wide was accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("test:laser: event 4 (t = 2)"), std::string::npos) << what;
    EXPECT_NE(what.find("raise grid.max_cells"), std::string::npos) << what;
  }
}

TEST(GridPipeline, GridSettingsAreValidatedAndRoundTripThroughRunJson) {
  FilterConfig config;
  config.filter = FilterKind::kGridFastSlam;
  config.grid.grid.resolution = 0.1;
  config.grid.proposal_spread_rad = deg2rad(0.5);
  config.grid.weight_temperature = 30.0;
  const FilterConfig back = filter_config_from_json(to_json(config), "run.json");
  EXPECT_EQ(back.filter, FilterKind::kGridFastSlam);
  EXPECT_DOUBLE_EQ(back.grid.grid.resolution, 0.1);
  EXPECT_DOUBLE_EQ(back.grid.grid.max_cells, 1e8);
  EXPECT_NEAR(back.grid.proposal_spread_rad, deg2rad(0.5), 1e-15);
  EXPECT_DOUBLE_EQ(back.grid.weight_temperature, 30.0);

  nlohmann::json bad = to_json(config);
  bad["grid"]["resolution_m"] = 0.0;
  EXPECT_THROW(filter_config_from_json(bad, "run.json"), InputError);
  bad = to_json(config);
  bad["grid"]["max_cells"] = -1.0;
  EXPECT_THROW(filter_config_from_json(bad, "run.json"), InputError);
  bad = to_json(config);
  bad["grid"]["resolutoin_m"] = 0.1;
  EXPECT_THROW(filter_config_from_json(bad, "run.json"), InputError);
  // Grid settings mean nothing to a landmark filter: a run that names them for one is refused.
  bad = to_json(config);
  bad["filter"] = "ekf";
  try {
    filter_config_from_json(bad, "run.json");
    FAIL() << "grid settings accepted for the EKF";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("grid settings apply"), std::string::npos) << e.what();
  }
}

TEST(GridPipeline, AMapPictureEmbedsItsGridImageUnderTheData) {
  plot::Figure figure;
  figure.add_image("foobar", Vector2(-1.0, -2.0), Vector2(4.0, 3.0));
  const std::vector<Vector2> line = {Vector2(0.0, 0.0), Vector2(1.0, 1.0)};
  figure.add_line(line, {});
  const std::string svg = figure.to_svg();
  const std::size_t image = svg.find("href=\"data:image/png;base64,Zm9vYmFy\"");
  ASSERT_NE(image, std::string::npos);
  EXPECT_LT(image, svg.find("<path", image)) << "the grid is drawn first, under the trajectory";
}
