// Dataset specs: their form is checked before any file is read (a usage error naming what was
// expected), MRCLAM's robot is taken as DIR:robotN, DIR:N or DIR/RobotN and Plaza's run as
// DIR:PlazaN, and recorded specs name the robot and the run.
#include "slamkit/io/load_dataset.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>

#include "slamkit/core/error.hpp"
#include "slamkit/io/mrclam.hpp"
#include "slamkit/io/plaza.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

std::string spec_error(const std::string& spec) {
  try {
    check_dataset_spec(spec);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no error";
}

TEST(DatasetSpec, KnownFormsPassWithoutTouchingTheFileSystem) {
  for (const char* spec : {"sim:/nowhere", "victoria-park:/nowhere", "victoria-park", "course:/nowhere",
                           "mrclam:/nowhere", "mrclam:/nowhere:robot3", "mrclam:/nowhere:Robot3", "mrclam:/nowhere:3",
                           "mrclam:/nowhere/Robot5", "mrclam", "plaza:/nowhere", "plaza:/nowhere:Plaza1",
                           "plaza:/nowhere:plaza2", "plaza:", "plaza"})
    EXPECT_EQ(spec_error(spec), "no error") << spec;
}

TEST(DatasetSpec, AMisspeltKindIsAnsweredWithTheNearest) {
  const std::string kinds = "sim, victoria-park, mrclam, course, plaza, carmen, scenario, family, building";
  EXPECT_EQ(spec_error("victoria_park:/x"),
            "unknown dataset kind 'victoria_park' (did you mean 'victoria-park'?); expected one of: " + kinds);
  EXPECT_EQ(spec_error("tape:/x"), "unknown dataset kind 'tape'; expected one of: " + kinds);
  EXPECT_EQ(spec_error("/data/log"),
            "'/data/log' is not a dataset spec; expected KIND:PATH with KIND one of: " + kinds);
  EXPECT_EQ(spec_error("mrclm"), "'mrclm' is not a dataset spec; expected KIND:PATH with KIND one of: " + kinds +
                                     " (did you mean 'mrclam'?)");
  EXPECT_EQ(spec_error("plaz:/x"), "unknown dataset kind 'plaz' (did you mean 'plaza'?); expected one of: " + kinds);
  EXPECT_EQ(spec_error("carmn:/x"), "unknown dataset kind 'carmn' (did you mean 'carmen'?); expected one of: " + kinds);
  EXPECT_EQ(spec_error("sim:"), "expected a path after 'sim:'");
  for (const char* spec : {"sim::x", "victoria-park::x", "scenario::3"})
    EXPECT_NE(spec_error(spec).find("which only mrclam and plaza have"), std::string::npos) << spec_error(spec);
}

TEST(DatasetSpec, SimulatedDatasetsAreNamedByScenarioAndSeeds) {
  for (const char* spec : {"scenario:default", "scenario:default:3", "scenario:city:0", "family:sparse:2",
                           "family:dense-cluttered:2:5", "building:office", "building:corridors:4"})
    EXPECT_EQ(spec_error(spec), "no error") << spec;
  EXPECT_NE(spec_error("scenario:defalt:3").find("unknown scenario 'defalt' (did you mean 'default'?)"),
            std::string::npos);
  EXPECT_NE(spec_error("family:sparse").find("expected family:NAME:WORLD_SEED[:SEED]"), std::string::npos);
  EXPECT_NE(spec_error("scenario:default:x").find("expected the noise seed as a whole number"), std::string::npos);
  EXPECT_NE(spec_error("scenario:default:1:2").find("expected scenario:NAME[:SEED]"), std::string::npos);
  EXPECT_EQ(spec_error("building:offce"), "unknown building 'offce' (did you mean 'office'?); expected one of: office, "
                                          "corridors, ring");
}

/// Every event and every piece of truth the same, to the bit.
void expect_same_data(const Dataset& a, const Dataset& b) {
  ASSERT_EQ(a.events.size(), b.events.size());
  for (std::size_t i = 0; i < a.events.size(); ++i) {
    ASSERT_EQ(a.events[i].index(), b.events[i].index()) << "event " << i;
    if (const auto* c = std::get_if<ControlEvent>(&a.events[i])) {
      const auto& d = std::get<ControlEvent>(b.events[i]);
      ASSERT_TRUE(c->t == d.t && c->dt == d.dt && c->u == d.u) << "control " << i;
      continue;
    }
    const auto& s = std::get<ScanEvent>(a.events[i]);
    const auto& r = std::get<ScanEvent>(b.events[i]);
    ASSERT_EQ(s.t, r.t) << "scan " << i;
    ASSERT_EQ(s.observations.size(), r.observations.size()) << "scan " << i;
    for (std::size_t k = 0; k < s.observations.size(); ++k) {
      ASSERT_EQ(s.observations[k].z, r.observations[k].z) << "scan " << i;
      ASSERT_EQ(s.observations[k].id, r.observations[k].id) << "scan " << i;
    }
  }
  ASSERT_EQ(a.truth.poses.size(), b.truth.poses.size());
  for (std::size_t i = 0; i < a.truth.poses.size(); ++i) {
    ASSERT_EQ(a.truth.poses[i].t, b.truth.poses[i].t);
    ASSERT_EQ(a.truth.poses[i].pose, b.truth.poses[i].pose);
  }
  ASSERT_EQ(a.truth.landmarks.size(), b.truth.landmarks.size());
  for (std::size_t i = 0; i < a.truth.landmarks.size(); ++i) {
    ASSERT_EQ(a.truth.landmarks[i].id, b.truth.landmarks[i].id);
    ASSERT_EQ(a.truth.landmarks[i].position, b.truth.landmarks[i].position);
  }
  EXPECT_EQ(a.truth.observation_ids, b.truth.observation_ids);
  EXPECT_EQ(a.initial_pose, b.initial_pose);
}

// A campaign's in-memory dataset and the log `slamkit simulate` writes are the same data, so the
// tables made from logs come back from campaigns to the last digit: on a cluttered world with
// withheld identities, with each sensor, and on a world of a family.
TEST(SimulatedDataset, IsItsLogToTheBit) {
  const test_data::ScratchDir dir;
  for (const auto& [name, sensor] : {std::pair{"sparse-cluttered", SensorKind::kRangeBearing},
                                      std::pair{"default", SensorKind::kRangeOnly},
                                      std::pair{"default", SensorKind::kBearingOnly}}) {
    const Scenario s = scenario(name);
    SimulatorConfig config = s.config;
    config.seed = 7;
    config.sensor = sensor;
    const Dataset simulated = simulate(s.world, config);
    const std::string log = dir.file(std::string(name) + "-" + to_string(sensor));
    write_sim_log(log, simulated, config, s.world);
    SCOPED_TRACE(log);
    expect_same_data(as_logged(simulated), read_sim_log(log));
  }
  expect_same_data(load_dataset("family:sparse:104"), [&] {
    const Scenario s = world_family("sparse").member(104);
    SimulatorConfig config = s.config;
    config.seed = 1;
    write_sim_log(dir.file("family"), simulate(s.world, config), config, s.world);
    return read_sim_log(dir.file("family"));
  }());
}

TEST(SimulatedDataset, IsTheSimulatorsOutputForItsSeedAndSettings) {
  SimulatorConfig config = scenario("loop-closure").config;
  config.seed = 4;
  const Dataset direct = as_logged(simulate(scenario("loop-closure").world, config));
  const Dataset named = load_dataset("scenario:loop-closure:4");
  ASSERT_EQ(named.events.size(), direct.events.size());
  EXPECT_EQ(named.truth.poses.back().pose, direct.truth.poses.back().pose);

  config.clutter_rate = 2.0;
  const Dataset cluttered =
      load_dataset("scenario:loop-closure:4", nlohmann::json{{"clutter_rate_per_scan", 2.0}}, "mine.json");
  const Dataset direct_cluttered = as_logged(simulate(scenario("loop-closure").world, config));
  std::size_t observations = 0, direct_observations = 0, clean_observations = 0;
  for (std::size_t i = 0; i < cluttered.events.size(); ++i)
    if (const auto* scan = std::get_if<ScanEvent>(&cluttered.events[i])) {
      observations += scan->observations.size();
      direct_observations += std::get<ScanEvent>(direct_cluttered.events[i]).observations.size();
      clean_observations += std::get<ScanEvent>(named.events[i]).observations.size();
    }
  EXPECT_EQ(observations, direct_observations);
  for (std::size_t i = 0; i < named.events.size(); ++i)
    if (const auto* scan = std::get_if<ScanEvent>(&named.events[i]))
      ASSERT_EQ(scan->observations.front().z, std::get<ScanEvent>(direct.events[i]).observations.front().z);
  EXPECT_GT(observations, clean_observations) << "the settings' clutter is simulated";
  try {
    load_dataset("scenario:loop-closure:4", nlohmann::json{{"seed", 5}}, "mine.json");
    ADD_FAILURE() << "a second seed in the settings";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mine.json"), std::string::npos) << e.what();
  }
  EXPECT_EQ(absolute_dataset_spec("family:sparse:3:1"), "family:sparse:3:1");
}

TEST(DatasetSpec, AnMrclamRobotOutsideOneToFiveOrWithoutANumberNamesTheValidOnes) {
  for (const char* spec : {"mrclam:/d:robot", "mrclam:/d:", "mrclam:/d:robot6", "mrclam:/d:0", "mrclam:/d:7",
                           "mrclam:/d:robotx", "mrclam:/d:rbot3", "mrclam:/d/Robot6", "mrclam:/d/Robot"}) {
    const std::string message = spec_error(spec);
    EXPECT_NE(message.find("1 to 5"), std::string::npos) << spec << ": " << message;
  }
  EXPECT_EQ(spec_error("mrclam:/d:robot"),
            "no robot number in 'robot'; expected a robot from 1 to 5 as DIR:robotN, DIR:N or DIR/RobotN");
  // load_dataset reports the same as bad input naming the spec (a spec in a run.json is data).
  try {
    load_dataset("mrclam:/d:9");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "mrclam:/d:9: no MRCLAM robot '9'; expected a robot from 1 to 5 as DIR:robotN, DIR:N or DIR/RobotN");
  }
}

