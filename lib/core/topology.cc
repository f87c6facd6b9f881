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

// Both directions of every face edge, then each vertex's list sorted and
// made unique.
Incidence BuildNeighbors(const Mesh& mesh) {
  const int64_t nv = mesh.num_vertices();
  Incidence inc = BuildIncidence(nv, [&](auto&& emit) {
    for (const Face& face : mesh.faces) {
      const int edges = face.size == 2 ? 1 : face.size;
      for (int k = 0; k < edges; ++k) {
        const int32_t a = face.v[k], b = face.v[(k + 1) % face.size];
        emit(a, b);
        emit(b, a);
      }
    }
  });
  int32_t out = 0;
  for (int64_t v = 0; v < nv; ++v) {
    auto begin = inc.items.begin() + inc.offsets[v];
    auto end = inc.items.begin() + inc.offsets[v + 1];
    std::sort(begin, end);
    end = std::unique(begin, end);
    const int32_t start = out;
    out = static_cast<int32_t>(std::copy(begin, end, inc.items.begin() + out) -
                               inc.items.begin());
    inc.offsets[v] = start;
  }
  inc.offsets[nv] = out;
  inc.items.resize(out);
  return inc;
}

}  // namespace

MeshTopology MeshTopology::Build(const Mesh& mesh) {
  MeshTopology topo;
  topo.primitives.reserve(mesh.faces.size() * 2);
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
  topo.vertex_primitives = BuildIncidence(nv, [&](auto&& emit) {
    for (int32_t p = 0; p < static_cast<int32_t>(topo.primitives.size()); ++p) {
      for (int32_t v : topo.primitives[p].v) {
        if (v >= 0) emit(v, p);
      }
    }
  });
  topo.vertex_neighbors = BuildNeighbors(mesh);
  topo.vertex_direction.assign(nv, ConeDirection::kInward);
  for (int64_t f = 0; f < mesh.num_faces(); ++f) {
    const ConeDirection dir = mesh.DirectionOfRegion(mesh.RegionOf(f));
    const Face& face = mesh.faces[f];
    for (int k = 0; k < face.size; ++k) topo.vertex_direction[face.v[k]] = dir;
  }
  return topo;
}

void OneRingPrimitives(const MeshTopology& topo, int64_t p,
                       std::vector<int32_t>* out) {
  out->clear();
  const auto& prims = topo.primitives;
  for (int32_t q : topo.vertex_primitives.Of(p)) {
    out->push_back(q);
    // A quad's two triangles are consecutive primitives.
    if (q > 0 && prims[q - 1].face == prims[q].face) out->push_back(q - 1);
    if (q + 1 < std::ssize(prims) && prims[q + 1].face == prims[q].face) {
      out->push_back(q + 1);
    }
  }
  std::sort(out->begin(), out->end());
  out->erase(std::unique(out->begin(), out->end()), out->end());
}

}  // namespace meshgauge
