#include "slamkit/io/sim_log.hpp"

#include <gtest/gtest.h>

#include "test_data.hpp"
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "slamkit/core/error.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"

using slamkit::test_data::write_text;

namespace slamkit {
namespace {

namespace fs = std::filesystem;

using test_data::ScratchDir;

std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

void write_lines(const std::string& path, const std::vector<std::string>& lines) {
  std::ofstream out(path);
  for (const std::string& line : lines) out << line << '\n';
}

// 1-based number of the first line starting with `prefix`.
std::size_t line_starting(const std::string& path, const std::string& prefix) {
  const std::vector<std::string> lines = read_lines(path);
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (lines[i].rfind(prefix, 0) == 0) return i + 1;
  ADD_FAILURE() << "no line starting with '" << prefix << "' in " << path;
  return 0;
}

void replace_line(const std::string& path, std::size_t number, const std::string& text) {
  std::vector<std::string> lines = read_lines(path);
  ASSERT_LE(number, lines.size());
  lines[number - 1] = text;
  write_lines(path, lines);
}

// Runs `action`, requires an InputError at `file`:`line` whose message contains `needle`.
void expect_input_error(const std::function<void()>& action, const std::string& file, std::size_t line,
                        const std::string& needle) {
  try {
    action();
    ADD_FAILURE() << "no error; expected one at " << file << ":" << line << " about '" << needle << "'";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file) << e.what();
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

void expect_close(double a, double b, const char* what) {
  // Twelve significant digits on disk.
  EXPECT_NEAR(a, b, 1e-11 * std::max(1.0, std::abs(b))) << what;
}

void expect_same_dataset(const Dataset& read, const Dataset& written) {
  ASSERT_EQ(read.events.size(), written.events.size());
  for (std::size_t i = 0; i < written.events.size(); ++i) {
    ASSERT_EQ(read.events[i].index(), written.events[i].index()) << "event " << i;
    if (const auto* w = std::get_if<ControlEvent>(&written.events[i])) {
      const auto& r = std::get<ControlEvent>(read.events[i]);
      expect_close(r.t, w->t, "control t");
      expect_close(r.dt, w->dt, "control dt");
      ASSERT_EQ(r.u.size(), 2);
      expect_close(r.u[0], w->u[0], "speed");
      expect_close(r.u[1], w->u[1], "steer");
    } else {
      const auto& ws = std::get<ScanEvent>(written.events[i]);
      const auto& rs = std::get<ScanEvent>(read.events[i]);
      expect_close(rs.t, ws.t, "scan t");
      ASSERT_EQ(rs.observations.size(), ws.observations.size()) << "event " << i;
      for (std::size_t j = 0; j < ws.observations.size(); ++j) {
        EXPECT_EQ(rs.observations[j].id, ws.observations[j].id);
        expect_close(rs.observations[j].z[0], ws.observations[j].z[0], "range");
        expect_close(rs.observations[j].z[1], ws.observations[j].z[1], "bearing");
      }
    }
  }
  ASSERT_EQ(read.truth.poses.size(), written.truth.poses.size());
  for (std::size_t i = 0; i < written.truth.poses.size(); ++i) {
    expect_close(read.truth.poses[i].t, written.truth.poses[i].t, "pose t");
    for (int k = 0; k < 3; ++k)
      expect_close(read.truth.poses[i].pose[k], written.truth.poses[i].pose[k], "pose");
  }
  ASSERT_EQ(read.truth.landmarks.size(), written.truth.landmarks.size());
  for (std::size_t i = 0; i < written.truth.landmarks.size(); ++i) {
    EXPECT_EQ(read.truth.landmarks[i].id, written.truth.landmarks[i].id);
    expect_close(read.truth.landmarks[i].position.x(), written.truth.landmarks[i].position.x(), "landmark x");
    expect_close(read.truth.landmarks[i].position.y(), written.truth.landmarks[i].position.y(), "landmark y");
  }
  EXPECT_EQ(read.truth.observation_ids, written.truth.observation_ids);
  EXPECT_TRUE(read.truth.poses_have_heading);
  EXPECT_LT((read.initial_pose - written.initial_pose).norm(), 1e-12);
}

// A simulated log written afresh for each test, ready to be read back or damaged.
class SimLog : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    world_ = new World(default_world());
    dataset_ = new Dataset(simulate(*world_, SimulatorConfig{}));
  }
  static void TearDownTestSuite() {
    delete dataset_;
    delete world_;
  }
  void SetUp() override { write_sim_log(dir(), *dataset_, SimulatorConfig{}, *world_); }

