// Compiled with -ffp-contract=off (lib/CMakeLists.txt): a build for a CPU
// with fused multiply-add must not fuse the lanes' products and sums, which
// EvaluateHit's do not fuse under the project's baseline flags.
#include "lib/core/hit_batch.h"

#include <cstring>
#include <limits>

namespace meshgauge {
namespace {

// Four doubles, one per ray (GCC's and clang's vector extension: AVX
// registers where the function is built for AVX, pairs of SSE2 registers
// otherwise).
typedef double V __attribute__((vector_size(32)));
typedef int64_t Mask __attribute__((vector_size(32)));

// Three of them: a vector of each lane's ray.
struct V3 {
  V x, y, z;
};

// Lanes [i, i + 4) of the batch's array `array` (A(array) + i). By
// reference, not by value: a V passed or returned by value in the baseline
// build would change the calling convention (GCC's -Wpsabi).
struct Lanes {
  double* base;
  size_t stride;
  int i;
  [[gnu::always_inline]] void Load(V& v, int array) const {
    std::memcpy(&v, base + array * stride + i, sizeof v);
  }
  [[gnu::always_inline]] void Store(int array, const V& v) const {
    std::memcpy(base + array * stride + i, &v, sizeof v);
  }
  // A Vec3's three arrays, from `first`.
  [[gnu::always_inline]] void Load(V3& v, int first) const {
    Load(v.x, first);
    Load(v.y, first + 1);
    Load(v.z, first + 2);
  }
  [[gnu::always_inline]] void Store(int first, const V3& v) const {
    Store(first, v.x);
    Store(first + 1, v.y);
    Store(first + 2, v.z);
  }
};

// Vec3's operator-, Cross and Dot (vec3.h) lane by lane, in their order.
[[gnu::always_inline]] inline void Sub(const V3& a, const V3& b, V3& out) {
  out = {a.x - b.x, a.y - b.y, a.z - b.z};
}
[[gnu::always_inline]] inline void Cross(const V3& a, const V3& b, V3& out) {
  out = {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
[[gnu::always_inline]] inline void Dot(const V3& a, const V3& b, V& out) {
  out = a.x * b.x + a.y * b.y + a.z * b.z;
}

using B = HitBatch;

// EvaluateHit (hit.h) on four lanes, operation for operation.
[[gnu::always_inline]] inline void EvaluateFour(const Lanes& l, const Vec3& x,
                                                uint8_t* ok) {
  V3 a, b, c, d;
  l.Load(a, B::kAX);
  l.Load(b, B::kBX);
  l.Load(c, B::kCX);
  l.Load(d, B::kDX);
  // x in every lane (not 0 + x, which would turn -0 into +0).
  const V3 xs = {
      {x.x, x.x, x.x, x.x}, {x.y, x.y, x.y, x.y}, {x.z, x.z, x.z, x.z}};
  // m = Cross(b - a, c - a), d . m, t = ((a - x) . m) / (d . m).
  V3 ab, ac, m, ax;
  Sub(b, a, ab);
  Sub(c, a, ac);
  Cross(ab, ac, m);
  V dm, am;
  Dot(d, m, dm);
  Sub(a, xs, ax);
  Dot(ax, m, am);
  const V t = am / dm;
  // ah = (x + d t) - a; beta = (Cross(ah, ac) . m) / (m . m), gamma =
  // (Cross(ab, ah) . m) / (m . m).
  const V3 hit = {xs.x + d.x * t, xs.y + d.y * t, xs.z + d.z * t};
  V3 ah, n_beta, n_gamma;
  Sub(hit, a, ah);
  Cross(ah, ac, n_beta);
  Cross(ab, ah, n_gamma);
  V mm, beta, gamma;
  Dot(m, m, mm);
  Dot(n_beta, m, beta);
  Dot(n_gamma, m, gamma);
  beta /= mm;
  gamma /= mm;
  l.Store(B::kT, t);
  l.Store(B::kMX, m);
  l.Store(B::kDotM, dm);
  l.Store(B::kL0, (1 - beta) - gamma);
  l.Store(B::kL1, beta);
  l.Store(B::kL2, gamma);
  // t > 0 and finite (NaN compares false).
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Mask positive = (t > 0) & (t < kInf);
  for (int k = 0; k < 4; ++k) ok[l.i + k] = positive[k] != 0;
}

// The scale of HitBatch::Weigh on four lanes.
[[gnu::always_inline]] inline void WeighFour(const Lanes& l,
                                             double weight_sum) {
  V weight, dm;
  l.Load(weight, B::kWeight);
  l.Load(dm, B::kDotM);
  l.Store(B::kScale, (weight / weight_sum) / dm);
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
  static const bool has_avx = __builtin_cpu_supports("avx");
  if (avx && has_avx) {
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
  if (segments_) {
    // 2D: EvaluateHit's own path for segments, one ray at a time.
    for (int i = 0; i < n_; ++i) {
      PrimitiveCorners pc;
      pc.a = Get(kAX, i);
      pc.b = Get(kBX, i);
      pc.c = Get(kCX, i);
      pc.segment = true;
      HitGeometry h;
      ok_[i] = EvaluateHit(pc, x, Get(kDX, i), &h);
      A(kT)[i] = h.t;
      for (int a = 0; a < 3; ++a) A(kMX + a)[i] = h.m[a];
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
