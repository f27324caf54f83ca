#pragma once
// Where the tests find the shared real datasets: $SLAMKIT_DATA if set, else ../shared/datasets beside
// the source tree (where CI has them). Tests that need one skip, naming the path, when it is absent.
#include <cstdlib>
#include <filesystem>
#include <string>

namespace slamkit::test_data {

inline std::filesystem::path shared_dataset(const std::string& folder) {
  const char* env = std::getenv("SLAMKIT_DATA");
  const std::filesystem::path root = env != nullptr && *env != '\0'
                                         ? std::filesystem::path(env)
                                         : std::filesystem::path(SLAMKIT_SOURCE_DIR) / ".." / "shared" / "datasets";
  return root / folder;
}

}  // namespace slamkit::test_data

/// Skips the current test when the dataset folder is missing.
#define SLAMKIT_REQUIRE_DATASET(path)                                                                     \
  do {                                                                                                    \
    if (!std::filesystem::exists(path))                                                                   \
      GTEST_SKIP() << "dataset not found at " << (path).string()                                          \
                   << " (set SLAMKIT_DATA to the folder holding the shared datasets)";                    \
  } while (0)