  std::string dir() const { return scratch_.file("log"); }
  std::string file(const std::string& name) const { return dir() + "/" + name; }
  Dataset read() const { return read_sim_log(dir()); }

  // Edits params.json through `edit`.
  void edit_params(const std::function<void(nlohmann::json&)>& edit) const {
    std::ifstream in(file("params.json"));
    nlohmann::json j = nlohmann::json::parse(in);
    edit(j);
    write_text(file("params.json"), j.dump(2));
  }

  static World* world_;
  static Dataset* dataset_;
  ScratchDir scratch_;
};

World* SimLog::world_ = nullptr;
Dataset* SimLog::dataset_ = nullptr;

TEST_F(SimLog, RoundTripPreservesEventsTruthAndConfig) {
  expect_same_dataset(read(), *dataset_);

  SimulatorConfig c;
  c.seed = 5;
  c.loops = 1;
  c.max_range = 25.0;
  c.fov = deg2rad(270.0);
  c.sigma_steer = deg2rad(2.5);
  c.sigma_range = 0.15;
  c.wheelbase = 3.0;
  const Dataset written = simulate(*world_, c);
  const std::string other = scratch_.file("other");
  write_sim_log(other, written, c, *world_);
  const Dataset read = read_sim_log(other);
  expect_same_dataset(read, written);

  const auto* motion = dynamic_cast<const AckermannModel*>(read.motion.get());
  ASSERT_NE(motion, nullptr);
  EXPECT_EQ(motion->params().wheelbase, 3.0);
  EXPECT_EQ(motion->params().sigma_speed, c.sigma_speed);
  EXPECT_EQ(motion->params().sigma_steer, c.sigma_steer);
  const auto* sensor = dynamic_cast<const RangeBearingModel*>(read.observation.get());
  ASSERT_NE(sensor, nullptr);
  EXPECT_EQ(sensor->params().sigma_range, 0.15);
  EXPECT_EQ(sensor->params().sigma_bearing, c.sigma_bearing);
  EXPECT_EQ(read.sensor.max_range, 25.0);
  EXPECT_EQ(read.sensor.fov, c.fov);

  std::ifstream params(other + "/params.json");
  const nlohmann::json j = nlohmann::json::parse(params);
  EXPECT_EQ(j.at("format"), "slamkit-sim");
  EXPECT_EQ(j.at("version"), 1);
  EXPECT_EQ(j.at("simulator"), to_json(c));
  const SimulatorConfig r = simulator_config_from_json(j.at("simulator"), "params.json");
  EXPECT_EQ(r.seed, 5u);
  EXPECT_EQ(r.loops, 1);
  EXPECT_EQ(r.fov, c.fov);
  EXPECT_EQ(r.sigma_steer, c.sigma_steer);

  const World w = read_world(other + "/world.txt");
  ASSERT_EQ(w.landmarks.size(), world_->landmarks.size());
  EXPECT_EQ(w.waypoints, world_->waypoints);
}

TEST_F(SimLog, FilesStaySmall) {
  std::uintmax_t total = 0;
  for (const auto& entry : fs::directory_iterator(dir())) total += entry.file_size();
  EXPECT_LT(fs::file_size(file("events.txt")), 1'500'000u);
  EXPECT_LT(total, 2'000'000u);
}

TEST_F(SimLog, LoadDatasetReadsSimSpecs) {
  const Dataset d = load_dataset("sim:" + dir());
  EXPECT_EQ(d.spec, "sim:" + dir());
  EXPECT_EQ(d.name, "sim:log");
  EXPECT_EQ(d.events.size(), dataset_->events.size());
  EXPECT_EQ(load_dataset("sim:" + dir() + "/").name, "sim:log");
}

TEST_F(SimLog, LoadDatasetRejectsUnknownKindsAndBareSpecs) {
  try {
    load_dataset("bogus:" + dir());
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("bogus:" + dir() + ": unknown dataset kind 'bogus'; expected one of: sim", 0), 0u)
        << message;
  }
  EXPECT_THROW(load_dataset(dir()), InputError);
  EXPECT_THROW(load_dataset("sim:"), InputError);
}

TEST_F(SimLog, TruthFilesAreOptional) {
  fs::remove(file("truth_poses.txt"));
  fs::remove(file("truth_landmarks.txt"));
  fs::remove(file("truth_observations.txt"));
  const Dataset d = read();
  EXPECT_TRUE(d.truth.empty());
  EXPECT_TRUE(d.truth.observation_ids.empty());
  EXPECT_EQ(d.events.size(), dataset_->events.size());
}

