#include "lib/core/hit_batch.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "lib/core/hit.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Bits;

struct Ray {
  PrimitiveCorners pc;
  Vec3 d;
  double weight = 1;
};

Vec3 Unit(const Vec3& v) { return v / Norm(v); }

// Rays from `x` to random triangles of every scale, with the cases that
// have no hit among them: along the plane, away from it, degenerate.
std::vector<Ray> RandomRays(const Vec3& x, int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  auto point = [&](double scale) {
    return Vec3{u(rng), u(rng), u(rng)} * scale;
  };
  std::vector<Ray> rays;
  for (int i = 0; i < n; ++i) {
    const double scale = std::ldexp(1.0, static_cast<int>(u(rng) * 20));
    Ray r;
    r.pc.a = point(scale);
    r.pc.b = point(scale);
    r.pc.c = point(scale);
    // Most rays aim at a point of the triangle, so that they hit it.
    const Vec3 target = (r.pc.a + r.pc.b * 2 + r.pc.c * 3) / 6;
    r.d = Unit(target - x + point(scale * 0.1));
    r.weight = 1 / (0.05 + std::abs(u(rng)));
    switch (i % 7) {
      case 1:  // along the plane: d . m = 0 or nearly
        r.d = Unit(r.pc.b - r.pc.a);
        break;
      case 2:  // away from it
        r.d = -r.d;
        break;
      case 3:  // a degenerate triangle: m = 0
        r.pc.c = r.pc.b;
        break;
      default:
        break;
    }
    rays.push_back(r);
  }
  return rays;
}

// Every field EvaluateHit writes, bit for bit (lambda only with a hit:
// EvaluateHit stops before it otherwise), and with a hit SampleTerms'
// scale (weight / weight_sum) / (d . m) once the batch is weighed.
void ExpectEvaluateHitsBits(const HitBatch& batch, int i, const Ray& r,
                            const Vec3& x, double weight_sum = 0) {
  HitGeometry want;
  const bool ok = EvaluateHit(r.pc, x, r.d, &want);
  ASSERT_EQ(batch.ok(i), ok) << "ray " << i;
  const HitGeometry got = batch.hit(i);
  EXPECT_EQ(Bits(got.t), Bits(want.t)) << "ray " << i;
  EXPECT_EQ(Bits(got.d_dot_m), Bits(want.d_dot_m)) << "ray " << i;
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(Bits(got.m[a]), Bits(want.m[a])) << "ray " << i;
  }
  if (!ok) return;
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(Bits(got.lambda[j]), Bits(want.lambda[j])) << "ray " << i;
  }
  if (weight_sum == 0) return;
  const double c = r.weight / weight_sum;
  EXPECT_EQ(Bits(batch.scale(i)), Bits(c / want.d_dot_m)) << "ray " << i;
}

// Rays whose distance is exactly a boundary case: d . m == 0 with the
// origin off the plane (t infinite) and on it (t NaN), the origin on the
// triangle (t = 0), and coordinates of -0 (kept by the lanes, whose x is
// not 0 + x).
std::vector<Ray> EdgeCaseRays(const Vec3& x) {
  const Vec3 a = x + Vec3{-1, -1, 2}, b = x + Vec3{3, -1, 2},
             c = x + Vec3{-1, 3, 2};
  std::vector<Ray> rays;
  rays.push_back({{a, b, c}, {1, 0, 0}});  // along the plane z = x.z + 2
  rays.push_back({{x + Vec3{-1, -1, 0}, x + Vec3{3, -1, 0}, x + Vec3{-1, 3, 0}},
                  {0, 1, 0}});  // along a plane through x: 0 / 0
  rays.push_back({{x + Vec3{-1, -1, 0}, x + Vec3{3, -1, 0}, x + Vec3{-1, 3, 0}},
                  {0, 0, 1}});  // from a point of the triangle: t = 0
  rays.push_back({{{-0.0, -1, 1}, {-0.0, 1, 1}, {1, -0.0, 1}}, {0, 0, 1}});
  rays.push_back({{a, b, c}, {0, 0, 1}});  // a plain hit
  return rays;
}

void ExpectBatchesAreEvaluateHitsBits(bool avx) {
  for (const Vec3 x : {Vec3{0.1, -0.25, 0.3}, Vec3{-0.0, 0.0, -0.0}}) {
    std::vector<Ray> rays = RandomRays(x, 4000, 7);
    const std::vector<Ray> edge = EdgeCaseRays(x);
    for (size_t i = 0; i < edge.size(); ++i) rays[97 * i + 5] = edge[i];
    int hits = 0;
    HitBatch batch(avx);
    // Batches of every size from 1 to 13 (padding lanes in every
    // position), the same object reused from larger to smaller.
    for (size_t first = 0, k = 0; first < rays.size(); ++k) {
      const int n = static_cast<int>(std::min(1 + k % 13, rays.size() - first));
      batch.Reset(n);
      double weight_sum = 0;
      for (int i = 0; i < n; ++i) {
        const Ray& r = rays[first + i];
        batch.Add(r.pc, r.d, r.weight);
        weight_sum += r.weight;
      }
      batch.Evaluate(x);
      batch.Weigh(weight_sum);
      ASSERT_EQ(batch.size(), n);
      for (int i = 0; i < n; ++i) {
        ExpectEvaluateHitsBits(batch, i, rays[first + i], x, weight_sum);
        hits += batch.ok(i);
      }
      first += n;
    }
    // Both kinds were seen.
    EXPECT_GT(hits, 1000);
    EXPECT_LT(hits, 3900);
  }
}

TEST(HitBatchTest, EveryRayGetsTheScalarBitsInAvxRegisters) {
#if defined(__x86_64__)
  if (!__builtin_cpu_supports("avx")) GTEST_SKIP() << "no AVX on this CPU";
#endif
  ExpectBatchesAreEvaluateHitsBits(/*avx=*/true);
}

TEST(HitBatchTest, EveryRayGetsTheScalarBitsInSse2Pairs) {
  ExpectBatchesAreEvaluateHitsBits(/*avx=*/false);
}

TEST(HitBatchTest, SegmentsGetEvaluateHitsBits) {
  const Vec3 x{0.5, 0.5, 0};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-2, 2);
  HitBatch batch;
  batch.Reset(50);
  std::vector<Ray> rays;
  double weight_sum = 0;
  for (int i = 0; i < 50; ++i) {
    Ray r;
    r.pc.a = {u(rng), u(rng), 0};
    r.pc.b = {u(rng), u(rng), 0};
    r.pc.segment = true;
    r.d = Unit((r.pc.a + r.pc.b) / 2 - x + Vec3{u(rng), u(rng), 0} * 0.1);
    if (i % 5 == 0) r.d = -r.d;
    r.weight = 1 + i % 3;
    rays.push_back(r);
    batch.Add(r.pc, r.d, r.weight);
    weight_sum += r.weight;
  }
  batch.Evaluate(x);
  batch.Weigh(weight_sum);
  for (int i = 0; i < 50; ++i) {
    ExpectEvaluateHitsBits(batch, i, rays[i], x, weight_sum);
  }
}

}  // namespace
}  // namespace meshgauge