TEST(DatasetSpec, RecordedMrclamSpecsNameTheRobot) {
  const std::string dir = std::filesystem::absolute("/data/MRCLAM_Dataset6").string();
  for (const char* spec : {"mrclam:/data/MRCLAM_Dataset6:3", "mrclam:/data/MRCLAM_Dataset6:robot3",
                           "mrclam:/data/MRCLAM_Dataset6:ROBOT3", "mrclam:/data/MRCLAM_Dataset6/Robot3"})
    EXPECT_EQ(absolute_dataset_spec(spec), "mrclam:" + dir + ":robot3") << spec;
  EXPECT_EQ(absolute_dataset_spec("mrclam:/data/MRCLAM_Dataset6"), "mrclam:" + dir + ":robot1");
}

TEST(DatasetSpec, EveryFormOfAnMrclamRobotReadsThatRobot) {
  const auto dir = test_data::shared_dataset("mrclam/MRCLAM_Dataset6");
  SLAMKIT_REQUIRE_DATASET(dir);
  const Dataset reference = read_mrclam(dir.string(), 3);
  for (const std::string suffix : {":3", ":robot3", "/Robot3"}) {
    const Dataset d = load_dataset("mrclam:" + dir.string() + suffix);
    EXPECT_EQ(d.name, reference.name) << suffix;
    EXPECT_EQ(d.events.size(), reference.events.size()) << suffix;
  }
  // "mrclam::robot3": robot 3 of the datasets folder's Dataset6, as campaign files name it.
  const test_data::ScopedEnvironment data("SLAMKIT_DATA", dir.parent_path().parent_path().string());
  const Dataset chosen = load_dataset("mrclam::robot3");
  EXPECT_EQ(absolute_dataset_spec("mrclam::robot3"),
            "mrclam:" + std::filesystem::absolute(dir).lexically_normal().string() + ":robot3");
  EXPECT_EQ(spec_error("mrclam::robot9"),
            "no MRCLAM robot 'robot9'; expected a robot from 1 to 5 as DIR:robotN, DIR:N or DIR/RobotN");
  EXPECT_EQ(chosen.name, reference.name);
  EXPECT_EQ(chosen.events.size(), reference.events.size());
}

