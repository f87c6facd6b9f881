// The memory a VJP's sums hold while they are computed, counted by this
// binary's global operator new and delete (a binary of its own so that
// nothing else allocates meanwhile): the exact sums and the batches' rows,
// and nothing that grows with the vertex count times the threads (a row
// used to find its vertices through 4 bytes a vertex per thread, held
// outside the server's memory budget: docs/server.md).
#include <gtest/gtest.h>
#include <malloc.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <new>

#include "lib/core/sensitivity.h"
#include "lib/core/shapes.h"
#include "lib/core/table_allocator.h"
#include "lib/embree/sdf_evaluator.h"

namespace {

std::atomic<bool> counting{false};
std::atomic<int64_t> live{0}, peak{0};

void Count(int64_t bytes) {
  if (!counting.load(std::memory_order_relaxed)) return;
  const int64_t now = live.fetch_add(bytes) + bytes;
  int64_t seen = peak.load();
  while (now > seen && !peak.compare_exchange_weak(seen, now)) {
  }
}

}  // namespace

void* operator new(size_t size) {
  void* p = std::malloc(size == 0 ? 1 : size);
  if (p == nullptr) throw std::bad_alloc();
  Count(static_cast<int64_t>(malloc_usable_size(p)));
  return p;
}
void operator delete(void* p) noexcept {
  if (p == nullptr) return;
  Count(-static_cast<int64_t>(malloc_usable_size(p)));
  std::free(p);
}
void operator delete(void* p, size_t) noexcept { operator delete(p); }
// Over-aligned types (alignas(64) per-thread state) come here.
void* operator new(size_t size, std::align_val_t align) {
  const size_t a = static_cast<size_t>(align);
  void* p = std::aligned_alloc(a, (std::max<size_t>(size, 1) + a - 1) / a * a);
  if (p == nullptr) throw std::bad_alloc();
  Count(static_cast<int64_t>(malloc_usable_size(p)));
  return p;
}
void operator delete(void* p, std::align_val_t) noexcept { operator delete(p); }
void operator delete(void* p, size_t, std::align_val_t) noexcept {
  operator delete(p);
}

namespace meshgauge {
namespace {

TEST(VjpMemoryTest, ManyThreadsHoldNoSlotPerVertex) {
  constexpr int kThreads = 16;
  // Room for kThreads threads on a machine of fewer cores.
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism,
                                  kThreads);
  auto ev = SdfEvaluator::Create(MakeTorus(1.0, 0.3, 1000, 500),
                                 {.bvh_policy = BvhUpdatePolicy::kRebuild});
  ASSERT_TRUE(ev.ok()) << ev.status();
  const int64_t nv = (*ev)->mesh().num_vertices();
  SdfParams params;
  params.rays = 2;
  HitTable hits;
  auto pass = (*ev)->Compute(params, {}, &hits);
  ASSERT_TRUE(pass.ok()) << pass.status();
  const std::vector<double> g(nv, 1.0);
  live = 0;
  peak = 0;
  counting = true;
  auto sums = ComputeVjpSums(**ev, hits, g, {.threads = kThreads});
  counting = false;
  ASSERT_TRUE(sums.ok()) << sums.status();
  // The sums (2 doubles for each of x, y, z): 48 bytes a vertex, and the
  // samples' visiting order, 4; the two batches' rows, at 2 rays a sample,
  // and the rest: under 2 MiB. A slot per vertex per thread added 4 bytes a
  // vertex (2 MB here) for every thread that took a chunk (measured: 57 MB
  // against 25 MB). The sums' array is mapped by TableAllocator, past
  // operator new, but under a sanitizer: counted here as the 48 bytes a
  // vertex it holds.
  const int64_t sums_bytes = kTableMapsLargeArrays ? 48 * nv : 0;
  const int64_t bound = 52 * nv + (int64_t{2} << 20);
  EXPECT_LE(peak.load() + sums_bytes, bound)
      << "peak " << peak.load() << " bytes through operator new, and "
      << sums_bytes << " mapped, for " << nv << " vertices";
}

}  // namespace
}  // namespace meshgauge
