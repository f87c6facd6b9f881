// The memory a VJP holds while it runs, counted by this binary's global
// operator new and delete (a binary of its own so that nothing else
// allocates meanwhile): the exact sums, the result and the batches' rows,
// and nothing that grows with the vertex count times the threads (a row
// used to find its vertices through 4 bytes a vertex per thread, held
// outside the server's memory budget: docs/server.md).
#include <gtest/gtest.h>
#include <malloc.h>
#include <tbb/global_control.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "lib/core/sensitivity.h"
#include "lib/core/shapes.h"
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
  auto vjp = ComputeVjp(**ev, hits, g, {.threads = kThreads});
  counting = false;
  ASSERT_TRUE(vjp.ok()) << vjp.status();
  // The sums (2 doubles for each of x, y, z) and the result (a Vec3): 72
  // bytes a vertex; the two batches' rows, at 2 rays a sample, and the
  // rest: under 4 MiB. A slot per vertex per thread added 4 bytes a vertex
  // for every thread that took a chunk (measured: 57 MB against 36 MB).
  const int64_t bound = 72 * nv + (int64_t{4} << 20);
  EXPECT_LE(peak.load(), bound)
      << "peak " << peak.load() << " bytes for " << nv << " vertices";
}

}  // namespace
}  // namespace meshgauge
