#pragma once

// Which sanitizer this test binary is built under. gcc names AddressSanitizer with a macro; clang 14
// only answers __has_feature, so a test that must not run under it asks here rather than either.
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SLAMKIT_ADDRESS_SANITIZER 1
#endif
#if __has_feature(thread_sanitizer)
#define SLAMKIT_THREAD_SANITIZER 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) && !defined(SLAMKIT_ADDRESS_SANITIZER)
#define SLAMKIT_ADDRESS_SANITIZER 1
#endif
#if defined(__SANITIZE_THREAD__) && !defined(SLAMKIT_THREAD_SANITIZER)
#define SLAMKIT_THREAD_SANITIZER 1
#endif
