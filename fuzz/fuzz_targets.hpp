#pragma once
// The fuzz targets: one entry point per reader (and one for a filter run on arbitrary events), each
// taking raw bytes. libFuzzer drives them in the clang build (fuzz/libfuzzer_main.cpp, `make fuzz`);
// the test suite feeds them every file of fuzz/corpus/ and fuzz/crashes/ in the ordinary gcc build
// (tests/fuzz_replay_test.cpp), so a crash once found stays fixed without clang.
//
// The contract each target checks: whatever the bytes, the code under test either succeeds or throws
// InputError, the one error type for bad input. Any other exception escapes the target (libFuzzer
// reports it as a crash, the replay test as a failure); a crash, a hang or undefined behaviour is
// caught by the sanitizers the fuzz build carries.
//
// Readers of a folder take one input holding every file: the files' contents in a fixed order
// (FuzzTarget::files), separated by lines of "@@". A missing part leaves its file out, so optional
// files and missing required ones are explored too.
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace slamkit::fuzz {

/// Separates the files of a folder within one input.
inline constexpr std::string_view kFileSeparator = "\n@@\n";

struct FuzzTarget {
  const char* name;
  void (*run)(std::string_view input);
};

std::span<const FuzzTarget> targets();

/// The target called `name`; throws std::invalid_argument naming the targets there are.
const FuzzTarget& target(std::string_view name);

}  // namespace slamkit::fuzz
