// libFuzzer's entry point for one target of fuzz_targets.hpp, chosen at compile time
// (SLAMKIT_FUZZ_TARGET); CMake builds one executable per target.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const slamkit::fuzz::FuzzTarget& target = slamkit::fuzz::target(SLAMKIT_FUZZ_TARGET);
  target.run(std::string_view(reinterpret_cast<const char*>(data), size));
  return 0;
}
