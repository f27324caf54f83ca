// What `slamkit run --config RUN.json` takes from a run.json, under every wrong kind of value, as the
// reliability probe tried it: every key of a real run.json (nested ones too) set to a string, a
// number, a boolean, null, an array and an object in turn, and read through the path --config takes
// (run_settings_from_json, then the dataset with the settings recorded). Each variant is either
// accepted or refused by an InputError naming the file and the key; a 'dataset' or
// 'dataset_settings' of another kind used to escape as nlohmann's type error and abort the CLI.
#include "slamkit/pipeline/settings.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/sim/simulator.hpp"
#include "test_data.hpp"

namespace slamkit {
namespace {

using test_data::ScratchDir;

/// The run.json of a real run (EKF, history none) on a one-lap simulated log in `dir`.
nlohmann::json real_run_json(const ScratchDir& dir) {
  Scenario s = scenario("default");
  s.config.loops = 1;
  write_sim_log(dir.file("sim"), simulate(s.world, s.config), s.config, s.world);
  const std::string command = std::string(SLAMKIT_CLI) + " run --history none --quiet --data sim:" + dir.file("sim") +
                              " --out " + dir.file("run");
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  return read_json_file(dir.file("run") + "/run.json");
}

TEST(RunSettings, EveryKeyOfEveryKindIsReadOrRefusedNamingTheFileAndKey) {
  const ScratchDir dir;
  const nlohmann::json original = real_run_json(dir);
  ASSERT_TRUE(original.contains("settings"));
  const std::string source = dir.file("run/run.json");
  const std::vector<std::pair<std::string, nlohmann::json>> kinds = {
      {"string", "x"}, {"number", 1.5}, {"boolean", true}, {"null", nullptr}, {"array", {1}}, {"object", {{"a", 1}}}};

  std::size_t variants = 0, refused = 0;
  const std::function<void(const nlohmann::json::json_pointer&, const nlohmann::json&)> sweep =
      [&](const nlohmann::json::json_pointer& at, const nlohmann::json& object) {
        for (const auto& item : object.items()) {
          const nlohmann::json::json_pointer key = at / item.key();
          for (const auto& kind : kinds) {
            if (item.value().type_name() == kind.first) continue;
            nlohmann::json j = original;
            j[key] = kind.second;
            ++variants;
            try {
              const RunSettings settings = run_settings_from_json(j, source);
              load_dataset(absolute_dataset_spec(settings.dataset), settings.dataset_settings_contents,
                           settings.dataset_settings_source);
            } catch (const InputError& e) {
              ++refused;
              const std::string message = e.what();
              EXPECT_NE(message.find(source), std::string::npos) << key << " = " << kind.second << ": " << message;
              EXPECT_NE(message.find(item.key()), std::string::npos) << key << " = " << kind.second << ": " << message;
            } catch (const std::exception& e) {
              ADD_FAILURE() << key << " = " << kind.second << ": not an InputError: " << e.what();
            }
          }
          if (item.value().is_object()) sweep(key, item.value());
        }
      };
  sweep(nlohmann::json::json_pointer(), original);
  // run.json has some twenty keys, the filter and association settings forty more.
  EXPECT_GT(variants, 300u);
  EXPECT_GT(refused, 100u);
}

TEST(RunSettings, SettingsRecordedOrNamedAreTakenAndMissingKeysAreNamed) {
  const ScratchDir dir;
  nlohmann::json j = {{"settings", nlohmann::json::object()}, {"dataset", "course:x"}};
  RunSettings s = run_settings_from_json(j, "r.json");
  EXPECT_EQ(s.dataset, "course:x");
  EXPECT_TRUE(s.dataset_settings_contents.is_null());
  // An older run.json names the settings file without its contents: they are read from the file.
  std::ofstream(dir.file("course.json")) << R"({"step_period_s": 0.2})";
  j["dataset_settings"] = dir.file("course.json");
  s = run_settings_from_json(j, "r.json");
  EXPECT_EQ(s.dataset_settings_contents, nlohmann::json({{"step_period_s", 0.2}}));
  EXPECT_EQ(s.dataset_settings_source, dir.file("course.json"));
  j["dataset_settings_contents"] = {{"step_period_s", 0.5}};
  s = run_settings_from_json(j, "r.json");
  EXPECT_EQ(s.dataset_settings_contents, nlohmann::json({{"step_period_s", 0.5}}));
  EXPECT_EQ(s.dataset_settings_source, "r.json (dataset_settings_contents)");

  for (const char* key : {"settings", "dataset"}) {
    nlohmann::json missing = j;
    missing.erase(key);
    const std::string message = test_data::input_error_at([&] { run_settings_from_json(missing, "r.json"); }, "r.json", 0);
    EXPECT_NE(message.find(std::string("missing key '") + key + "'"), std::string::npos) << message;
  }
  EXPECT_NE(test_data::input_error_at([&] { run_settings_from_json(nlohmann::json::array(), "r.json"); }, "r.json", 0)
                .find("expected the run.json of a run folder (a JSON object), found array"),
            std::string::npos);
}

}  // namespace
}  // namespace slamkit
