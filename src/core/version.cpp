#include "slamkit/core/version.hpp"

namespace slamkit {

std::string version() { return SLAMKIT_VERSION; }

}  // namespace slamkit
