// Compiled with -ffp-contract=off (lib/CMakeLists.txt): a triangle's edge
// functions must be exactly the negation of its neighbour's across their
// shared edge, which a contracted a * b - c * d would break. The loops over
// a triangle's three corners are unrolled by pragma: at -O2 GCC leaves them
// rolled, its vectors in memory (a pass that walks took 1.07-1.18 times as
// long on the teapot, the tray, spot and the knight; docs/benchmarks.md).
#include "lib/embree/cone_walk.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include "lib/embree/fan_filter.h"

namespace meshgauge {
namespace {

constexpr int kLanes = 8;
constexpr float kInf = std::numeric_limits<float>::infinity();
// The widest cone walked: cos(80 degrees).
constexpr float kMinCos = 0.1736f;
// Margins that keep the node and group tests conservative under
// single-precision rounding (relative to the sizes compared).
constexpr float kMargin = 1e-4f;

#if defined(__x86_64__)
// A fan's rays, regrouped kLanes at a time by where they point
// (structure of arrays; slot s = group * kLanes + lane).
struct FanSlots {
  // In the cone's frame (u, v, axis) ray d runs along (sx, sy, 1) / iz:
  // sx = d.u / d.axis, sy = d.v / d.axis, iz = 1 / d.axis.
  std::vector<float> sx, sy, iz, start, limit;
  std::vector<int32_t> ray;  // -1: padding.
  // Per group: the box of its rays' projections onto the plane at distance
  // 1 along the axis.
  std::vector<float> lo_x, hi_x, lo_y, hi_y;
  std::vector<float> fx, fy, fz, px, py, inv;  // per ray.
  std::vector<uint8_t> key;               // per ray.
  std::vector<int32_t> order;
  int groups = 0;
};

struct Cone {
  float o[3];
  float axis[3], u[3], v[3];
  float cos_half = 0, sin_half = 0;
  float length = 1;  // the longest direction's length.
};

// The dot products of 8 vectors (x, y, z) with w.
[[gnu::always_inline]] inline __attribute__((target("avx2,fma"))) __m256 Dot8(
    __m256 x, __m256 y, __m256 z, const float* w) {
  return _mm256_fmadd_ps(
      z, _mm256_set1_ps(w[2]),
      _mm256_fmadd_ps(y, _mm256_set1_ps(w[1]),
                      _mm256_mul_ps(x, _mm256_set1_ps(w[0]))));
}

// The smallest and the largest of v's lanes.
[[gnu::always_inline]] inline __attribute__((target("avx2,fma"))) float
ReduceMin(__m256 v) {
  alignas(32) float lanes[kLanes];
  _mm256_store_ps(lanes, v);
  return *std::min_element(lanes, lanes + kLanes);
}
[[gnu::always_inline]] inline __attribute__((target("avx2,fma"))) float
ReduceMax(__m256 v) {
  alignas(32) float lanes[kLanes];
  _mm256_store_ps(lanes, v);
  return *std::max_element(lanes, lanes + kLanes);
}

// The fan's cone and its rays' slots; false for rays outside a cone of
// half-angle 80 degrees about `axis` (null: the rays' mean direction).
__attribute__((target("avx2,fma"))) bool SetUpFan(
    const Vec3& origin, absl::Span<const Vec3> dirs, const Vec3* axis,
    absl::Span<const float> starts, float t_near, float t_far, Cone& cone,
    FanSlots& s) {
  const size_t n = dirs.size();
  Vec3 sum;
  double longest2 = 0;
  for (const Vec3& d : dirs) {
    sum += d;
    longest2 = std::max(longest2, Dot(d, d));
  }
  if (axis != nullptr) sum = *axis;
  const double longest = std::sqrt(longest2);
  const double sum_norm = Norm(sum);
  if (!(sum_norm > 0) || !(longest > 0)) return false;
  const Vec3 a = sum / sum_norm;
  // u: any unit vector orthogonal to the axis.
  Vec3 u = std::abs(a.x) < 0.9 ? Vec3(0, a.z, -a.y) : Vec3(-a.z, 0, a.x);
  u = u / Norm(u);
  const Vec3 v = Cross(a, u);
  cone.o[0] = static_cast<float>(origin.x);
  cone.o[1] = static_cast<float>(origin.y);
  cone.o[2] = static_cast<float>(origin.z);
  for (int i = 0; i < 3; ++i) {
    cone.axis[i] = static_cast<float>(a[i]);
    cone.u[i] = static_cast<float>(u[i]);
    cone.v[i] = static_cast<float>(v[i]);
  }
  cone.length = static_cast<float>(longest) * (1 + kMargin);
  // The rays in single precision (padded with copies of the last), then
  // their projections, 8 at a time.
  const size_t padded = (n + kLanes - 1) / kLanes * kLanes;
  for (auto* f : {&s.fx, &s.fy, &s.fz, &s.px, &s.py, &s.inv}) {
    f->resize(padded);
  }
  for (size_t k = 0; k < padded; ++k) {
    const Vec3& d = dirs[std::min(k, n - 1)];
    s.fx[k] = static_cast<float>(d.x);
    s.fy[k] = static_cast<float>(d.y);
    s.fz[k] = static_cast<float>(d.z);
  }
  __m256 min_cos = _mm256_set1_ps(1), lo_x = _mm256_set1_ps(kInf),
         hi_x = _mm256_set1_ps(-kInf), lo_y = lo_x, hi_y = hi_x;
  const __m256 zero = _mm256_setzero_ps();
  for (size_t k = 0; k < padded; k += kLanes) {
    const __m256 x = _mm256_loadu_ps(&s.fx[k]);
    const __m256 y = _mm256_loadu_ps(&s.fy[k]);
    const __m256 z = _mm256_loadu_ps(&s.fz[k]);
    const __m256 along = Dot8(x, y, z, cone.axis);
    if (_mm256_movemask_ps(_mm256_cmp_ps(along, zero, _CMP_GT_OQ)) != 0xff) {
      return false;
    }
    const __m256 norm = _mm256_sqrt_ps(
        _mm256_fmadd_ps(z, z, _mm256_fmadd_ps(y, y, _mm256_mul_ps(x, x))));
    min_cos = _mm256_min_ps(min_cos, _mm256_div_ps(along, norm));
    const __m256 inv = _mm256_div_ps(_mm256_set1_ps(1), along);
    const __m256 px = _mm256_mul_ps(Dot8(x, y, z, cone.u), inv);
    const __m256 py = _mm256_mul_ps(Dot8(x, y, z, cone.v), inv);
    _mm256_storeu_ps(&s.inv[k], inv);
    _mm256_storeu_ps(&s.px[k], px);
    _mm256_storeu_ps(&s.py[k], py);
    lo_x = _mm256_min_ps(lo_x, px);
    hi_x = _mm256_max_ps(hi_x, px);
    lo_y = _mm256_min_ps(lo_y, py);
    hi_y = _mm256_max_ps(hi_y, py);
  }
  const float cos_min = ReduceMin(min_cos);
  const float box_lo_x = ReduceMin(lo_x), box_hi_x = ReduceMax(hi_x);
  const float box_lo_y = ReduceMin(lo_y), box_hi_y = ReduceMax(hi_y);
  if (!(cos_min > kMinCos)) return false;
  cone.cos_half = std::max(0.0f, cos_min - kMargin);
  cone.sin_half = std::sqrt(1 - cone.cos_half * cone.cos_half);

  // Rays sorted by their cell of a 4 x 4 grid over the projections, the
  // cells in Morton order, so that kLanes consecutive rays point close
  // together; a counting sort, stable.
  s.key.resize(n);
  const float scale_x = box_hi_x > box_lo_x ? 4 / (box_hi_x - box_lo_x) : 0;
  const float scale_y = box_hi_y > box_lo_y ? 4 / (box_hi_y - box_lo_y) : 0;
  int counts[17] = {};
  for (size_t k = 0; k < n; ++k) {
    const int cx =
        std::min(3, static_cast<int>((s.px[k] - box_lo_x) * scale_x));
    const int cy =
        std::min(3, static_cast<int>((s.py[k] - box_lo_y) * scale_y));
    s.key[k] = static_cast<uint8_t>((cx & 1) | (cy & 1) << 1 | (cx & 2) << 1 |
                                    (cy & 2) << 2);
    ++counts[s.key[k] + 1];
  }
  for (int c = 0; c < 16; ++c) counts[c + 1] += counts[c];
  s.order.resize(n);
  for (size_t k = 0; k < n; ++k) {
    s.order[counts[s.key[k]]++] = static_cast<int32_t>(k);
  }

  s.groups = static_cast<int>((n + kLanes - 1) / kLanes);
  const size_t slots = static_cast<size_t>(s.groups) * kLanes;
  for (auto* f : {&s.sx, &s.sy, &s.iz, &s.start, &s.limit}) f->resize(slots);
  s.ray.resize(slots);
  for (auto* f : {&s.lo_x, &s.lo_y}) f->assign(s.groups, kInf);
  for (auto* f : {&s.hi_x, &s.hi_y}) f->assign(s.groups, -kInf);
  const float pad =
      kMargin * (1 + std::max({std::abs(box_lo_x), std::abs(box_hi_x),
                               std::abs(box_lo_y), std::abs(box_hi_y)}));
  for (size_t slot = 0; slot < slots; ++slot) {
    const size_t g = slot / kLanes;
    if (slot >= n) {
      // No start before infinity, no limit past -infinity.
      s.sx[slot] = s.sy[slot] = s.iz[slot] = 0;
      s.start[slot] = kInf;
      s.limit[slot] = -kInf;
      s.ray[slot] = -1;
      continue;
    }
    const int32_t k = s.order[slot];
    s.sx[slot] = s.px[k];
    s.sy[slot] = s.py[k];
    s.iz[slot] = s.inv[k];
    s.start[slot] = starts.empty() ? t_near : starts[k];
    s.limit[slot] = t_far;
    s.ray[slot] = k;
    s.lo_x[g] = std::min(s.lo_x[g], s.px[k] - pad);
    s.hi_x[g] = std::max(s.hi_x[g], s.px[k] + pad);
    s.lo_y[g] = std::min(s.lo_y[g], s.py[k] - pad);
    s.hi_y[g] = std::max(s.hi_y[g], s.py[k] + pad);
  }
  return true;
}

// Up to kLanes candidate triangles, tested together: their corners, then
// the corners relative to the fan's origin in the cone's frame (u, v,
// axis): frame[corner][0, 1, 2] = X, Y, Z.
struct Batch {
  alignas(32) float corner[3][3][kLanes];  // [corner][coordinate][lane]
  alignas(32) float frame[3][3][kLanes];
  int32_t prim[kLanes];
  int count = 0;
};

// Which lanes of the batch group g's rays can meet, per group; the batch's
// corners in the cone's frame. The lanes of a triangle whose corners all lie
// behind the plane through the origin normal to the axis meet none; one with a
// corner near or behind it may meet every group; the others, the groups whose
// boxes their projection's box overlaps.
__attribute__((target("avx2,fma"))) void PrepareBatch(const Cone& cone,
                                                      const FanSlots& s,
                                                      Batch& b,
                                                      uint8_t* lanes_of_group) {
  const __m256 used = _mm256_castsi256_ps(_mm256_cmpgt_epi32(
      _mm256_set1_epi32(b.count), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
  __m256 c[3][3];
  __m256 size = _mm256_setzero_ps();
  const __m256 sign = _mm256_set1_ps(-0.0f);
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i) {
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) {
      c[i][j] = _mm256_sub_ps(_mm256_load_ps(b.corner[i][j]),
                              _mm256_set1_ps(cone.o[j]));
      size = _mm256_max_ps(size, _mm256_andnot_ps(sign, c[i][j]));
    }
  }
  __m256 z[3], px[3], py[3];
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i) {
    z[i] = Dot8(c[i][0], c[i][1], c[i][2], cone.axis);
    px[i] = Dot8(c[i][0], c[i][1], c[i][2], cone.u);
    py[i] = Dot8(c[i][0], c[i][1], c[i][2], cone.v);
    _mm256_store_ps(b.frame[i][0], px[i]);
    _mm256_store_ps(b.frame[i][1], py[i]);
    _mm256_store_ps(b.frame[i][2], z[i]);
  }
  const __m256 tiny = _mm256_mul_ps(_mm256_set1_ps(kMargin), size);
  const __m256 z_lo = _mm256_min_ps(z[0], _mm256_min_ps(z[1], z[2]));
  const __m256 z_hi = _mm256_max_ps(z[0], _mm256_max_ps(z[1], z[2]));
  const __m256 ahead = _mm256_and_ps(
      used, _mm256_cmp_ps(z_hi, _mm256_sub_ps(_mm256_setzero_ps(), tiny),
                          _CMP_GE_OQ));
  const __m256 near =
      _mm256_and_ps(ahead, _mm256_cmp_ps(z_lo, tiny, _CMP_LT_OQ));
  __m256 lo_x = _mm256_set1_ps(kInf), hi_x = _mm256_set1_ps(-kInf);
  __m256 lo_y = lo_x, hi_y = hi_x;
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i) {
    const __m256 inv = _mm256_div_ps(_mm256_set1_ps(1), z[i]);
    const __m256 x = _mm256_mul_ps(px[i], inv);
    const __m256 y = _mm256_mul_ps(py[i], inv);
    lo_x = _mm256_min_ps(lo_x, x);
    hi_x = _mm256_max_ps(hi_x, x);
    lo_y = _mm256_min_ps(lo_y, y);
    hi_y = _mm256_max_ps(hi_y, y);
  }
  const unsigned all = static_cast<unsigned>(_mm256_movemask_ps(near));
  const __m256 projected = _mm256_andnot_ps(near, ahead);
  for (int g = 0; g < s.groups; ++g) {
    const __m256 overlap = _mm256_and_ps(
        _mm256_and_ps(
            _mm256_cmp_ps(_mm256_set1_ps(s.lo_x[g]), hi_x, _CMP_LE_OQ),
            _mm256_cmp_ps(_mm256_set1_ps(s.hi_x[g]), lo_x, _CMP_GE_OQ)),
        _mm256_and_ps(
            _mm256_cmp_ps(_mm256_set1_ps(s.lo_y[g]), hi_y, _CMP_LE_OQ),
            _mm256_cmp_ps(_mm256_set1_ps(s.hi_y[g]), lo_y, _CMP_GE_OQ)));
    lanes_of_group[g] =
        static_cast<uint8_t>(all | static_cast<unsigned>(_mm256_movemask_ps(
                                       _mm256_and_ps(overlap, projected))));
  }
}

