#include "lib/core/polygon.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"

namespace meshgauge {
namespace {

struct P2 {
  double x, y;
};

double Cross2(const P2& o, const P2& a, const P2& b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Closed segments ab and cd share a point (proper crossing, touching or
// collinear overlap), with a tolerance relative to the polygon's size.
bool SegmentsMeet(const P2& a, const P2& b, const P2& c, const P2& d,
                  double eps) {
  const double d1 = Cross2(a, b, c), d2 = Cross2(a, b, d);
  const double d3 = Cross2(c, d, a), d4 = Cross2(c, d, b);
  auto sign = [eps](double v) { return v > eps ? 1 : (v < -eps ? -1 : 0); };
  const int s1 = sign(d1), s2 = sign(d2), s3 = sign(d3), s4 = sign(d4);
  if (s1 * s2 < 0 && s3 * s4 < 0) return true;
  auto on = [](const P2& p, const P2& q, const P2& r) {
    return std::min(p.x, q.x) <= r.x && r.x <= std::max(p.x, q.x) &&
           std::min(p.y, q.y) <= r.y && r.y <= std::max(p.y, q.y);
  };
  return (s1 == 0 && on(a, b, c)) || (s2 == 0 && on(a, b, d)) ||
         (s3 == 0 && on(c, d, a)) || (s4 == 0 && on(c, d, b));
}

// p strictly inside or on the triangle abc (counter-clockwise).
bool InTriangle(const P2& p, const P2& a, const P2& b, const P2& c,
                double eps) {
  return Cross2(a, b, p) >= -eps && Cross2(b, c, p) >= -eps &&
         Cross2(c, a, p) >= -eps;
}

// Twice the polygon's vector area (Newell's formula).
Vec3 NewellNormal(absl::Span<const Vec3> corners) {
  const size_t n = corners.size();
  Vec3 normal;
  for (size_t i = 0; i < n; ++i) {
    const Vec3& a = corners[i];
    const Vec3& b = corners[(i + 1) % n];
    normal += Vec3((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x),
                   (a.x - b.x) * (a.y + b.y));
  }
  return normal;
}

// Ear clipping in the best-fit plane; errors when the polygon is not simple
// there.
absl::StatusOr<std::vector<std::array<int32_t, 3>>> EarClip(
    absl::Span<const Vec3> corners) {
  const int n = static_cast<int>(corners.size());
  // Newell normal and an orthonormal basis of its plane.
  const Vec3 normal = NewellNormal(corners);
  Vec3 centre;
  for (const Vec3& c : corners) centre += c;
  centre = centre / n;
  double size = 0;
  for (const Vec3& c : corners) size = std::max(size, Norm(c - centre));
  const double area2 = Norm(normal);
  if (!(area2 > 1e-14 * size * size)) {
    return absl::InvalidArgumentError(
        "the polygon has no area in its best-fit plane");
  }
  const Vec3 nz = normal / area2;
  const Vec3 helper = std::abs(nz.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
  const Vec3 ux = Cross(helper, nz) / Norm(Cross(helper, nz));
  const Vec3 uy = Cross(nz, ux);
  std::vector<P2> p(n);
  for (int i = 0; i < n; ++i) {
    const Vec3 d = corners[i] - centre;
    p[i] = {Dot(d, ux), Dot(d, uy)};  // counter-clockwise about nz.
  }
  const double eps = 1e-12 * size * size;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const bool adjacent = j == i + 1 || (i == 0 && j == n - 1);
      if (adjacent) continue;
      if (SegmentsMeet(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n], eps)) {
        return absl::InvalidArgumentError(absl::StrCat(
            "the polygon is not simple in its best-fit plane: edge ", i, "-",
            (i + 1) % n, " meets edge ", j, "-", (j + 1) % n));
      }
    }
  }
  std::vector<int32_t> ring(n);
  for (int i = 0; i < n; ++i) ring[i] = i;
  std::vector<std::array<int32_t, 3>> out;
  out.reserve(n - 2);
  while (ring.size() > 3) {
    const int m = static_cast<int>(ring.size());
    bool clipped = false;
    for (int k = 0; k < m && !clipped; ++k) {
      const int32_t a = ring[(k + m - 1) % m], b = ring[k],
                    c = ring[(k + 1) % m];
      if (Cross2(p[a], p[b], p[c]) <= eps) continue;  // reflex or flat.
      bool empty = true;
      for (int32_t q : ring) {
        if (q == a || q == b || q == c) continue;
        if (InTriangle(p[q], p[a], p[b], p[c], eps)) {
          empty = false;
          break;
        }
      }
      if (!empty) continue;
      out.push_back({a, b, c});
      ring.erase(ring.begin() + k);
      clipped = true;
    }
    if (!clipped) {
      return absl::InvalidArgumentError(
          "the polygon could not be triangulated (collinear corners)");
    }
  }
  out.push_back({ring[0], ring[1], ring[2]});
  return out;
}

// Of all triangulations of the corners in their order (diagonals i-j), the
// one whose smallest triangle is largest, by dynamic programming over the
// index intervals (O(n^3)). A triangle's size is its doubled area along
// `normal` (signed: a triangle facing against the polygon counts as
// negative), or its unsigned doubled area when `normal` is zero. Empty when
// every triangulation has a triangle of no area (or, signed, one facing
// backwards). Triangles (i, k, j), i < k < j, keep the polygon's cyclic
// order.
std::vector<std::array<int32_t, 3>> MaxMinTriangulation(
    absl::Span<const Vec3> corners, const Vec3& normal) {
  const int n = static_cast<int>(corners.size());
  double size = 0;
  for (const Vec3& c : corners) size = std::max(size, Norm(c - corners[0]));
  const bool signed_area = Norm(normal) > 0;
  auto twice_area = [&](int i, int k, int j) {
    const Vec3 c = Cross(corners[k] - corners[i], corners[j] - corners[i]);
    return signed_area ? Dot(c, normal) : Norm(c);
  };
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // best[i][j]: the largest smallest doubled area over triangulations of
  // the sub-polygon i..j (kInf for an edge); split[i][j]: its apex.
  std::vector<double> best(static_cast<size_t>(n) * n, kInf);
  std::vector<int32_t> split(static_cast<size_t>(n) * n, -1);
  for (int len = 2; len < n; ++len) {
    for (int i = 0; i + len < n; ++i) {
      const int j = i + len;
      double b = -kInf;
      for (int k = i + 1; k < j; ++k) {
        const double v =
            std::min({best[i * n + k], best[k * n + j], twice_area(i, k, j)});
        if (v > b) {
          b = v;
          split[i * n + j] = k;
        }
      }
      best[i * n + j] = b;
    }
  }
  std::vector<std::array<int32_t, 3>> out;
  // The zero-area test of ValidateMesh on the doubled area.
  if (!(best[n - 1] > 1e-14 * size * size)) return out;
  std::vector<std::pair<int32_t, int32_t>> stack = {{0, n - 1}};
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    if (j - i < 2) continue;
    const int32_t k = split[i * n + j];
    out.push_back({i, k, j});
    stack.push_back({i, k});
    stack.push_back({k, j});
  }
  return out;
}

}  // namespace

absl::StatusOr<std::vector<std::array<int32_t, 3>>> TriangulatePolygon(
    absl::Span<const Vec3> corners, bool* fallback_used) {
  if (fallback_used != nullptr) *fallback_used = false;
  const int n = static_cast<int>(corners.size());
  if (n < 3 || n > kMaxPolygonCorners) {
    return absl::InvalidArgumentError(absl::StrCat(
        "a polygon needs 3 to ", kMaxPolygonCorners, " corners, got ", n));
  }
  auto clipped = EarClip(corners);
  if (clipped.ok()) return clipped;
  // Prefer triangles that all face along the Newell normal; a polygon
  // folded so that none does (or with no net normal) takes unsigned areas.
  Vec3 normal = NewellNormal(corners);
  if (Norm(normal) > 0) normal = normal / Norm(normal);
  auto fallback = MaxMinTriangulation(corners, normal);
  if (fallback.empty()) fallback = MaxMinTriangulation(corners, Vec3());
  if (fallback.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        clipped.status().message(),
        ", and every triangulation of it has a triangle of no area"));
  }
  if (fallback_used != nullptr) *fallback_used = true;
  return fallback;
}

}  // namespace meshgauge
