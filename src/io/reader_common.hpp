#pragma once
// Small pieces the io module's dataset readers share. Private to the io module.
#include <filesystem>
#include <string>

namespace slamkit::io_detail {

/// The largest time, in seconds, a log may state (about 31,700 years): beyond it a time is a
/// misread field, and the doubles that hold it would lose the milliseconds.
inline constexpr double kMaxAbsTime = 1e12;

/// The last component of a dataset folder's path ("a/b/Dataset6/" gives "Dataset6"), for its name.
inline std::string last_component(std::string dir) {
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  const std::string name = std::filesystem::path(dir).filename().string();
  return name.empty() ? dir : name;
}

}  // namespace slamkit::io_detail
