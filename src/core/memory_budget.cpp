#include "slamkit/core/memory_budget.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <stdexcept>

namespace slamkit {

double physical_memory_bytes() {
  return static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGESIZE));
}

void require_memory(double bytes, std::string_view what) {
  const double available = physical_memory_bytes();
  if (!(bytes <= available))
    throw std::length_error(fmt::format("{} would need about {:.3g} GiB of memory; this machine has {:.3g} GiB",
                                        what, bytes / 0x1p30, available / 0x1p30));
}

}  // namespace slamkit
