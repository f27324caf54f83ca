// Every seed of the fuzz corpora and every input that once crashed a fuzz target, through the same
// entry points libFuzzer drives (fuzz/fuzz_targets.hpp), compiled here with the ordinary compiler:
// each must be read or refused with an InputError, never crash or throw anything else.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "../fuzz/fuzz_targets.hpp"

namespace fs = std::filesystem;

namespace slamkit::fuzz {
namespace {

std::vector<fs::path> inputs_of(const std::string& target, const char* kind) {
  const fs::path dir = fs::path(SLAMKIT_SOURCE_DIR) / "fuzz" / kind / target;
  std::vector<fs::path> files;
  if (fs::is_directory(dir))
    for (const auto& entry : fs::directory_iterator(dir))
      if (entry.is_regular_file()) files.push_back(entry.path());
  return files;
}

std::string contents(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class FuzzReplay : public testing::TestWithParam<const char*> {};

TEST_P(FuzzReplay, EverySeedAndCrashIsReadOrRefusedWithInputError) {
  const FuzzTarget& fuzz_target = target(GetParam());
  const std::vector<fs::path> seeds = inputs_of(GetParam(), "corpus");
  EXPECT_FALSE(seeds.empty()) << "fuzz/corpus/" << GetParam() << " holds no seed";
  std::vector<fs::path> inputs = seeds;
  for (const fs::path& crash : inputs_of(GetParam(), "crashes")) inputs.push_back(crash);
  for (const fs::path& input : inputs) {
    SCOPED_TRACE(input.string());
    EXPECT_NO_THROW(fuzz_target.run(contents(input)));
  }
}

std::vector<const char*> target_names() {
  std::vector<const char*> names;
  for (const FuzzTarget& t : targets()) names.push_back(t.name);
  return names;
}

INSTANTIATE_TEST_SUITE_P(Targets, FuzzReplay, testing::ValuesIn(target_names()),
                         [](const testing::TestParamInfo<const char*>& info) { return std::string(info.param); });

TEST(FuzzTargets, AnUnknownNameListsTheTargets) {
  try {
    target("gps");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sim_log, course_log"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace slamkit::fuzz
