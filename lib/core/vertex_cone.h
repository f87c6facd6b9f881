// Per-vertex cone set-up shared by the value pass and the sensitivities.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "absl/types/span.h"
#include "lib/core/cone.h"
#include "lib/core/mesh.h"
#include "lib/core/topology.h"

namespace meshgauge {

struct VertexCone {
  bool valid = false;        // false when |N_p| == 0 (no axis).
  double sign = -1;          // axis = sign * n: -1 INWARD, +1 OUTWARD.
  double normal_length = 0;  // |N_p|.
  Vec3 n;                    // N_p / |N_p|.
  ConeFrame frame;
  // True for a 3D vertex whose one-ring gave no frame edge (SPEC v2 §3
  // fallback to the world frame); counted in SdfResult.
  bool world_frame = false;
  Vec3 axis() const { return n * sign; }  // frame.axis once there is a frame.
};

// A cone with no frame yet: `direction`'s sign, and the axis from the
// unnormalised normal sum N (not valid when N is 0 or not finite).
inline VertexCone ConeOfNormal(ConeDirection direction,
                               const Vec3& normal_sum) {
  VertexCone vc;
  vc.sign = direction == ConeDirection::kInward ? -1.0 : 1.0;
  vc.normal_length = Norm(normal_sum);
  if (!(vc.normal_length > 0) || !std::isfinite(vc.normal_length)) return vc;
  vc.valid = true;
  vc.n = normal_sum / vc.normal_length;
  return vc;
}

// The cone of vertex p: its axis from the unnormalised normal sum N_p
// (SPEC §2) and its frame, attached to the mesh in 3D (SPEC v2 §3).
inline VertexCone MakeVertexCone(const Mesh& mesh, const MeshTopology& topo,
                                 int64_t p, const Vec3& normal_sum) {
  VertexCone vc = ConeOfNormal(topo.vertex_direction[p], normal_sum);
  if (!vc.valid) return vc;
  const Vec3 axis = vc.axis();
  if (mesh.dimension == 2) {
    vc.frame = MakeWorldFrame(2, axis);
  } else {
    thread_local std::vector<int32_t> neighbors;
    VertexNeighbors(mesh, topo, p, &neighbors);
    vc.frame =
        MakeAttachedFrame(axis, mesh.positions[p], neighbors, mesh.positions);
    vc.world_frame = vc.frame.reference < 0;
  }
  return vc;
}

inline Vec3 RayDirection(const ConeFrame& f, const ConeRay& ray) {
  return f.u * ray.local.x + f.v * ray.local.y + f.axis * ray.local.z;
}

// The direction of every ray of `cone` in frame f: dirs[k] for cone[k]
// (dirs.size() >= cone.size()).
inline void RayDirections(const ConeFrame& f, absl::Span<const ConeRay> cone,
                          absl::Span<Vec3> dirs) {
  for (size_t k = 0; k < cone.size(); ++k) dirs[k] = RayDirection(f, cone[k]);
}

}  // namespace meshgauge
