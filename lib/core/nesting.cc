#include "lib/core/nesting.h"

#include <cmath>
#include <numbers>

#include "lib/core/box.h"
#include "lib/core/components.h"

namespace meshgauge {
namespace {

// The solid angle of triangle (a, b, c) seen from the origin (Van Oosterom
// and Strackee), signed by the triangle's orientation.
double SolidAngle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double la = Norm(a), lb = Norm(b), lc = Norm(c);
  const double numerator = Dot(a, Cross(b, c));
  const double denominator =
      la * lb * lc + Dot(a, b) * lc + Dot(a, c) * lb + Dot(b, c) * la;
  return 2 * std::atan2(numerator, denominator);
}

Vec3 Centroid(const Mesh& mesh, const Face& f) {
  Vec3 sum;
  for (int k = 0; k < f.size; ++k) sum += mesh.positions[f.v[k]];
  return sum / f.size;
}

Box BoxOf(const Mesh& mesh, const std::vector<int32_t>& faces) {
  Box box;
  for (int32_t id : faces) {
    const Face& f = mesh.faces[id];
    for (int k = 0; k < f.size; ++k) box.Extend(mesh.positions[f.v[k]], mesh.positions[f.v[k]]);
  }
  return box;
}

bool Contains(const Box& outer, const Box& inner) {
  return outer.lo.x <= inner.lo.x && outer.lo.y <= inner.lo.y &&
         outer.lo.z <= inner.lo.z && inner.hi.x <= outer.hi.x &&
         inner.hi.y <= outer.hi.y && inner.hi.z <= outer.hi.z;
}

}  // namespace

double WindingNumber(const Mesh& mesh, const std::vector<int32_t>& faces,
                     const Vec3& point) {
  const auto& p = mesh.positions;
  double sum = 0;
  for (int32_t id : faces) {
    const Face& f = mesh.faces[id];
    if (f.size == 2) {
      const Vec3 a = p[f.v[0]] - point, b = p[f.v[1]] - point;
      sum += std::atan2(a.x * b.y - a.y * b.x, a.x * b.x + a.y * b.y);
      continue;
    }
    for (int t = 0; t + 2 < f.size; ++t) {
      sum += SolidAngle(p[f.v[0]] - point, p[f.v[t + 1]] - point,
                        p[f.v[t + 2]] - point);
    }
  }
  return sum / (mesh.dimension == 2 ? 2 * std::numbers::pi
                                    : 4 * std::numbers::pi);
}

std::vector<int32_t> NestingDepths(const Mesh& mesh,
                                   const std::vector<Component>& components) {
  std::vector<int32_t> depth(components.size(), 0);
  std::vector<int32_t> closed;
  for (size_t i = 0; i < components.size(); ++i) {
    if (components[i].closed) closed.push_back(static_cast<int32_t>(i));
  }
  if (closed.size() < 2) return depth;
  std::vector<Box> boxes(components.size());
  for (int32_t i : closed) boxes[i] = BoxOf(mesh, components[i].faces);
  for (int32_t i : closed) {
    const Vec3 point =
        Centroid(mesh, mesh.faces[components[i].faces.front()]);
    for (int32_t j : closed) {
      if (j == i || !Contains(boxes[j], boxes[i])) continue;
      if (std::abs(WindingNumber(mesh, components[j].faces, point)) >= 0.5) {
        ++depth[i];
      }
    }
  }
  return depth;
}

}  // namespace meshgauge
