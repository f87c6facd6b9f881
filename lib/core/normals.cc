#include "lib/core/normals.h"

#include <cmath>

namespace meshgauge {

Vec3 PrimitiveNormal(const Mesh& mesh, const Primitive& prim) {
  const Vec3& a = mesh.positions[prim.v[0]];
  const Vec3& b = mesh.positions[prim.v[1]];
  if (prim.v[2] < 0) return Perp(b - a);
  const Vec3& c = mesh.positions[prim.v[2]];
  return Cross(b - a, c - a);
}

void PrimitiveNormalVjp(const Mesh& mesh, const Primitive& prim, const Vec3& g,
                        Vec3 grad_out[3]) {
  const Vec3& a = mesh.positions[prim.v[0]];
  const Vec3& b = mesh.positions[prim.v[1]];
  if (prim.v[2] < 0) {
    // perp(e) = (e_y, -e_x): g . perp(e) = g_x e_y - g_y e_x.
    const Vec3 d_de(-g.y, g.x, 0.0);
    grad_out[0] = -d_de;
    grad_out[1] = d_de;
    grad_out[2] = Vec3();
    return;
  }
  const Vec3& c = mesh.positions[prim.v[2]];
  // g . ((b-a) x (c-a)): d/db = (c-a) x g, d/dc = g x (b-a), d/da = -(sum).
  const Vec3 db = Cross(c - a, g);
  const Vec3 dc = Cross(g, b - a);
  grad_out[0] = -(db + dc);
  grad_out[1] = db;
  grad_out[2] = dc;
}

Vec3 UnnormalizedNormal(const Mesh& mesh, const MeshTopology& topo, int64_t p,
                        NormalWeighting weighting) {
  const bool angle =
      weighting == NormalWeighting::kAngle && mesh.dimension == 3;
  Vec3 sum;
  for (int32_t prim_id : topo.PrimitivesOf(p)) {
    const Primitive& prim = topo.primitives[prim_id];
    const Vec3 n = PrimitiveNormal(mesh, prim);
    if (!angle) {
      sum += n;
      continue;
    }
    int corner = 0;
    while (prim.v[corner] != p) ++corner;
    const Vec3& x = mesh.positions[p];
    const Vec3 e1 = mesh.positions[prim.v[(corner + 1) % 3]] - x;
    const Vec3 e2 = mesh.positions[prim.v[(corner + 2) % 3]] - x;
    const double theta = std::atan2(Norm(Cross(e1, e2)), Dot(e1, e2));
    sum += n * (theta / Norm(n));
  }
  return sum;
}

std::vector<Vec3> UnnormalizedNormals(const Mesh& mesh,
                                      const MeshTopology& topo,
                                      NormalWeighting weighting) {
  std::vector<Vec3> normals(mesh.positions.size());
  for (int64_t p = 0; p < mesh.num_vertices(); ++p) {
    normals[p] = UnnormalizedNormal(mesh, topo, p, weighting);
  }
  return normals;
}

}  // namespace meshgauge
