#include "slamkit/core/memory_budget.hpp"

#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace slamkit {
namespace {

/// The soft limit of `resource` in bytes; infinite when there is none.
double resource_limit(int resource) {
  rlimit limit{};
  if (getrlimit(resource, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return INFINITY;
  return static_cast<double>(limit.rlim_cur);
}

double process_limit() { return std::min(resource_limit(RLIMIT_AS), resource_limit(RLIMIT_DATA)); }

}  // namespace

double physical_memory_bytes() {
  return static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGESIZE));
}

void require_memory(double bytes, std::string_view what) {
  const double physical = physical_memory_bytes(), limit = process_limit();
  if (bytes <= std::min(physical, limit)) return;
  const std::string available = limit < physical ? fmt::format("this process may use {:.3g} GiB (ulimit)", limit / 0x1p30)
                                                 : fmt::format("this machine has {:.3g} GiB", physical / 0x1p30);
  throw std::length_error(fmt::format("{} would need about {:.3g} GiB of memory; {}", what, bytes / 0x1p30, available));
}

}  // namespace slamkit
