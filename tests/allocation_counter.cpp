#include "allocation_counter.hpp"
#include "sanitizers.hpp"

#include <atomic>
#include <cerrno>
#include <cstddef>

namespace {
std::atomic<std::uint64_t> allocation_calls{0};
void count_one() { allocation_calls.fetch_add(1, std::memory_order_relaxed); }
}  // namespace

std::uint64_t slamkit::test::allocations_so_far() { return allocation_calls.load(std::memory_order_relaxed); }

#ifdef SLAMKIT_ADDRESS_SANITIZER
// Under AddressSanitizer malloc belongs to the sanitizer, which sets itself up on the first call:
// an interposed malloc would run before it exists. Its allocator reports every allocation, whatever
// the route (malloc, operator new, aligned variants), to a hook installed at start-up instead.
#include <sanitizer/allocator_interface.h>

namespace {
void on_allocation(const volatile void*, std::size_t) { count_one(); }
void on_free(const volatile void*) {}
// Installed during static initialisation, before any test runs. If the sanitizer refused the hooks,
// nothing would be counted: AllocationCounter.SeesOperatorNewEigenAndAlignedNew fails then.
struct InstallHooks {
  InstallHooks() { __sanitizer_install_malloc_and_free_hooks(on_allocation, on_free); }
} install_hooks;
}  // namespace
#else
// glibc's own entry points, so the interposed functions below can count and then delegate.
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* ptr, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
}

extern "C" {
void* malloc(std::size_t size) {
  count_one();
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) {
  count_one();
  return __libc_calloc(count, size);
}
void* realloc(void* ptr, std::size_t size) {
  count_one();
  return __libc_realloc(ptr, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  count_one();
  return __libc_memalign(alignment, size);
}
void* memalign(std::size_t alignment, std::size_t size) {
  count_one();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  count_one();
  void* ptr = __libc_memalign(alignment, size);
  if (ptr == nullptr) return ENOMEM;
  *out = ptr;
  return 0;
}
}
#endif
