#pragma once
// The library's version (CMake's project version), for `slamkit --version`, run.json and metrics.json,
// so every output names the code that produced it; and how it was built, for run.json: a campaign
// spread over machines must be able to tell a portable build from one for the host's instruction set,
// whose numbers may differ in the last digits.
#include <string>

namespace slamkit {

std::string version();

/// "GNU 12.2.0, Release, -march=native" (or "portable" for the compiler's generic target).
std::string build_description();

}  // namespace slamkit
