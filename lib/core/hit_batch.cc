// Compiled with -ffp-contract=off (lib/CMakeLists.txt): the lanes' products
// and sums are never fused, as EvaluateHit's are not where the target has no
// fused multiply-add (x86-64's baseline; on other targets, or with -mfma,
// the lanes take EvaluateHit itself: kLanesAreEvaluateHit).
#include "lib/core/hit_batch.h"

#include <cstring>
#include <limits>

#include "lib/core/double_lanes.h"

namespace meshgauge {
namespace {

// Whether the vector lanes give EvaluateHit's bits: only where the compiler
// cannot fuse EvaluateHit's products and sums (GCC fuses by default where
// the target has FMA).
#if defined(__x86_64__) && !defined(__FMA__)
constexpr bool kLanesAreEvaluateHit = true;
#else
constexpr bool kLanesAreEvaluateHit = false;
#endif

// A 3-vector of each lane's ray (a V4 lane per ray).
struct V3x4 {
  V4 x, y, z;
};

// Lanes [i, i + 4) of the batch's array `array` (A(array) + i). By
// reference, not by value: a V4 passed or returned by value in the baseline
// build would change the calling convention (GCC's -Wpsabi).
struct Lanes {
  double* base;
  size_t stride;
  int i;
  [[gnu::always_inline]] void Load(V4& v, int array) const {
    std::memcpy(&v, base + array * stride + i, sizeof v);
  }
  [[gnu::always_inline]] void Store(int array, const V4& v) const {
    std::memcpy(base + array * stride + i, &v, sizeof v);
  }
  // A Vec3's three arrays, from `first`.
  [[gnu::always_inline]] void Load(V3x4& v, int first) const {
    Load(v.x, first);
    Load(v.y, first + 1);
    Load(v.z, first + 2);
  }
  [[gnu::always_inline]] void Store(int first, const V3x4& v) const {
    Store(first, v.x);
    Store(first + 1, v.y);
    Store(first + 2, v.z);
  }
};

// Vec3's operator-, Cross and Dot (vec3.h) lane by lane, in their order.
[[gnu::always_inline]] inline void Sub(const V3x4& a, const V3x4& b,
                                       V3x4& out) {
  out = {a.x - b.x, a.y - b.y, a.z - b.z};
}
[[gnu::always_inline]] inline void Cross(const V3x4& a, const V3x4& b,
                                         V3x4& out) {
  out = {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
[[gnu::always_inline]] inline void Dot(const V3x4& a, const V3x4& b, V4& out) {
  out = a.x * b.x + a.y * b.y + a.z * b.z;
}

// EvaluateHit (hit.h) on four lanes, operation for operation.
[[gnu::always_inline]] inline void EvaluateFour(const Lanes& l, const Vec3& x,
                                                uint8_t* ok) {
  V3x4 a, b, c, d;
  l.Load(a, HitBatch::kAX);
  l.Load(b, HitBatch::kBX);
  l.Load(c, HitBatch::kCX);
  l.Load(d, HitBatch::kDX);
  // x in every lane (not 0 + x, which would turn -0 into +0).
  const V3x4 xs = {
      {x.x, x.x, x.x, x.x}, {x.y, x.y, x.y, x.y}, {x.z, x.z, x.z, x.z}};
  // m = Cross(b - a, c - a), d . m, t = ((a - x) . m) / (d . m).
  V3x4 ab, ac, m, ax;
  Sub(b, a, ab);
  Sub(c, a, ac);
  Cross(ab, ac, m);
  V4 dm, am;
  Dot(d, m, dm);
  Sub(a, xs, ax);
  Dot(ax, m, am);
  const V4 t = am / dm;
  // ah = (x + d t) - a; beta = (Cross(ah, ac) . m) / (m . m), gamma =
  // (Cross(ab, ah) . m) / (m . m).
  const V3x4 hit = {xs.x + d.x * t, xs.y + d.y * t, xs.z + d.z * t};
  V3x4 ah, n_beta, n_gamma;
  Sub(hit, a, ah);
  Cross(ah, ac, n_beta);
  Cross(ab, ah, n_gamma);
  V4 mm, beta, gamma;
  Dot(m, m, mm);
  Dot(n_beta, m, beta);
  Dot(n_gamma, m, gamma);
  beta /= mm;
  gamma /= mm;
  l.Store(HitBatch::kT, t);
  l.Store(HitBatch::kMX, m);
  l.Store(HitBatch::kDotM, dm);
  l.Store(HitBatch::kL0, (1 - beta) - gamma);
  l.Store(HitBatch::kL1, beta);
  l.Store(HitBatch::kL2, gamma);
  // t > 0 and finite (NaN compares false).
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const auto positive = (t > 0) & (t < kInf);
  for (int k = 0; k < 4; ++k) ok[l.i + k] = positive[k] != 0;
}

// The scale of HitBatch::Weigh on four lanes.
[[gnu::always_inline]] inline void WeighFour(const Lanes& l,
                                             double weight_sum) {
  V4 weight, dm;
  l.Load(weight, HitBatch::kWeight);
  l.Load(dm, HitBatch::kDotM);
  l.Store(HitBatch::kScale, (weight / weight_sum) / dm);
}

// One pass over the lanes [0, n): Evaluate's or Weigh's.
struct Job {
  double* base;
  size_t stride;
  int n;
  bool weigh;
  Vec3 x;
  double weight_sum;
  uint8_t* ok;
};

[[gnu::always_inline]] inline void RunLanes(const Job& job) {
  for (int i = 0; i < job.n; i += 4) {
    const Lanes l{job.base, job.stride, i};
    if (job.weigh) {
      WeighFour(l, job.weight_sum);
    } else {
      EvaluateFour(l, job.x, job.ok);
    }
  }
}

#if defined(__x86_64__)
__attribute__((target("avx"))) void RunAvx(const Job& job) { RunLanes(job); }
#endif
void RunBaseline(const Job& job) { RunLanes(job); }

// In AVX registers when `avx` and the CPU has them, else in the baseline's.
void Run(bool avx, const Job& job) {
#if defined(__x86_64__)
  if (avx && CpuHasAvx()) {
    RunAvx(job);
    return;
  }
#endif
  RunBaseline(job);
}

}  // namespace

void HitBatch::Reset(int capacity) {
  n_ = 0;
  segments_ = false;
  const size_t padded = (static_cast<size_t>(capacity) + 3) / 4 * 4;
  if (stride_ >= padded) return;
  stride_ = padded;
  buf_.assign(kArrays * stride_, 0.0);
  ok_.assign(stride_, 0);
}

void HitBatch::Evaluate(const Vec3& x) {
  if (segments_ || !kLanesAreEvaluateHit) {
    // 2D segments, or a target where only EvaluateHit gives its own bits:
    // one ray at a time.
    for (int i = 0; i < n_; ++i) {
      PrimitiveCorners pc;
      pc.a = Get(kAX, i);
      pc.b = Get(kBX, i);
      pc.c = Get(kCX, i);
      pc.segment = segments_;
      HitGeometry h;
      ok_[i] = EvaluateHit(pc, x, Get(kDX, i), &h);
      A(kT)[i] = h.t;
      Set(kMX, i, h.m);
      A(kDotM)[i] = h.d_dot_m;
      for (int j = 0; j < 3; ++j) A(kL0 + j)[i] = h.lambda[j];
    }
    return;
  }
  // Every lane in vectors, the padding's included (its results are not
  // read), so that a ray's bits do not depend on its place in the batch.
  Run(avx_, {buf_.data(), stride_, n_, /*weigh=*/false, x, 0, ok_.data()});
}

void HitBatch::Weigh(double weight_sum) {
  Run(avx_,
      {buf_.data(), stride_, n_, /*weigh=*/true, {}, weight_sum, ok_.data()});
}

}  // namespace meshgauge
