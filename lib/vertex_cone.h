// Per-vertex cone set-up shared by the value pass and the sensitivities.
#pragma once

#include "lib/cone.h"
#include "lib/mesh.h"

namespace meshgauge {

struct VertexCone {
  bool valid = false;        // false when |N_p| == 0 (no axis).
  double sign = -1;          // axis = sign * n: -1 INWARD, +1 OUTWARD.
  double normal_length = 0;  // |N_p|.
  Vec3 n;                    // N_p / |N_p|.
  ConeFrame frame;
};

inline VertexCone MakeVertexCone(int dimension, const Vec3& normal_sum,
                                 ConeDirection direction) {
  VertexCone vc;
  vc.sign = direction == ConeDirection::kInward ? -1.0 : 1.0;
  vc.normal_length = Norm(normal_sum);
  if (!(vc.normal_length > 0) || !std::isfinite(vc.normal_length)) return vc;
  vc.valid = true;
  vc.n = normal_sum / vc.normal_length;
  vc.frame = MakeFrame(dimension, vc.n * vc.sign);
  return vc;
}

inline Vec3 RayDirection(const ConeFrame& f, const ConeRay& ray) {
  return f.u * ray.local.x + f.v * ray.local.y + f.axis * ray.local.z;
}

}  // namespace meshgauge
