// An exact accumulator of doubles: the sum of any number of finite doubles
// is held without rounding and rounded once, so that it does not depend on
// the order of the additions or on how they were split into partial sums
// (the VJP's and the penalty's cross-sample sums: a sample range's partial
// sums, merged by a client, give the single pass's bits).
//
// Representation: the value is sum_i limbs[i] 2^(32 (base + i) - 1074), each
// limb a signed 64-bit integer that receives 32-bit chunks (carries are
// propagated before a limb can overflow), over a window of limbs that grows
// as the additions need: a sum of values within 2^64 of each other holds 3
// or 4 limbs. Non-finite inputs are not summed: NaN, or +inf and -inf both,
// make the sum NaN; +inf (-inf) alone makes it +inf (-inf), as IEEE
// addition would in any order.
#pragma once

#include <cstdint>
#include <type_traits>
#include <vector>

#include "absl/container/flat_hash_map.h"
#include "absl/container/inlined_vector.h"
#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/table_allocator.h"

namespace meshgauge {

struct RowTerm;  // lib/core/row_term.h

class ExactSum {
 public:
  ExactSum() = default;

  void Add(double x);
  void Add(const ExactSum& other);
  ExactSum& operator+=(double x) {
    Add(x);
    return *this;
  }

  // The double nearest the exact value (ties to even); +-inf beyond the
  // largest double (as IEEE rounding of the exact value would give), the
  // infinity or NaN of non-finite inputs. Exact zero is +0.
  double Round() const;

  // The exact value as a short list of doubles whose exact sum it is:
  // Round() first, then the rounded rest, and so on (each term rounds the
  // value left by the ones before; at most one term per 53 bits of the
  // value's span). Empty for exact zero; one entry (inf or NaN) for a
  // non-finite sum. Add()ing the terms to an empty ExactSum gives this sum.
  std::vector<double> Terms() const;

  bool IsZero() const;

 private:
  // Propagates carries so that every limb but the top one is in [0, 2^32).
  void Normalize();
  // Makes limb index k (absolute) part of the window.
  void Cover(int32_t first, int32_t last);
  void AddChunk(int32_t k, int64_t chunk) { limbs_[k - base_] += chunk; }

  int32_t base_ = 0;
  // Additions since the last Normalize: each adds less than 2^32 in
  // magnitude to a limb, so 2^30 of them cannot overflow one.
  uint32_t pending_ = 0;
  uint8_t special_ = 0;  // bit 0: +inf seen, bit 1: -inf, bit 2: NaN.
  absl::InlinedVector<int64_t, 4> limbs_;
};

// n exact sums in one array, for scatters over many accumulators (the VJP's
// and the penalty's sums per vertex and per sample), 16 bytes each: sum i
// is held as two doubles hi + lo, exactly, as long as an addition's error
// fits in them (TwoSum twice: values within about 2^50 of each other in
// magnitude); an addition that does not fit, or a non-finite one, goes
// whole to an ExactSum kept for that index alone. The value, its rounding
// and its terms are ExactSum's, so nothing depends on the order of the
// additions or on which of the two paths took them.
class ExactSums {
 public:
  ExactSums() = default;
  explicit ExactSums(int64_t n) : pairs_(n) {}

  int64_t size() const { return static_cast<int64_t>(pairs_.size()); }
  // Where the sums are held (for tests of their memory).
  const void* storage() const { return pairs_.data(); }

  // Adds x to sum i, 0 <= i < size().
  void Add(int64_t i, double x) {
    Pair& p = pairs_[i];
    double s, t, e2;
    TwoSums(p.hi, p.lo, x, s, t, e2);
    if (e2 == 0) [[likely]] {
      p.hi = s;
      p.lo = t;
      return;
    }
    Spill(i, x);
  }
  // Adds g * t.d to the sums 3 v, 3 v + 1 and 3 v + 2 of each term t (v =
  // t.vertex), in the terms' order: the VJP's scatter of a sample's row
  // into x, y, z sums per vertex. The bits of Add(3 v, g * t.d.x), Add(3 v
  // + 1, g * t.d.y), Add(3 v + 2, g * t.d.z) term by term (the products
  // never fused into the sums), with a term's TwoSums lane by lane: the
  // three in one AVX vector where the CPU has AVX and `avx`, else x and y
  // in an SSE2 pair (or the target's vector extension) and z alone
  // (exact_sums_rows.cc). Precondition: 0 <= 3 v + 2 < size() for every
  // term.
  void AddScaledTerms(absl::Span<const RowTerm> terms, double g,
                      bool avx = true);
  // As ExactSum::Round and ExactSum::Terms of sum i.
  double Round(int64_t i) const;
  std::vector<double> Terms(int64_t i) const;

 private:
  // Adds x to sum i's ExactSum (out of line: Add's rare path).
  void Spill(int64_t i, double x);
  // Sum i as an ExactSum (its spill, if any, and its two doubles).
  ExactSum Exact(int64_t i) const;

  struct Pair {
    double hi = 0;
    double lo = 0;
  };
  // The two TwoSums of adding x to a pair (hi, lo): hi + x = s + e1,
  // lo + e1 = t + e2, on doubles or, lane by lane, on vectors of them
  // (AddScaledTerms). Once a step is inf or NaN, every later one is (an
  // overflow of s makes s - s_x inf - inf, one of t makes t - t_e so), so
  // e2 is NaN when anything overflowed or x is not finite; e2 == 0 says
  // both were exact and (s, t) holds the sum. Outputs by reference: a
  // vector returned by value in a baseline build would change the calling
  // convention (GCC's -Wpsabi).
  template <typename V>
  [[gnu::always_inline]] static inline void TwoSums(const V& hi, const V& lo,
                                                    const V& x, V& s, V& t,
                                                    V& e2) {
    s = hi + x;
    const V s_x = s - hi;
    const V e1 = (hi - (s - s_x)) + (x - s_x);
    t = lo + e1;
    const V t_e = t - lo;
    e2 = (lo - (t - t_e)) + (e1 - t_e);
  }
  // AddScaledTerms' loop, built for AVX or for the baseline.
  friend struct RowScatter;
  // A TableVector: a large array (the VJP's, 48 bytes a vertex) sits in
  // huge pages, as a fresh one is made for every VJP and 4 KiB pages cost
  // about 12 us each to fault in on this project's machines.
  TableVector<Pair> pairs_;
  // TableAllocator default-initializes: Pair's initializers zero new sums.
  static_assert(!std::is_trivially_default_constructible_v<Pair>);
  absl::flat_hash_map<int64_t, ExactSum> spill_;
};

}  // namespace meshgauge
