#pragma once
// A check before a large allocation: an estimate of the bytes a request needs against the memory
// this process may use, so that a setting like a hundred million particles is one clear error up
// front rather than std::bad_alloc, or the machine swapping, minutes into a run.
#include <string_view>

namespace slamkit {

/// The machine's physical memory in bytes.
double physical_memory_bytes();

/// Throws std::length_error naming `what`, the estimate and the limit when `bytes` (an estimate)
/// exceeds the memory this process may use: the physical memory, or less where a resource limit
/// on the address space or the data segment (ulimit -v, ulimit -d) says so.
void require_memory(double bytes, std::string_view what);

}  // namespace slamkit
