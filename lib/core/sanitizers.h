// Whether this translation unit is built with a sanitizer (AddressSanitizer,
// ThreadSanitizer or MemorySanitizer; GCC's and Clang's spellings), whose
// allocator replaces malloc and ignores glibc's tunables.
#pragma once

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define MESHGAUGE_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define MESHGAUGE_SANITIZED 1
#endif
#endif
#ifndef MESHGAUGE_SANITIZED
#define MESHGAUGE_SANITIZED 0
#endif
