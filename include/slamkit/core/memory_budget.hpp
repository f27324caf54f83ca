#pragma once
// A check before a large allocation: an estimate of the bytes a request needs against the machine's
// memory, so that a setting like a hundred million particles is one clear error up front rather
// than std::bad_alloc, or the machine swapping, minutes into a run.
#include <string_view>

namespace slamkit {

/// The machine's physical memory in bytes.
double physical_memory_bytes();

/// Throws std::length_error naming `what`, the estimate and the machine's memory when `bytes` (an
/// estimate) exceeds the physical memory.
void require_memory(double bytes, std::string_view what);

}  // namespace slamkit