// Tests group g's rays against lane `lane` of the batch with a sheared
// watertight test (Woop et al.): each corner sheared along the ray to (X - sx
// Z, Y - sy Z) in the cone's frame, the edge functions w[i] the 2D cross
// products of the other two corners (each a product minus a product, no
// fused multiply-add, so that a shared edge's are exact negations in its
// two triangles), t the corners' Z interpolated, times iz. Records the
// hits as FanFilter would; returns whether a ray's limit changed.
[[gnu::always_inline]] inline __attribute__((target("avx2,fma"))) bool TestLane(
    const Batch& b, int lane, __m256 sx, __m256 sy, __m256 iz, int g,
    const FanContext& fan, FanSlots& s, HitCandidates* out) {
  __m256 x[3], y[3], z[3];
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i) {
    z[i] = _mm256_broadcast_ss(&b.frame[i][2][lane]);
    x[i] =
        _mm256_fnmadd_ps(sx, z[i], _mm256_broadcast_ss(&b.frame[i][0][lane]));
    y[i] =
        _mm256_fnmadd_ps(sy, z[i], _mm256_broadcast_ss(&b.frame[i][1][lane]));
  }
  __m256 w[3];
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i) {
    const int p = (i + 1) % 3, q = (i + 2) % 3;
    w[i] = _mm256_sub_ps(_mm256_mul_ps(x[p], y[q]), _mm256_mul_ps(y[p], x[q]));
  }
  const __m256 zero = _mm256_setzero_ps();
  const __m256 lo = _mm256_min_ps(w[0], _mm256_min_ps(w[1], w[2]));
  const __m256 hi = _mm256_max_ps(w[0], _mm256_max_ps(w[1], w[2]));
  const __m256 inside = _mm256_or_ps(_mm256_cmp_ps(lo, zero, _CMP_GE_OQ),
                                     _mm256_cmp_ps(hi, zero, _CMP_LE_OQ));
  if (_mm256_testz_ps(inside, inside)) return false;
  const int at = g * kLanes;
  const __m256 den = _mm256_add_ps(_mm256_add_ps(w[0], w[1]), w[2]);
  const __m256 depth = _mm256_fmadd_ps(
      w[2], z[2], _mm256_fmadd_ps(w[1], z[1], _mm256_mul_ps(w[0], z[0])));
  const __m256 t = _mm256_mul_ps(_mm256_div_ps(depth, den), iz);
  const __m256 hit = _mm256_and_ps(
      inside, _mm256_and_ps(
                  _mm256_cmp_ps(t, _mm256_loadu_ps(&s.start[at]), _CMP_GT_OQ),
                  _mm256_cmp_ps(t, _mm256_loadu_ps(&s.limit[at]), _CMP_LE_OQ)));
  unsigned rays = static_cast<unsigned>(_mm256_movemask_ps(hit));
  if (rays == 0) return false;
  // The smallest barycentric coordinate: w[i] / den, all of one sign.
  const __m256 nearest = _mm256_div_ps(
      _mm256_blendv_ps(hi, lo, _mm256_cmp_ps(den, zero, _CMP_GT_OQ)), den);
  const unsigned edge = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(
      nearest, _mm256_set1_ps(HitCandidates::kEdge), _CMP_LT_OQ)));
  alignas(32) float ts[kLanes];
  _mm256_store_ps(ts, t);
  bool changed = false;
  for (; rays != 0; rays &= rays - 1) {
    const int ray = std::countr_zero(rays);
    const int slot = at + ray;
    HitCandidates& c = out[s.ray[slot]];
    if (!RecordHit(fan, c, b.prim[lane], ts[ray], (edge >> ray) & 1)) continue;
    s.limit[slot] = std::min(c.Limit(), fan.t_far);
    changed = true;
  }
  return changed;
}