TEST_F(SimLog, RewritingWithoutTruthRemovesTheOldTruth) {
  Dataset no_truth = *dataset_;
  no_truth.truth = GroundTruth{};
  write_sim_log(dir(), no_truth, SimulatorConfig{}, *world_);
  EXPECT_FALSE(fs::exists(file("truth_poses.txt")));
  EXPECT_FALSE(fs::exists(file("truth_observations.txt")));
  EXPECT_TRUE(read().truth.empty());
}

TEST_F(SimLog, MissingFilesAreNamed) {
  fs::remove(file("events.txt"));
  expect_input_error([&] { read(); }, file("events.txt"), 0, "missing file");
  fs::remove(file("params.json"));
  expect_input_error([&] { read(); }, file("params.json"), 0, "missing file");
  expect_input_error([&] { read_sim_log(dir() + "/nowhere"); }, dir() + "/nowhere", 0, "not a directory");
}

TEST_F(SimLog, MalformedLineNamesItsLineNumber) {
  const std::size_t n = line_starting(file("events.txt"), "obs ");
  replace_line(file("events.txt"), n, "obs 0.2 5 7.7");
  expect_input_error([&] { read(); }, file("events.txt"), n, "expected 5 fields");
  try {
    read();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("events.txt:" + std::to_string(n) + ":"), std::string::npos)
        << e.what();
  }
}

TEST_F(SimLog, RejectsNonFiniteNumbers) {
  const std::size_t obs = line_starting(file("events.txt"), "obs ");
  replace_line(file("events.txt"), obs, "obs 0.2 5 nan 0.5");
  expect_input_error([&] { read(); }, file("events.txt"), obs, "expected a finite number for the range");
  replace_line(file("events.txt"), obs - 1, "control 0.2 0.025 inf 0");
  expect_input_error([&] { read(); }, file("events.txt"), obs - 1, "expected a finite number for the speed");
}

TEST_F(SimLog, RejectsUnknownKeywords) {
  const std::size_t n = line_starting(file("events.txt"), "control ");
  replace_line(file("events.txt"), n, "odometry 0.025 0.025 3 0");
  expect_input_error([&] { read(); }, file("events.txt"), n, "unknown keyword 'odometry'");
}

TEST_F(SimLog, RejectsTimeGoingBackwards) {
  const std::size_t first = line_starting(file("events.txt"), "control ");
  replace_line(file("events.txt"), first + 2, "control 0.01 0.025 3 0");
  expect_input_error([&] { read(); }, file("events.txt"), first + 2, "expected times never to decrease");
}

TEST_F(SimLog, RejectsBadOrInconsistentDt) {
  const std::size_t first = line_starting(file("events.txt"), "control ");
  replace_line(file("events.txt"), first + 1, "control 0.06 0.025 3 0");
  expect_input_error([&] { read(); }, file("events.txt"), first + 1, "start where the previous one ended");
  replace_line(file("events.txt"), first + 1, "control 0.05 0 3 0");
  expect_input_error([&] { read(); }, file("events.txt"), first + 1, "expected dt > 0");
}

TEST_F(SimLog, RejectsAControlSpanningAScan) {
  // Swap the control ending at the first scan with that scan's first observation.
  const std::size_t obs = line_starting(file("events.txt"), "obs ");
  std::vector<std::string> lines = read_lines(file("events.txt"));
  std::swap(lines[obs - 1], lines[obs - 2]);
  write_lines(file("events.txt"), lines);
  expect_input_error([&] { read(); }, file("events.txt"), obs, "expected a scan to follow the control");
}

TEST_F(SimLog, RejectsNonPositiveRangesAndBadIds) {
  const std::size_t obs = line_starting(file("events.txt"), "obs ");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"obs 0.2 5 0 0.5", "expected a range > 0"},
      {"obs 0.2 5 -1 0.5", "expected a range > 0"},
      {"obs 0.2 -2 7 0.5", "expected an id from -1"},
      {"obs 0.2 1.5 7 0.5", "expected an integer for an id"},
  };
  for (const auto& [text, message] : cases) {
    replace_line(file("events.txt"), obs, text);
    expect_input_error([&] { read(); }, file("events.txt"), obs, message);
  }
  // An unknown id is legal: the id is the sensor's claim, not the truth.
  replace_line(file("events.txt"), obs, "obs 0.2 -1 7 0.5");
  EXPECT_EQ(std::get<ScanEvent>(read().events[8]).observations.front().id, kUnknownId);
}