TEST(DatasetSpec, APlazaRunOfAnotherFormNamesTheValidForm) {
  for (const char* spec : {"plaza:/d:", "plaza:/d:Plaza", "plaza:/d:Plaza0", "plaza:/d:Plaza01", "plaza:/d:Plaza1x",
                           "plaza:/d:Gesling1", "plaza:/d:robot1", "plaza:/d:1"}) {
    const std::string message = spec_error(spec);
    EXPECT_NE(message.find("expected a run as DIR:PlazaN"), std::string::npos) << spec << ": " << message;
  }
  EXPECT_EQ(spec_error("plaza:/d:Plaza0"),
            "no Plaza run 'Plaza0'; expected a run as DIR:PlazaN with N a whole number from 1 (a bare DIR is Plaza1)");
  try {
    load_dataset("plaza:/d:Gesling1");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "plaza:/d:Gesling1: no Plaza run 'Gesling1'; expected a run as DIR:PlazaN with N a whole number from 1 "
              "(a bare DIR is Plaza1)");
  }
}

TEST(DatasetSpec, RecordedPlazaSpecsNameTheRun) {
  const std::string dir = std::filesystem::absolute("/data/plaza_range_only").string();
  EXPECT_EQ(absolute_dataset_spec("plaza:/data/plaza_range_only"), "plaza:" + dir + ":Plaza1");
  EXPECT_EQ(absolute_dataset_spec("plaza:/data/plaza_range_only:PLAZA2"), "plaza:" + dir + ":Plaza2");
}