// Tests the batch's triangles against the rays that can meet them and
// empties it; adds the (triangle, group) tests made to `tests` (unless
// null). Returns whether a ray's limit changed.
[[gnu::always_inline]] inline __attribute__((target("avx2,fma"))) bool
TestBatch(const Cone& cone, const FanContext& fan, FanSlots& s, Batch& b,
          HitCandidates* out, int64_t* tests) {
  uint8_t lanes_of_group[ConeWalk::kMaxRays / kLanes];
  PrepareBatch(cone, s, b, lanes_of_group);
  bool changed = false;
  for (int g = 0; g < s.groups; ++g) {
    unsigned lanes = lanes_of_group[g];
    if (lanes == 0) continue;
    if (tests != nullptr) *tests += std::popcount(lanes);
    const int at = g * kLanes;
    const __m256 sx = _mm256_loadu_ps(&s.sx[at]);
    const __m256 sy = _mm256_loadu_ps(&s.sy[at]);
    const __m256 iz = _mm256_loadu_ps(&s.iz[at]);
    for (; lanes != 0; lanes &= lanes - 1) {
      changed |=
          TestLane(b, std::countr_zero(lanes), sx, sy, iz, g, fan, s, out);
    }
  }
  b.count = 0;
  return changed;
}

// The largest limit of any ray: how far the walk must still look.
[[gnu::always_inline]] inline __attribute__((target("avx2,fma"))) float Reach(
    const FanSlots& s) {
  __m256 m = _mm256_loadu_ps(&s.limit[0]);
  for (int g = 1; g < s.groups; ++g) {
    m = _mm256_max_ps(m, _mm256_loadu_ps(&s.limit[g * kLanes]));
  }
  return ReduceMax(m);
}

