// ExactSums::AddScaledTerms, the VJP's scatter. Compiled with
// -ffp-contract=off (lib/CMakeLists.txt): a product g * d is never fused
// into the sum it is added to, in the lanes or in the fall-back's Add, so
// each lane is Add's arithmetic on the same addend.
#include <cstddef>
#include <cstring>
#include <type_traits>

#include "lib/core/double_lanes.h"
#include "lib/core/exact_sum.h"
#include "lib/core/row_term.h"

namespace meshgauge {

// A term's three sums' pairs are hi0 lo0 hi1 lo1 hi2 lo2 in memory. Their
// his and los are gathered into vectors (AVX: the three in four lanes, the
// fourth adding 0 to 0 and never read; the baseline: x and y in an SSE2
// pair, z alone), Add's two TwoSums are done lane by lane, and the pairs
// are written back when every lane's sum was exact. Otherwise (rare: a
// term beyond about 2^50 of its sum's magnitude, or not finite) the term
// takes Add three times, from the sums as they were.
struct RowScatter {
  using Pair = ExactSums::Pair;
  static_assert(std::is_trivially_copyable_v<Pair> &&
                    sizeof(Pair) == 2 * sizeof(double) &&
                    offsetof(Pair, lo) == sizeof(double),
                "the vectors read and write pairs as hi, lo doubles");

  // Adds d * g to the three pairs at `p` in four lanes; false, with nothing
  // written, where a lane's sum would not be exact in its pair.
  [[gnu::always_inline]] static inline bool AddFour(Pair* p, const Vec3& d,
                                                    double g) {
    V4 a;  // hi0 lo0 hi1 lo1
    V2 b;  // hi2 lo2
    std::memcpy(&a, p, sizeof a);
    std::memcpy(&b, p + 2, sizeof b);
    const V4 b4 = __builtin_shufflevector(b, V2{0, 0}, 0, 1, 2, 3);
    const V4 hi = __builtin_shufflevector(a, b4, 0, 2, 4, 6);
    const V4 lo = __builtin_shufflevector(a, b4, 1, 3, 5, 7);
    V4 s, t, e2;
    ExactSums::TwoSums(hi, lo, V4{d.x, d.y, d.z, 0} * g, s, t, e2);
    const auto exact = e2 == 0;  // false for NaN, as in Add.
    if ((exact[0] & exact[1] & exact[2]) == 0) return false;
    const V4 a2 = __builtin_shufflevector(s, t, 0, 4, 1, 5);
    const V2 b2 = __builtin_shufflevector(s, t, 2, 6);
    std::memcpy(static_cast<void*>(p), &a2, sizeof a2);
    std::memcpy(static_cast<void*>(p + 2), &b2, sizeof b2);
    return true;
  }
  // As AddFour, with x and y in two lanes and z alone.
  [[gnu::always_inline]] static inline bool AddTwoAndOne(Pair* p, const Vec3& d,
                                                         double g) {
    V2 a0, a1;  // hi0 lo0, hi1 lo1
    std::memcpy(&a0, p, sizeof a0);
    std::memcpy(&a1, p + 1, sizeof a1);
    const V2 hi = __builtin_shufflevector(a0, a1, 0, 2);
    const V2 lo = __builtin_shufflevector(a0, a1, 1, 3);
    V2 s, t, e2;
    double sz, tz, ez;
    ExactSums::TwoSums(hi, lo, V2{d.x, d.y} * g, s, t, e2);
    ExactSums::TwoSums(p[2].hi, p[2].lo, d.z * g, sz, tz, ez);
    const auto exact = e2 == 0;
    if ((exact[0] & exact[1]) == 0 || ez != 0) return false;
    const V2 b0 = __builtin_shufflevector(s, t, 0, 2);
    const V2 b1 = __builtin_shufflevector(s, t, 1, 3);
    std::memcpy(static_cast<void*>(p), &b0, sizeof b0);
    std::memcpy(static_cast<void*>(p + 1), &b1, sizeof b1);
    p[2] = {sz, tz};
    return true;
  }

  template <bool kFour>
  [[gnu::always_inline]] static inline void Loop(ExactSums& sums,
                                                 absl::Span<const RowTerm> row,
                                                 double g) {
    // The sums of the term this far ahead are asked for, for writing (a
    // hint: scatters over large arrays miss the cache on almost every term
    // otherwise). Directly: GCC drops a call to a prefetching function
    // that it does not inline into this always-inline one.
    constexpr size_t kAhead = 8;
    Pair* pairs = sums.pairs_.data();
    for (size_t k = 0; k < row.size(); ++k) {
      if (k + kAhead < row.size()) {
        Pair* ahead = pairs + 3 * int64_t{row[k + kAhead].vertex};
        __builtin_prefetch(ahead, 1);
        __builtin_prefetch(ahead + 2, 1);
      }
      const RowTerm& term = row[k];
      const int64_t o = 3 * int64_t{term.vertex};
      bool done;
      if constexpr (kFour) {
        done = AddFour(pairs + o, term.d, g);
      } else {
        done = AddTwoAndOne(pairs + o, term.d, g);
      }
      if (done) [[likely]] {
        continue;
      }
      sums.Add(o, term.d.x * g);
      sums.Add(o + 1, term.d.y * g);
      sums.Add(o + 2, term.d.z * g);
    }
  }

#if defined(__x86_64__)
  __attribute__((target("avx"))) static void Avx(ExactSums& sums,
                                                 absl::Span<const RowTerm> row,
                                                 double g) {
    Loop<true>(sums, row, g);
  }
#endif
  static void Baseline(ExactSums& sums, absl::Span<const RowTerm> row,
                       double g) {
    Loop<false>(sums, row, g);
  }
};

void ExactSums::AddScaledTerms(absl::Span<const RowTerm> terms, double g,
                               bool avx) {
#if defined(__x86_64__)
  if (avx && CpuHasAvx()) {
    RowScatter::Avx(*this, terms, g);
    return;
  }
#endif
  RowScatter::Baseline(*this, terms, g);
}

}  // namespace meshgauge
