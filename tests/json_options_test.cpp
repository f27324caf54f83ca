// The settings mechanism every settings file goes through (core/json_options.hpp), on a settings
// struct with one key of each kind: what it reads, what it writes back, and the error of every way a
// file can be wrong, each naming the file and the key.
#include "slamkit/core/json_options.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <string>

#include "test_data.hpp"

using namespace slamkit;

namespace {

struct Settings {
  double range = 10.0;
  double angle = deg2rad(30.0);
  int count = 3;
  std::uint64_t seed = 1;
  bool enabled = true;
  struct {
    double gain = 0.5;
  } inner;
};

using Real = RealOption<Settings>;

const OptionKey<Settings> kInnerKeys[] = {
    {"gain", Real{[](Settings& s) -> double& { return s.inner.gain; }, option_ranges::kNonNegative}},
};

const OptionKey<Settings> kKeys[] = {
    {"range_m", Real{[](Settings& s) -> double& { return s.range; }, option_ranges::kPositive}},
    {"angle_deg", Real{[](Settings& s) -> double& { return s.angle; }, option_ranges::kFinite, Unit::kDegrees}},
    {"count", IntegerOption<Settings, int>{[](Settings& s) -> int& { return s.count; }, 1, 10}},
    {"seed", IntegerOption<Settings, std::uint64_t>{[](Settings& s) -> std::uint64_t& { return s.seed; }}},
    {"enabled", FlagOption<Settings>{[](Settings& s) -> bool& { return s.enabled; }}},
    {"inner", section(kInnerKeys)},
};

Settings read(const nlohmann::json& json) {
  return options_from_json<Settings>(json, "settings.json", "the test settings", Settings{}, kKeys);
}

/// The message of the InputError reading `text` throws, which must name settings.json.
std::string error_reading(const std::string& text) {
  return test_data::input_error_at([&] { read(nlohmann::json::parse(text)); }, "settings.json", 0);
}

}  // namespace

TEST(JsonOptions, ReadsEveryKindOverTheDefaults) {
  const Settings s = read(nlohmann::json::parse(
      R"({"angle_deg": 90, "count": 7, "seed": 18446744073709551615, "enabled": false, "inner": {"gain": 2}})"));
  EXPECT_EQ(s.range, 10.0);  // absent: the default
  EXPECT_DOUBLE_EQ(s.angle, kPi / 2.0);
  EXPECT_EQ(s.count, 7);
  EXPECT_EQ(s.seed, 18446744073709551615ULL);
  EXPECT_FALSE(s.enabled);
  EXPECT_EQ(s.inner.gain, 2.0);
}

TEST(JsonOptions, WritesWhatItReads) {
  Settings s;
  s.angle = deg2rad(3.0);
  s.count = 9;
  s.seed = 18446744073709551615ULL;
  s.enabled = false;
  s.inner.gain = 0.25;
  const nlohmann::json j = options_to_json<Settings>(s, kKeys);
  // Whole degrees stay whole after the trip through radians.
  EXPECT_EQ(j.dump(), R"({"angle_deg":3.0,"count":9,"enabled":false,"inner":{"gain":0.25},"range_m":10.0,)"
                      R"("seed":18446744073709551615})");
  const Settings back = read(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(back.angle, s.angle);
  EXPECT_EQ(back.count, s.count);
  EXPECT_EQ(back.seed, s.seed);
  EXPECT_EQ(back.enabled, s.enabled);
  EXPECT_EQ(back.inner.gain, s.inner.gain);
}

TEST(JsonOptions, EveryWrongValueNamesTheFileAndTheKey) {
  EXPECT_NE(error_reading(R"({"rnage_m": 1})")
                .find("settings.json: unknown key 'rnage_m' in the test settings (did you mean 'range_m'?); expected "
                      "one of: range_m, angle_deg, count, seed, enabled, inner"),
            std::string::npos);
  EXPECT_NE(error_reading(R"({"inner": {"gian": 1}})")
                .find("unknown key 'gian' in 'inner' (did you mean 'gain'?); expected one of: gain"),
            std::string::npos);
  EXPECT_NE(error_reading(R"({"inner": 3})").find("expected 'inner' as a JSON object, found number"),
            std::string::npos);
  EXPECT_NE(error_reading(R"([1])").find("expected the test settings as a JSON object, found array"),
            std::string::npos);
  EXPECT_NE(error_reading(R"({"range_m": "5"})").find("'range_m' must be a number, found \"5\""), std::string::npos);
  EXPECT_NE(error_reading(R"({"range_m": 0})").find("'range_m' must be > 0, found 0"), std::string::npos);
  EXPECT_NE(error_reading(R"({"inner": {"gain": -1}})").find("'gain' must be >= 0, found -1"), std::string::npos);
  EXPECT_NE(error_reading(R"({"count": 11})").find("'count' must be an integer from 1 to 10, found 11"),
            std::string::npos);
  EXPECT_NE(error_reading(R"({"count": 2.5})").find("'count' must be an integer from 1 to 10, found 2.5"),
            std::string::npos);
  EXPECT_NE(error_reading(R"({"count": 18446744073709551615})").find("'count' must be an integer"),
            std::string::npos);
  EXPECT_NE(error_reading(R"({"seed": -1})").find("'seed' must be an integer from 0 to 18446744073709551615"),
            std::string::npos);
  EXPECT_NE(error_reading(R"({"enabled": 1})").find("'enabled' must be true or false, found 1"), std::string::npos);
}

TEST(JsonOptions, ValidatesSettingsBuiltInCode) {
  Settings s;
  s.inner.gain = std::nan("");
  EXPECT_THROW(validate_options<Settings>(s, "code", kKeys), InputError);
  s = {};
  s.count = 0;
  const std::string message =
      test_data::input_error_at([&] { validate_options<Settings>(s, "code", kKeys); }, "code", 0);
  EXPECT_NE(message.find("'count' must be an integer from 1 to 10, found 0"), std::string::npos) << message;
}

TEST(JsonFile, ANumberBeyondADoubleIsAnInputErrorAtItsLine) {
  // nlohmann reports this as out_of_range, not as a parse error, and without a position.
  for (const char* number : {"1e400", "-1e400"}) {
    const std::string message = test_data::input_error_at(
        [&] { parse_json(std::string("{\n  \"a\": 1,\n  \"b\": ") + number + "\n}\n", "big.json"); }, "big.json", 3);
    EXPECT_NE(message.find(number), std::string::npos) << message;
    EXPECT_NE(message.find("expected a number within the range of a double"), std::string::npos) << message;
  }
  // Underflow is no error: the number rounds to zero.
  EXPECT_EQ(parse_json("{\"a\": 1e-400}", "small.json")["a"].get<double>(), 0.0);
}

TEST(JsonFile, MalformedJsonAndMissingFilesNameTheFile) {
  const std::string message = test_data::input_error_at(
      [] { parse_json("{\n  \"a\": 1,\n  \"b\": tru,\n  \"c\": 2\n}", "bad.json"); }, "bad.json", 3);
  EXPECT_EQ(message.find("[json.exception"), std::string::npos) << message;
  EXPECT_NE(message.find("invalid JSON"), std::string::npos) << message;

  const test_data::ScratchDir dir;
  test_data::input_error_at([&] { read_json_file(dir.file("absent.json")); }, dir.file("absent.json"), 0);
  std::ofstream(dir.file("good.json")) << "{\"x\": [1, 2]}";
  EXPECT_EQ(read_json_file(dir.file("good.json"))["x"][1], 2);
}