#endif  // __x86_64__

}  // namespace

bool ConeWalk::TakesEveryFan(int64_t primitives, int dimension, int rays,
                             double half_angle) {
  // 5 degrees short of the 80 that SetUpFan checks in single precision.
  return Supported() && dimension == 3 && primitives <= kMaxPrimitives &&
         rays <= kMaxRays && half_angle <= 75 * std::numbers::pi / 180;
}

bool ConeWalk::Supported() {
#if defined(__x86_64__)
  static const bool supported =
      __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return supported;
#else
  return false;
#endif
}

namespace {

// The binary tree the walk's wide nodes are collapsed from.
struct BinaryNode {
  float centre[3];
  float radius;  // of the bounding sphere of its triangles' box.
  int32_t left = -1, right = -1;  // -1: a leaf.
  int32_t first = 0, count = 0;
};

// Median splits along the centroids' longest extent, leaves of up to 4.
int32_t BuildBinary(absl::Span<const ConeWalk::Triangle> triangles,
                    const std::vector<float>& centroids,
                    std::vector<int32_t>& ids, int32_t lo, int32_t hi,
                    std::vector<BinaryNode>& nodes) {
  float box_lo[3] = {kInf, kInf, kInf}, box_hi[3] = {-kInf, -kInf, -kInf};
  float c_lo[3] = {kInf, kInf, kInf}, c_hi[3] = {-kInf, -kInf, -kInf};
  for (int32_t i = lo; i < hi; ++i) {
    const ConeWalk::Triangle& t = triangles[ids[i]];
    for (int k = 0; k < 3; ++k) {
      box_lo[k] = std::min({box_lo[k], t.a[k], t.b[k], t.c[k]});
      box_hi[k] = std::max({box_hi[k], t.a[k], t.b[k], t.c[k]});
      c_lo[k] = std::min(c_lo[k], centroids[3 * ids[i] + k]);
      c_hi[k] = std::max(c_hi[k], centroids[3 * ids[i] + k]);
    }
  }
  BinaryNode node;
  double r2 = 0;
  for (int k = 0; k < 3; ++k) {
    node.centre[k] = 0.5f * (box_lo[k] + box_hi[k]);
    const double half = 0.5 * (static_cast<double>(box_hi[k]) - box_lo[k]);
    r2 += half * half;
  }
  node.radius = static_cast<float>(std::sqrt(r2)) * (1 + kMargin);
  const auto me = static_cast<int32_t>(nodes.size());
  nodes.push_back(node);
  constexpr int32_t kLeafSize = 4;
  if (hi - lo <= kLeafSize) {
    nodes[me].first = lo;
    nodes[me].count = hi - lo;
    return me;
  }
  int axis = 0;
  for (int k = 1; k < 3; ++k) {
    if (c_hi[k] - c_lo[k] > c_hi[axis] - c_lo[axis]) axis = k;
  }
  const int32_t mid = lo + (hi - lo) / 2;
  std::nth_element(ids.begin() + lo, ids.begin() + mid, ids.begin() + hi,
                   [&](int32_t p, int32_t q) {
                     const float cp = centroids[3 * p + axis];
                     const float cq = centroids[3 * q + axis];
                     return cp < cq || (cp == cq && p < q);
                   });
  const int32_t left = BuildBinary(triangles, centroids, ids, lo, mid, nodes);
  const int32_t right = BuildBinary(triangles, centroids, ids, mid, hi, nodes);
  nodes[me].left = left;
  nodes[me].right = right;
  return me;
}

// The wide node standing for binary node `b`: its descendants down to
// kWidth of them, opening the largest first (a leaf stands for itself).
int32_t Collapse(const std::vector<BinaryNode>& binary, int32_t b,
                 std::vector<ConeWalk::Node>& wide) {
  std::vector<int32_t> kids = {b};
  while (std::ssize(kids) < ConeWalk::kWidth) {
    int32_t open = -1;
    for (int32_t i = 0; i < std::ssize(kids); ++i) {
      if (binary[kids[i]].left < 0) continue;
      if (open < 0 || binary[kids[i]].radius > binary[kids[open]].radius) {
        open = i;
      }
    }
    if (open < 0) break;
    const BinaryNode& n = binary[kids[open]];
    kids[open] = n.left;
    kids.push_back(n.right);
  }
  const auto me = static_cast<int32_t>(wide.size());
  wide.emplace_back();
  for (int32_t i = 0; i < std::ssize(kids); ++i) {
    const BinaryNode& n = binary[kids[i]];
    int32_t child = -1;
    if (n.left >= 0) child = Collapse(binary, kids[i], wide);
    ConeWalk::Node& w = wide[me];
    w.x[i] = n.centre[0];
    w.y[i] = n.centre[1];
    w.z[i] = n.centre[2];
    w.radius[i] = n.radius;
    w.child[i] = child;
    w.first[i] = n.first;
    w.count[i] = n.count;
    w.children = i + 1;
  }
  return me;
}

}  // namespace

