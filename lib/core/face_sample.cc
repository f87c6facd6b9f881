#include "lib/core/face_sample.h"

#include <algorithm>
#include <array>
#include <utility>

#include "lib/core/normals.h"

namespace meshgauge {

Vec3 FaceCentroid(const Mesh& mesh, int64_t f) {
  const Face& face = mesh.faces[f];
  Vec3 sum;
  for (int k = 0; k < face.size; ++k) sum += mesh.positions[face.v[k]];
  return sum / face.size;
}

VertexCone MakeFaceCone(const Mesh& mesh, const MeshTopology& topo, int64_t f) {
  const auto [first, count] = topo.PrimitiveRangeOfFace(f);
  Vec3 normal_sum;
  for (int32_t q = first; q < first + count; ++q) {
    normal_sum += PrimitiveNormal(mesh, topo.primitives[q]);
  }
  VertexCone vc =
      ConeOfNormal(mesh.DirectionOfRegion(mesh.RegionOf(f)), normal_sum);
  if (!vc.valid) return vc;
  const Vec3 axis = vc.n * vc.sign;
  if (mesh.dimension == 2) {
    vc.frame = MakeWorldFrame(2, axis);
    return vc;
  }
  const Face& face = mesh.faces[f];
  std::array<int32_t, 4> corners = face.v;  // ascending (insertion sort).
  for (int i = 1; i < face.size; ++i) {
    for (int k = i; k > 0 && corners[k - 1] > corners[k]; --k) {
      std::swap(corners[k - 1], corners[k]);
    }
  }
  vc.frame = MakeAttachedFrame(axis, FaceCentroid(mesh, f),
                               absl::MakeConstSpan(corners.data(), face.size),
                               mesh.positions);
  vc.world_frame = vc.frame.reference < 0;
  return vc;
}

void FacePrimitives(const MeshTopology& topo, int64_t f,
                    std::vector<int32_t>* out) {
  out->clear();
  const auto [first, count] = topo.PrimitiveRangeOfFace(f);
  for (int32_t q = first; q < first + count; ++q) out->push_back(q);
}

void FaceRingPrimitives(const Mesh& mesh, const MeshTopology& topo, int64_t f,
                        std::vector<int32_t>* out) {
  out->clear();
  const Face& face = mesh.faces[f];
  for (int k = 0; k < face.size; ++k) {
    for (int32_t g : topo.vertex_faces.Of(face.v[k])) {
      const auto [first, count] = topo.PrimitiveRangeOfFace(g);
      for (int32_t q = first; q < first + count; ++q) out->push_back(q);
    }
  }
  std::sort(out->begin(), out->end());
  out->erase(std::unique(out->begin(), out->end()), out->end());
}

}  // namespace meshgauge
