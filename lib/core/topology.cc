#include "lib/core/topology.h"

#include <algorithm>

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

}  // namespace meshgauge