void ConeWalk::Build(const float* vertices,
                     absl::Span<const Primitive> primitives) {
  nodes_.clear();
  triangles_.clear();
  std::vector<float> centroids;
  // A node's centre and radius, and the origin's offset from it, round by
  // a few units of 2^-24 of the coordinates.
  float largest = 0;
  for (size_t i = 0; i < primitives.size(); ++i) {
    Triangle t;
    t.prim = static_cast<int32_t>(i);
    float* corners[3] = {t.a, t.b, t.c};
    for (int j = 0; j < 3; ++j) {
      const float* p = vertices + 4 * static_cast<size_t>(primitives[i].v[j]);
      std::copy(p, p + 3, corners[j]);
      largest =
          std::max({largest, std::abs(p[0]), std::abs(p[1]), std::abs(p[2])});
    }
    triangles_.push_back(t);
    for (int k = 0; k < 3; ++k) {
      centroids.push_back((t.a[k] + t.b[k] + t.c[k]) / 3);
    }
  }
  if (triangles_.empty()) return;
  slack_ = 8 * std::numeric_limits<float>::epsilon() * largest;
  std::vector<int32_t> ids(triangles_.size());
  std::iota(ids.begin(), ids.end(), 0);
  std::vector<BinaryNode> binary;
  binary.reserve(2 * triangles_.size());
  BuildBinary(triangles_, centroids, ids, 0, static_cast<int32_t>(ids.size()),
              binary);
  std::vector<Triangle> ordered;
  ordered.reserve(ids.size());
  for (int32_t id : ids) ordered.push_back(triangles_[id]);
  triangles_ = std::move(ordered);
  Collapse(binary, 0, nodes_);
}

