// The allocator of the hit table's large per-ray arrays (HitTable): filled
// by the ray pass's workers, read by the sensitivities, and made anew by
// every pass of a session, incremental ones included; also of ExactSums'
// sums (a VJP's: 48 bytes a vertex, made anew by every VJP).
//  * resize() leaves new entries of trivial types uninitialized, so the
//    workers that write the rows are the first to touch their pages, in
//    parallel, instead of one thread zeroing the table before the pass.
//  * Arrays of kHugeBytes or more are mapped on their own and advised for
//    transparent huge pages (madvise MADV_HUGEPAGE; granted when the
//    kernel's THP mode is "madvise", Debian's default, or "always"): on this
//    project's machines a 4 KiB page fault costs about 12 us, so touching a
//    fresh 67 MB table (igea, 100 rays) took 0.15 s of one thread. A process
//    started with glibc.malloc.hugetlb=0 in GLIBC_TUNABLES (glibc's own
//    switch for malloc) keeps small pages here too. Under a sanitizer every
//    array comes from std::allocator, so that the sanitizer sees it.
#pragma once

#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include "lib/core/sanitizers.h"

namespace meshgauge {

// Whether TableAllocator maps its large arrays itself: not under a
// sanitizer.
inline constexpr bool kTableMapsLargeArrays = !MESHGAUGE_SANITIZED;

// Whether TableAllocator advises huge pages: unless the process was started
// with glibc.malloc.hugetlb=0 in GLIBC_TUNABLES.
inline bool TableHugePagesWanted() {
  static const bool wanted = [] {
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    return tunables == nullptr ||
           std::strstr(tunables, "glibc.malloc.hugetlb=0") == nullptr;
  }();
  return wanted;
}

template <typename T>
class TableAllocator {
 public:
  using value_type = T;
  static constexpr size_t kHugeBytes = size_t{4} << 20;

  TableAllocator() = default;
  template <typename U>
  TableAllocator(const TableAllocator<U>&) noexcept {}

  T* allocate(size_t n) {
    if (n > SIZE_MAX / sizeof(T)) throw std::bad_array_new_length();
    const size_t bytes = n * sizeof(T);
    if (!Mapped(bytes)) return std::allocator<T>().allocate(n);
    void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE,
                   MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::bad_alloc();
    // Advice only: small pages where the kernel does not grant them.
    if (TableHugePagesWanted()) madvise(p, bytes, MADV_HUGEPAGE);
    return static_cast<T*>(p);
  }
  void deallocate(T* p, size_t n) noexcept {
    if (Mapped(n * sizeof(T))) {
      munmap(p, n * sizeof(T));
    } else {
      std::allocator<T>().deallocate(p, n);
    }
  }

  // Value-less construction default-initializes (leaves trivial types
  // uninitialized).
  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }

  template <typename U>
  bool operator==(const TableAllocator<U>&) const noexcept {
    return true;
  }

 private:
  static bool Mapped(size_t bytes) {
    return kTableMapsLargeArrays && bytes >= kHugeBytes;
  }
};

// resize(n) leaves the new entries of a trivial T uninitialized; large
// arrays sit in huge pages where the kernel grants them.
template <typename T>
using TableVector = std::vector<T, TableAllocator<T>>;

}  // namespace meshgauge
