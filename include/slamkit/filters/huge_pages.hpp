#pragma once
// The EKF's covariance is one buffer of tens of megabytes to gigabytes that grows by copying into a
// larger one. Every 4 KiB page of a fresh buffer costs a page fault when first written, and on a
// virtual machine a fault costs tens of microseconds: filling 64 MB took 0.63 s on the 2-core VM of
// docs/performance.md, against 0.04-0.11 s in 2 MiB pages. So the big buffers ask for huge pages.
//
// The cost is resident memory: a 2 MiB page is resident as soon as any byte of it is written, so
// the square buffer's unwritten upper triangle, which 4 KiB pages mostly left unbacked, is resident
// too: about the whole capacity x dim block, up to 2.5 times the lower triangle's bytes.
#include <cstddef>

namespace slamkit {

/// Asks the kernel to back the whole pages inside [data, data + bytes) with transparent huge pages
/// (Linux, where they are enabled "always" or "madvise"); a no-op elsewhere, and for small buffers.
/// Call it before the buffer is first written: pages already faulted in stay small.
void advise_huge_pages(void* data, std::size_t bytes) noexcept;

}  // namespace slamkit
