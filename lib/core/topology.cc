#include "lib/core/topology.h"

#include <algorithm>
#include <cmath>

namespace meshgauge {
namespace {

// Builds CSR lists from (vertex, item) pairs given in ascending item order,
// so each list comes out ascending.
template <typename ForEachPair>
Incidence BuildIncidence(int64_t num_vertices, ForEachPair for_each_pair) {
  Incidence inc;
  inc.offsets.assign(num_vertices + 1, 0);
  for_each_pair([&](int32_t v, int32_t) { ++inc.offsets[v + 1]; });
  for (int64_t i = 0; i < num_vertices; ++i) {
    inc.offsets[i + 1] += inc.offsets[i];
  }
  inc.items.resize(inc.offsets[num_vertices]);
  std::vector<int32_t> fill(inc.offsets.begin(), inc.offsets.end() - 1);
  for_each_pair([&](int32_t v, int32_t item) { inc.items[fill[v]++] = item; });
  return inc;
}

}  // namespace

MeshTopology MeshTopology::Build(const Mesh& mesh) {
  MeshTopology topo;
  int64_t quads = 0;
  for (const Face& face : mesh.faces) quads += face.size == 4;
  topo.primitives.reserve(mesh.faces.size() + quads);
  for (int32_t f = 0; f < static_cast<int32_t>(mesh.faces.size()); ++f) {
    const Face& face = mesh.faces[f];
    if (face.size == 2) {
      topo.primitives.push_back({{face.v[0], face.v[1], -1}, f});
    } else {
      topo.primitives.push_back({{face.v[0], face.v[1], face.v[2]}, f});
      if (face.size == 4) {
        topo.primitives.push_back({{face.v[0], face.v[2], face.v[3]}, f});
      }
    }
  }
  const int64_t nv = mesh.num_vertices();
  topo.vertex_faces = BuildIncidence(nv, [&](auto&& emit) {
    for (int32_t f = 0; f < static_cast<int32_t>(mesh.faces.size()); ++f) {
      const Face& face = mesh.faces[f];
      for (int k = 0; k < face.size; ++k) emit(face.v[k], f);
    }
  });
  // Segments and triangles are their own primitives: the lists are
  // vertex_faces' (PrimitivesOf).
  if (quads > 0) {
    topo.face_first_primitive.assign(mesh.faces.size() + 1, 0);
    for (const Primitive& prim : topo.primitives) {
      ++topo.face_first_primitive[prim.face + 1];
    }
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
      topo.face_first_primitive[f + 1] += topo.face_first_primitive[f];
    }
    topo.vertex_primitives = BuildIncidence(nv, [&](auto&& emit) {
      for (int32_t p = 0; p < static_cast<int32_t>(topo.primitives.size());
           ++p) {
        for (int32_t v : topo.primitives[p].v) {
          if (v >= 0) emit(v, p);
        }
      }
    });
  }
  topo.vertex_direction.assign(nv, ConeDirection::kInward);
  for (int64_t f = 0; f < mesh.num_faces(); ++f) {
    const ConeDirection dir = mesh.DirectionOfRegion(mesh.RegionOf(f));
    const Face& face = mesh.faces[f];
    for (int k = 0; k < face.size; ++k) topo.vertex_direction[face.v[k]] = dir;
  }
  return topo;
}

void VertexNeighbors(const Mesh& mesh, const MeshTopology& topo, int64_t p,
                     std::vector<int32_t>* out) {
  out->clear();
  for (int32_t f : topo.vertex_faces.Of(p)) {
    const Face& face = mesh.faces[f];
    int k = 0;  // p's corner (a face repeats no vertex).
    while (face.v[k] != p) ++k;
    if (face.size == 2) {
      out->push_back(face.v[1 - k]);
      continue;
    }
    out->push_back(face.v[(k + 1) % face.size]);
    out->push_back(face.v[(k + face.size - 1) % face.size]);
  }
  std::sort(out->begin(), out->end());
  out->erase(std::unique(out->begin(), out->end()), out->end());
}

void OneRingPrimitives(const MeshTopology& topo, int64_t p,
                       std::vector<int32_t>* out) {
  out->clear();
  for (int32_t f : topo.vertex_faces.Of(p)) topo.AppendPrimitivesOfFace(f, out);
  std::sort(out->begin(), out->end());
  out->erase(std::unique(out->begin(), out->end()), out->end());
}

std::vector<uint8_t> CornersOfFacesAround(const MeshTopology& topo,
                                          const Mesh& mesh,
                                          absl::Span<const int32_t> vertices) {
  std::vector<uint8_t> corners(mesh.num_vertices(), 0);
  for (int32_t v : vertices) {
    for (int32_t f : topo.vertex_faces.Of(v)) {
      const Face& face = mesh.faces[f];
      for (int k = 0; k < face.size; ++k) corners[face.v[k]] = 1;
    }
  }
  return corners;
}

void AppendPrimitivesNear(const MeshTopology& topo, const Mesh& mesh,
                          int32_t prim, const Vec3& y, double near,
                          std::vector<int32_t>* out) {
  const std::array<int32_t, 3>& v = topo.primitives[prim].v;
  if (v[2] < 0 || !std::isfinite(near)) {
    for (int32_t corner : v) {
      if (corner < 0) continue;
      for (int32_t q : topo.PrimitivesOf(corner)) out->push_back(q);
    }
    return;
  }
  bool corner_near[3];
  for (int k = 0; k < 3; ++k) {
    const Vec3 r = y - mesh.positions[v[k]];
    corner_near[k] = Dot(r, r) <= near * near;
    if (!corner_near[k]) continue;
    for (int32_t q : topo.PrimitivesOf(v[k])) out->push_back(q);
  }
  for (int k = 0; k < 3; ++k) {
    // An edge with a near end: its primitives are among that end's.
    if (corner_near[k] || corner_near[(k + 1) % 3]) continue;
    const int32_t a = v[k], b = v[(k + 1) % 3];
    const Vec3 pa = mesh.positions[a], e = mesh.positions[b] - pa;
    const double s =
        std::clamp(Dot(y - pa, e) / std::max(Dot(e, e), 1e-300), 0.0, 1.0);
    const Vec3 r = y - (pa + e * s);
    if (Dot(r, r) > near * near) continue;
    absl::Span<const int32_t> small = topo.PrimitivesOf(a),
                              large = topo.PrimitivesOf(b);
    if (small.size() > large.size()) std::swap(small, large);
    for (int32_t q : small) {
      if (std::binary_search(large.begin(), large.end(), q)) out->push_back(q);
    }
  }
}

}  // namespace meshgauge
