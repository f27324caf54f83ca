#pragma once
// The library's version (CMake's project version), for `slamkit --version`, run.json and metrics.json,
// so every output names the code that produced it.
#include <string>

namespace slamkit {

std::string version();

}  // namespace slamkit
