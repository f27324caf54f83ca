#include "slamkit/core/version.hpp"

namespace slamkit {

std::string version() { return SLAMKIT_VERSION; }

std::string build_description() { return SLAMKIT_BUILD; }

}  // namespace slamkit
