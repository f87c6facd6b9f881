// A std::vector whose resize() leaves new elements of trivial types
// uninitialized: a large table whose every entry is written by the workers
// that fill it is then first touched by them, in parallel, instead of being
// zeroed by one thread before them (on a machine where a page fault costs
// about 12 us, zeroing a 24 MB hit table took 0.07 s; docs/benchmarks.md).
#pragma once

#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace meshgauge {

// std::allocator<T> whose value-less construct() default-initializes.
template <typename T>
class DefaultInitAllocator : public std::allocator<T> {
 public:
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <typename U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}

  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

// resize(n) leaves the new entries uninitialized (for trivial T); assign()
// and the other members behave as std::vector's.
template <typename T>
using DefaultInitVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace meshgauge