#if defined(__x86_64__)
namespace {

// The descent: children nearer than the rays' largest limit that the cone
// meets, nearest along the axis first; candidate triangles gathered kLanes
// at a time and tested against the groups of rays that can meet them.
// `slack`: the absolute rounding of a node's sphere in single precision;
// `tests` (unless null) counts the (triangle, group) tests.
__attribute__((target("avx2,fma"))) void Walk(
    absl::Span<const ConeWalk::Node> nodes,
    absl::Span<const ConeWalk::Triangle> triangles, float slack,
    const Cone& cone, const FanContext& fan, FanSlots& s, HitCandidates* out,
    int64_t* tests) {
  static_assert(ConeWalk::kWidth == kLanes);
  float reach = fan.t_far * cone.length;
  // Bit (prim mod 64) of every excluded primitive: most candidates need no
  // search of the list.
  uint64_t excluded_bits = 0;
  for (const int32_t prim : fan.excluded) {
    excluded_bits |= uint64_t{1} << (prim & 63);
  }
  Batch batch{};
  // A node (count < 0) or a leaf's triangles [index, index + count); at
  // most kWidth - 1 entries per level below the one popped (the tree of
  // at most kMaxPrimitives is far shallower than 32 levels).
  struct Entry {
    int32_t index, count;
  };
  Entry stack[32 * ConeWalk::kWidth];
  int depth = 0;
  stack[depth++] = {0, -1};
  const __m256 ox = _mm256_set1_ps(cone.o[0]), oy = _mm256_set1_ps(cone.o[1]),
               oz = _mm256_set1_ps(cone.o[2]);
  const __m256 shrink = _mm256_set1_ps((1 - kMargin) * (1 - kMargin));
  const __m256 cos2 = _mm256_set1_ps(cone.cos_half * cone.cos_half);
  const __m256 sin_half = _mm256_set1_ps(cone.sin_half);
  const __m256 zero = _mm256_setzero_ps();
  while (depth > 0) {
    const Entry entry = stack[--depth];
    if (entry.count >= 0) {
      for (int32_t i = entry.index; i < entry.index + entry.count; ++i) {
        const ConeWalk::Triangle& tri = triangles[i];
        if ((excluded_bits >> (tri.prim & 63) & 1) != 0 &&
            std::binary_search(fan.excluded.begin(), fan.excluded.end(),
                               tri.prim)) {
          continue;
        }
        const float* corners[3] = {tri.a, tri.b, tri.c};
        for (int c = 0; c < 3; ++c) {
          for (int k = 0; k < 3; ++k) {
            batch.corner[c][k][batch.count] = corners[c][k];
          }
        }
        batch.prim[batch.count++] = tri.prim;
        if (batch.count == kLanes &&
            TestBatch(cone, fan, s, batch, out, tests)) {
          reach = Reach(s) * cone.length;
        }
      }
      continue;
    }
    const ConeWalk::Node& node = nodes[entry.index];
    const __m256 tx = _mm256_sub_ps(_mm256_load_ps(node.x), ox);
    const __m256 ty = _mm256_sub_ps(_mm256_load_ps(node.y), oy);
    const __m256 tz = _mm256_sub_ps(_mm256_load_ps(node.z), oz);
    const __m256 radius =
        _mm256_add_ps(_mm256_load_ps(node.radius), _mm256_set1_ps(slack));
    // Within reach: |to| (1 - m) - radius <= reach, without a square root.
    const __m256 dist2 =
        _mm256_fmadd_ps(tz, tz, _mm256_fmadd_ps(ty, ty, _mm256_mul_ps(tx, tx)));
    const __m256 bound = _mm256_add_ps(_mm256_set1_ps(reach), radius);
    const __m256 near = _mm256_cmp_ps(_mm256_mul_ps(dist2, shrink),
                                      _mm256_mul_ps(bound, bound), _CMP_LE_OQ);
    // In the cone: off cos - along sin <= r, off the distance from the axis,
    // r the radius with a margin of its distance.
    const __m256 along = Dot8(tx, ty, tz, cone.axis);
    const __m256 r =
        _mm256_fmadd_ps(_mm256_set1_ps(kMargin),
                        _mm256_add_ps(_mm256_sqrt_ps(dist2), radius), radius);
    const __m256 rhs = _mm256_fmadd_ps(along, sin_half, r);
    const __m256 off2 =
        _mm256_max_ps(zero, _mm256_fnmadd_ps(along, along, dist2));
    const __m256 inside =
        _mm256_and_ps(_mm256_cmp_ps(rhs, zero, _CMP_GE_OQ),
                      _mm256_cmp_ps(_mm256_mul_ps(off2, cos2),
                                    _mm256_mul_ps(rhs, rhs), _CMP_LE_OQ));
    unsigned met =
        static_cast<unsigned>(_mm256_movemask_ps(_mm256_and_ps(near, inside))) &
        ((1u << node.children) - 1);
    if (met == 0) continue;
    // Push the children met, farthest first, so the nearest is popped first.
    alignas(32) float key[kLanes];
    _mm256_store_ps(key, along);
    int order[kLanes], n = 0;
    for (; met != 0; met &= met - 1) {
      const int i = std::countr_zero(met);
      int j = n++;
      for (; j > 0 && key[order[j - 1]] < key[i]; --j) order[j] = order[j - 1];
      order[j] = i;
    }
    for (int j = 0; j < n; ++j) {
      const int i = order[j];
      stack[depth++] = node.child[i] >= 0 ? Entry{node.child[i], -1}
                                          : Entry{node.first[i], node.count[i]};
    }
  }
  if (batch.count > 0) TestBatch(cone, fan, s, batch, out, tests);
}

}  // namespace

bool ConeWalk::Intersect(const Vec3& origin, absl::Span<const Vec3> dirs,
                         const Vec3* axis, absl::Span<const float> starts,
                         float t_near, const FanContext& fan,
                         absl::Span<HitCandidates> out,
                         int64_t* group_tests) const {
  const auto n = std::ssize(dirs);
  if (empty() || !Supported() || n == 0 || n > kMaxRays) return false;
  thread_local FanSlots s;
  Cone cone;
  if (!SetUpFan(origin, dirs, axis, starts, t_near, fan.t_far, cone, s)) {
    return false;
  }
  Walk(nodes_, triangles_, slack_, cone, fan, s, out.data(), group_tests);
  return true;
}
#else
bool ConeWalk::Intersect(const Vec3&, absl::Span<const Vec3>, const Vec3*,
                         absl::Span<const float>, float, const FanContext&,
                         absl::Span<HitCandidates>, int64_t*) const {
  return false;
}
#endif  // __x86_64__

}  // namespace meshgauge