TEST(DatasetSpec, EveryFormOfAPlazaRunReadsThatRunWithItsSettings) {
  const auto dir = test_data::shared_dataset("plaza_range_only");
  SLAMKIT_REQUIRE_DATASET(dir);
  const Dataset reference = read_plaza(dir.string());
  for (const std::string suffix : {"", ":Plaza1", ":plaza1"}) {
    const Dataset d = load_dataset("plaza:" + dir.string() + suffix);
    EXPECT_EQ(d.spec, "plaza:" + dir.string() + suffix);
    EXPECT_EQ(d.name, reference.name) << suffix;
    EXPECT_EQ(d.events.size(), reference.events.size()) << suffix;
  }
  {
    const test_data::ScopedEnvironment data("SLAMKIT_DATA", dir.parent_path().string());
    EXPECT_EQ(load_dataset("plaza::Plaza1").events.size(), reference.events.size());
  }
  const Dataset tuned = load_dataset("plaza:" + dir.string(), nlohmann::json{{"sigma_range_m", 0.5}}, "tuned.json");
  EXPECT_EQ(tuned.observation->noise()(0, 0), 0.25);
  try {
    load_dataset("plaza:" + dir.string(), nlohmann::json{{"sigma_bearing_deg", 1.0}}, "tuned.json");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tuned.json: unknown key 'sigma_bearing_deg' in the Plaza options"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace slamkit
