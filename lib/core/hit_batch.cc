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
};

using B = HitBatch;

// EvaluateHit (hit.h) on four lanes, operation for operation.
[[gnu::always_inline]] inline void EvaluateFour(const Lanes& l, const Vec3& x,
                                                uint8_t* ok) {
  V ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz;
  l.Load(ax, B::kAX);
  l.Load(ay, B::kAY);
  l.Load(az, B::kAZ);
  l.Load(bx, B::kBX);
  l.Load(by, B::kBY);
  l.Load(bz, B::kBZ);
  l.Load(cx, B::kCX);
  l.Load(cy, B::kCY);
  l.Load(cz, B::kCZ);
  l.Load(dx, B::kDX);
  l.Load(dy, B::kDY);
  l.Load(dz, B::kDZ);
  // m = Cross(b - a, c - a).
  const V abx = bx - ax, aby = by - ay, abz = bz - az;
  const V acx = cx - ax, acy = cy - ay, acz = cz - az;
  const V mx = aby * acz - abz * acy;
  const V my = abz * acx - abx * acz;
  const V mz = abx * acy - aby * acx;
  // d . m, t = ((a - x) . m) / (d . m).
  const V dm = dx * mx + dy * my + dz * mz;
  const V t = ((ax - x.x) * mx + (ay - x.y) * my + (az - x.z) * mz) / dm;
  // ah = (x + d t) - a; lambda from Cross(ah, ac) . m and Cross(ab, ah) . m
  // over m . m.
  const V ahx = (x.x + dx * t) - ax;
  const V ahy = (x.y + dy * t) - ay;
  const V ahz = (x.z + dz * t) - az;
  const V mm = mx * mx + my * my + mz * mz;
  const V beta = ((ahy * acz - ahz * acy) * mx + (ahz * acx - ahx * acz) * my +
                  (ahx * acy - ahy * acx) * mz) /
                 mm;
  const V gamma = ((aby * ahz - abz * ahy) * mx + (abz * ahx - abx * ahz) * my +
                   (abx * ahy - aby * ahx) * mz) /
                  mm;
  l.Store(B::kT, t);
  l.Store(B::kMX, mx);
  l.Store(B::kMY, my);
  l.Store(B::kMZ, mz);
  l.Store(B::kDotM, dm);
  l.Store(B::kL0, (1 - beta) - gamma);
  l.Store(B::kL1, beta);
  l.Store(B::kL2, gamma);
  // t > 0 and finite (NaN compares false).
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Mask hit = (t > 0) & (t < kInf);
  for (int k = 0; k < 4; ++k) ok[l.i + k] = hit[k] != 0;
}

// The scale of HitBatch::Weigh on four lanes.
[[gnu::always_inline]] inline void WeighFour(const Lanes& l,
                                             double weight_sum) {
  V weight, dm;
  l.Load(weight, B::kWeight);
  l.Load(dm, B::kDotM);
  l.Store(B::kScale, (weight / weight_sum) / dm);
}

__attribute__((target("avx"))) void EvaluateAvx(double* base, size_t stride,
                                                int n, const Vec3& x,
                                                uint8_t* ok) {
  for (int i = 0; i < n; i += 4) EvaluateFour({base, stride, i}, x, ok);
}
void EvaluateBaseline(double* base, size_t stride, int n, const Vec3& x,
                      uint8_t* ok) {
  for (int i = 0; i < n; i += 4) EvaluateFour({base, stride, i}, x, ok);
}
__attribute__((target("avx"))) void WeighAvx(double* base, size_t stride, int n,
                                             double weight_sum) {
  for (int i = 0; i < n; i += 4) WeighFour({base, stride, i}, weight_sum);
}
void WeighBaseline(double* base, size_t stride, int n, double weight_sum) {
  for (int i = 0; i < n; i += 4) WeighFour({base, stride, i}, weight_sum);
}

bool HasAvx() {
  static const bool avx = __builtin_cpu_supports("avx");
  return avx;
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
  if (avx_ && HasAvx()) {
    EvaluateAvx(buf_.data(), stride_, n_, x, ok_.data());
  } else {
    EvaluateBaseline(buf_.data(), stride_, n_, x, ok_.data());
  }
}

void HitBatch::Weigh(double weight_sum) {
  if (avx_ && HasAvx()) {
    WeighAvx(buf_.data(), stride_, n_, weight_sum);
  } else {
    WeighBaseline(buf_.data(), stride_, n_, weight_sum);
  }
}

}  // namespace meshgauge
