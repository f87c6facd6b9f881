// The hits of one sample's kept rays, evaluated four rays at a time (issue
// 52: EvaluateHit, a chain of products and three divisions per ray, and the
// two divisions of each ray's weight were a third of a VJP on the shared
// meshes).
//
// Each lane does exactly EvaluateHit's operations in its order, and neither
// path may fuse a multiply and an add (the library is built for baseline
// x86-64, and the vector path for AVX, which has none; hit_batch.cc with
// -ffp-contract=off), so every output is the scalar code's bits (HitBatchTest
// compares every field with EvaluateHit's): the Jacobian and the VJP do
// not change. Where the compiler may fuse EvaluateHit's (a target with FMA
// in its baseline, or -mfma), the rays take EvaluateHit one at a time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "lib/core/hit.h"
#include "lib/core/vec3.h"

namespace meshgauge {

class HitBatch {
 public:
  // `avx`: compute in AVX registers where the CPU has them (x86-64; false:
  // in the baseline's, SSE2 pairs, as on CPUs without; for tests).
  explicit HitBatch(bool avx = true) : avx_(avx) {}

  // Empties the batch, with room for `capacity` rays (kept across samples).
  void Reset(int capacity);
  int size() const { return n_; }

  // Appends a ray of weight `weight` from the sample point along unit
  // direction `d` to the primitive of corners `pc` (a triangle or, in 2D, a
  // segment: a batch holds one kind). Precondition: fewer than Reset's
  // capacity rays added since Reset.
  void Add(const PrimitiveCorners& pc, const Vec3& d, double weight) {
    const int i = n_++;
    Set(kAX, i, pc.a);
    Set(kBX, i, pc.b);
    Set(kCX, i, pc.c);
    Set(kDX, i, d);
    A(kWeight)[i] = weight;
    segments_ |= pc.segment;
  }

  // Evaluates every ray from `x`: ok(i) is whether EvaluateHit(pc_i, x,
  // d_i) returns true, and then hit(i) is what it writes.
  void Evaluate(const Vec3& x);
  bool ok(int i) const { return ok_[i] != 0; }
  HitGeometry hit(int i) const {
    HitGeometry h;
    h.t = A(kT)[i];
    h.m = Get(kMX, i);
    h.d_dot_m = A(kDotM)[i];
    for (int j = 0; j < 3; ++j) h.lambda[j] = A(kL0 + j)[i];
    return h;
  }

  // After Evaluate: scale(i) = (weight_i / weight_sum) / (d . m)_i, the
  // factor of m in SampleTerms' derivative of ray i's distance (its two
  // divisions in the same order).
  void Weigh(double weight_sum);
  double scale(int i) const { return A(kScale)[i]; }

  // The arrays of the batch, each of `stride_` doubles (structure of
  // arrays; a Vec3's three arrays are consecutive).
  // clang-format off
  enum Array {
    kAX, kAY, kAZ, kBX, kBY, kBZ, kCX, kCY, kCZ,  // the corners (Add)
    kDX, kDY, kDZ, kWeight,                       // the ray (Add)
    kT, kMX, kMY, kMZ, kDotM, kL0, kL1, kL2,      // Evaluate
    kScale,                                       // Weigh
    kArrays
  };
  // clang-format on

 private:
  double* A(int array) { return buf_.data() + array * stride_; }
  const double* A(int array) const { return buf_.data() + array * stride_; }
  void Set(int first, int i, const Vec3& v) {
    A(first)[i] = v.x;
    A(first + 1)[i] = v.y;
    A(first + 2)[i] = v.z;
  }
  Vec3 Get(int first, int i) const {
    return {A(first)[i], A(first + 1)[i], A(first + 2)[i]};
  }

  bool avx_;
  int n_ = 0;
  size_t stride_ = 0;  // a multiple of 4 rays.
  bool segments_ = false;
  std::vector<double> buf_;
  std::vector<uint8_t> ok_;
};

}  // namespace meshgauge