TEST_F(SimLog, TruthObservationsMustMatchTheObsLines) {
  const std::string truth = file("truth_observations.txt");
  std::vector<std::string> lines = read_lines(truth);
  const std::string last = lines.back();
  lines.pop_back();
  write_lines(truth, lines);
  expect_input_error([&] { read(); }, truth, 0, "expected " + std::to_string(lines.size() - 1));

  lines.push_back(last);
  lines.push_back(last);
  write_lines(truth, lines);
  expect_input_error([&] { read(); }, truth, lines.size(), "more lines than the");

  lines.pop_back();
  const std::size_t first = line_starting(truth, "0.2 ");
  lines[first - 1] = "0.4 5";
  write_lines(truth, lines);
  expect_input_error([&] { read(); }, truth, first, "differs from the 0.2 of the matching obs line");
}

TEST_F(SimLog, RejectsBadParams) {
  edit_params([](nlohmann::json& j) { j["simulator"]["speed_kmh"] = 10; });
  expect_input_error([&] { read(); }, file("params.json"), 0, "unknown key 'speed_kmh'");
  SetUp();
  edit_params([](nlohmann::json& j) { j["comment"] = "hi"; });
  expect_input_error([&] { read(); }, file("params.json"), 0, "unknown key 'comment'");
  SetUp();
  edit_params([](nlohmann::json& j) { j["format"] = "other"; });
  expect_input_error([&] { read(); }, file("params.json"), 0, "expected \"format\": \"slamkit-sim\"");
  SetUp();
  edit_params([](nlohmann::json& j) { j["version"] = 2; });
  expect_input_error([&] { read(); }, file("params.json"), 0, "unsupported version 2");
  SetUp();
  edit_params([](nlohmann::json& j) { j.erase("initial_pose"); });
  expect_input_error([&] { read(); }, file("params.json"), 0, "missing key 'initial_pose'");
  SetUp();
  edit_params([](nlohmann::json& j) { j["initial_pose"] = {1.0, 2.0}; });
  expect_input_error([&] { read(); }, file("params.json"), 0, "[x, y, theta]");
  write_text(file("params.json"), "{\n  \"format\": \"slamkit-sim\",\n  \"version\": 1,,\n}\n");
  expect_input_error([&] { read(); }, file("params.json"), 3, "invalid JSON");
  // Beyond a double, which nlohmann reports as out_of_range rather than as a parse error.
  write_text(file("params.json"), "{\n  \"format\": \"slamkit-sim\",\n  \"version\": 1e400\n}\n");
  expect_input_error([&] { read(); }, file("params.json"), 3, "number overflow parsing '1e400'");
}

// Without a single observation a run is dead reckoning, which used to be reported as a SLAM result.
TEST_F(SimLog, RefusesALogWithoutObservations) {
  std::vector<std::string> controls;
  for (const std::string& line : read_lines(file("events.txt")))
    if (!line.starts_with("obs ")) controls.push_back(line);
  write_lines(file("events.txt"), controls);
  fs::remove(file("truth_observations.txt"));
  expect_input_error([&] { read(); }, file("events.txt"), 0, "no 'obs' lines; expected observations");
}

// A truth landmark at 1e300 m used to run the whole filter and then fail in the plot without naming
// any input; a start at 1e20 m was scored as a map error of 1e20 m.
TEST_F(SimLog, RefusesPositionsBeyondTheCoordinateBound) {
  const std::size_t n = line_starting(file("truth_landmarks.txt"), "0 ");
  replace_line(file("truth_landmarks.txt"), n, "0 1e300 5");
  expect_input_error([&] { read(); }, file("truth_landmarks.txt"), n, "expected x within +-2e6 m, found 1e+300");
  SetUp();
  replace_line(file("truth_poses.txt"), line_starting(file("truth_poses.txt"), "0 "), "0 0 -3e6 0");
  expect_input_error([&] { read(); }, file("truth_poses.txt"), line_starting(file("truth_poses.txt"), "0 "),
                     "expected y within +-2e6 m");
  SetUp();
  edit_params([](nlohmann::json& j) { j["initial_pose"] = {1e20, 0.0, 0.0}; });
  expect_input_error([&] { read(); }, file("params.json"), 0, "expected \"initial_pose\" x and y within +-2e6 m");
  SetUp();
  edit_params([](nlohmann::json& j) { j["initial_pose"] = {2e6, -2e6, 0.0}; });  // the bound itself is inside
  EXPECT_EQ(read().initial_pose, Pose2(2e6, -2e6, 0.0));
}

