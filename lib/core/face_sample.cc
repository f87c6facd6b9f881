#include "lib/core/face_sample.h"

#include <algorithm>
#include <array>
#include <utility>

#include "absl/strings/str_cat.h"
#include "lib/core/normals.h"

namespace meshgauge {

absl::StatusOr<SampleRange> ResolveRange(const Mesh& mesh,
                                         const SdfParams& params) {
  const int64_t n = NumSamples(mesh, params.samples);
  const SampleRange& r = params.range;
  if (r.all()) return SampleRange{0, n};
  if (r.begin < 0 || r.begin >= r.end || r.end > n) {
    return absl::InvalidArgumentError(absl::StrCat(
        "sample range [", r.begin, ", ", r.end, ") is not a non-empty range "
        "of the mesh's ", n, " ", SampleSetName(params.samples),
        " (0 <= begin < end <= ", n, ")"));
  }
  return r;
}

Vec3 FaceCentroid(const Mesh& mesh, int64_t f) {
  const Face& face = mesh.faces[f];
  Vec3 sum;
  for (int k = 0; k < face.size; ++k) sum += mesh.positions[face.v[k]];
  return sum / face.size;
}

SampleCone MakeSampleCone(const Mesh& mesh, const MeshTopology& topo,
                          SampleSet set, int64_t p,
                          absl::FunctionRef<Vec3()> normal_sum, bool frame) {
  if (set == SampleSet::kVertices) {
    return {frame ? MakeVertexCone(mesh, topo, p, normal_sum())
                  : ConeOfNormal(topo.vertex_direction[p], normal_sum()),
            mesh.positions[p]};
  }
  const auto [first, count] = topo.PrimitiveRangeOfFace(p);
  Vec3 face_normal;
  for (int32_t q = first; q < first + count; ++q) {
    face_normal += PrimitiveNormal(mesh, topo.primitives[q]);
  }
  SampleCone s{
      ConeOfNormal(mesh.DirectionOfRegion(mesh.RegionOf(p)), face_normal),
      FaceCentroid(mesh, p)};
  if (!s.cone.valid || !frame) return s;
  if (mesh.dimension == 2) {
    s.cone.frame = MakeWorldFrame(2, s.cone.axis());
    return s;
  }
  const Face& face = mesh.faces[p];
  std::array<int32_t, 4> corners = face.v;  // ascending (insertion sort).
  for (int i = 1; i < face.size; ++i) {
    for (int k = i; k > 0 && corners[k - 1] > corners[k]; --k) {
      std::swap(corners[k - 1], corners[k]);
    }
  }
  s.cone.frame = MakeAttachedFrame(
      s.cone.axis(), s.x, absl::MakeConstSpan(corners.data(), face.size),
      mesh.positions);
  s.cone.world_frame = s.cone.frame.reference < 0;
  return s;
}

void SampleExclusions(const Mesh& mesh, const MeshTopology& topo, SampleSet set,
                      bool ball, int64_t p, std::vector<int32_t>* out) {
  if (set == SampleSet::kVertices) {
    OneRingPrimitives(topo, p, out);
    return;
  }
  out->clear();
  if (!ball) {
    topo.AppendPrimitivesOfFace(p, out);  // consecutive: ascending.
    return;
  }
  const Face& face = mesh.faces[p];
  for (int k = 0; k < face.size; ++k) {
    for (int32_t g : topo.vertex_faces.Of(face.v[k])) {
      topo.AppendPrimitivesOfFace(g, out);
    }
  }
  std::sort(out->begin(), out->end());
  out->erase(std::unique(out->begin(), out->end()), out->end());
}

}  // namespace meshgauge