TEST(SimLogWriter, LeavesOutScansWithoutObservations) {
  const ScratchDir scratch;
  Dataset d;
  d.initial_pose = Pose2(1.0, 2.0, 0.5);
  Control u(2);
  u << 3.0, 0.1;
  d.events = {ControlEvent{0.1, 0.1, u}, ScanEvent{0.1, {}}, ControlEvent{0.2, 0.1, u},
              ScanEvent{0.2, {Observation{Vector2(5.0, 0.25), 3}}}};
  d.truth.poses = {StampedPose{0.0, d.initial_pose}};
  d.truth.observation_ids = {{}, {3}};
  World w;
  w.waypoints = {Vector2(0.0, 0.0), Vector2(10.0, 0.0)};
  const std::string dir = scratch.file("log");
  SimulatorConfig c;
  c.control_period = 0.1;
  write_sim_log(dir, d, c, w);
  const Dataset r = read_sim_log(dir);
  ASSERT_EQ(r.events.size(), 3u);
  EXPECT_EQ(std::get<ScanEvent>(r.events[2]).observations.front().id, 3);
  EXPECT_EQ(r.truth.observation_ids, (std::vector<std::vector<int>>{{3}}));
  EXPECT_TRUE(r.initial_pose.isApprox(d.initial_pose));
}

// ---- World files ------------------------------------------------------------------------------------

TEST(WorldFile, RoundTripIsExact) {
  const ScratchDir scratch;
  WorldGenOptions o;
  o.landmarks = 300;
  const World w = generate_world(o);
  write_world(scratch.file("world.txt"), w);
  const World r = read_world(scratch.file("world.txt"));
  EXPECT_EQ(r.waypoints, w.waypoints);
  ASSERT_EQ(r.landmarks.size(), w.landmarks.size());
  for (std::size_t i = 0; i < w.landmarks.size(); ++i) {
    EXPECT_EQ(r.landmarks[i].id, w.landmarks[i].id);
    EXPECT_EQ(r.landmarks[i].position, w.landmarks[i].position);
  }
}

TEST(WorldFile, ReadsCommentsAndInterleavedLines) {
  const ScratchDir scratch;
  write_text(
      scratch.file("w.txt"),
      "# a tiny world\n\nwaypoint 0 0\nlandmark 7 1.5 -2   # a tree\nwaypoint 10 0\n  waypoint 10 10\n");
  const World w = read_world(scratch.file("w.txt"));
  ASSERT_EQ(w.waypoints.size(), 3u);
  EXPECT_EQ(w.waypoints[2], Vector2(10.0, 10.0));
  ASSERT_EQ(w.landmarks.size(), 1u);
  EXPECT_EQ(w.landmarks[0].id, 7);
  EXPECT_EQ(w.landmarks[0].position, Vector2(1.5, -2.0));
}

TEST(WorldFile, ReportsWhereAndWhatIsWrong) {
  const ScratchDir scratch;
  const std::string path = scratch.file("w.txt");
  expect_input_error([&] { read_world(path); }, path, 0, "cannot open file");

  const std::string good = "# world\nwaypoint 0 0\nwaypoint 10 0\n";
  const std::vector<std::tuple<std::string, std::size_t, std::string>> cases = {
      {good + "tree 1 2 3\n", 4, "unknown keyword 'tree'"},
      {good + "landmark 1 2\n", 4, "expected 4 fields (landmark <id> <x> <y>), found 3"},
      {good + "waypoint 1 2 3\n", 4, "expected 3 fields"},
      {good + "landmark 1 nan 3\n", 4, "expected a finite number for landmark x, found 'nan'"},
      {good + "landmark 1 2 3\nlandmark 1 4 5\n", 5, "duplicate landmark id 1 (first defined on line 4)"},
      {good + "landmark -1 2 3\n", 4, "expected a landmark id from 0"},
      {good + "waypoint 10 0\n", 4, "waypoint repeats the previous one"},
      // A waypoint at 1e300 m used to overflow the simulator's step count.
      {good + "waypoint 1e300 0\n", 4, "expected waypoint x within +-2e6 m, found 1e+300"},
      {good + "start 0 -3e6 90\n", 4, "expected start y within +-2e6 m"},
      {"waypoint 0 0\n# only one\n", 0, "expected at least 2 waypoints, found 1"},
  };
  for (const auto& [text, line, message] : cases) {
    write_text(path, text);
    expect_input_error([&] { read_world(path); }, path, line, message);
  }
}

}  // namespace
}  // namespace slamkit
