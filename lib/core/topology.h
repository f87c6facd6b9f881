// Derived connectivity of a validated Mesh: ray primitives and incidences.
#pragma once

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "absl/types/span.h"
#include "lib/core/mesh.h"

namespace meshgauge {

// A ray-tracing primitive: a triangle (3D; quads contribute (0,1,2) and
// (0,2,3)) or a segment (2D, v[2] == -1). `face` is the mesh face it comes
// from.
struct Primitive {
  std::array<int32_t, 3> v = {-1, -1, -1};
  int32_t face = -1;
};

// Compressed incidence lists (CSR).
struct Incidence {
  std::vector<int32_t> offsets;  // #V + 1
  std::vector<int32_t> items;
  absl::Span<const int32_t> Of(int64_t vertex) const {
    return absl::MakeConstSpan(items.data() + offsets[vertex],
                               offsets[vertex + 1] - offsets[vertex]);
  }
};

struct MeshTopology {
  std::vector<Primitive> primitives;
  // Faces incident to each vertex, ascending: the one-ring a ray ignores.
  Incidence vertex_faces;
  // Primitives containing each vertex, ascending: the sums of SPEC §2.
  // When every face is a segment or a triangle, primitive i is face i and
  // these lists
  // are vertex_faces' (then vertex_primitives stays empty and is not
  // stored twice).
  absl::Span<const int32_t> PrimitivesOf(int64_t vertex) const {
    return (vertex_primitives.offsets.empty() ? vertex_faces
                                              : vertex_primitives)
        .Of(vertex);
  }
  Incidence vertex_primitives;
  // Cone direction of each vertex (from its faces; kInward if it has none).
  std::vector<ConeDirection> vertex_direction;
  // The primitives of face f: [first, first + count), consecutive (a quad
  // has two).
  std::pair<int32_t, int32_t> PrimitiveRangeOfFace(int64_t f) const {
    if (face_first_primitive.empty()) return {static_cast<int32_t>(f), 1};
    return {face_first_primitive[f],
            face_first_primitive[f + 1] - face_first_primitive[f]};
  }
  // Appends them to `out`.
  void AppendPrimitivesOfFace(int64_t f, std::vector<int32_t>* out) const {
    const auto [first, count] = PrimitiveRangeOfFace(f);
    for (int32_t q = first; q < first + count; ++q) out->push_back(q);
  }
  // #F + 1 offsets when a face is a quad; empty when primitive i is face i.
  std::vector<int32_t> face_first_primitive;

  // Precondition: ValidateMesh(mesh) is OK.
  static MeshTopology Build(const Mesh& mesh);
};

// Per vertex of `mesh`, 1 when it is a corner of a face incident to one of
// `vertices` (an incremental pass traces these samples in full once those
// vertices moved: docs/numerics.md, "Incremental passes"), else 0.
// Precondition: every index in [0, #V).
std::vector<uint8_t> CornersOfFacesAround(const MeshTopology& topo,
                                          const Mesh& mesh,
                                          absl::Span<const int32_t> vertices);

// The primitives a point `y` on primitive `prim` lies within `near` of,
// through `prim`'s neighbourhood, appended to `out` (with repeats): those
// sharing each edge of `prim` within `near` of y (both ends' lists
// intersected: O(the smaller valence)) and all primitives of each corner
// within `near` of y. A 2D segment appends both ends' primitives. Appending
// every primitive of every corner instead made each hit near an edge
// O(valence): quadratic on fan-triangulated caps (a closed cone with 16k
// rim vertices: 13 s against 0.8 s at 4k; an edge shared by 16k triangles:
// over 2 minutes).
void AppendPrimitivesNear(const MeshTopology& topo, const Mesh& mesh,
                          int32_t prim, const Vec3& y, double near,
                          std::vector<int32_t>* out);

// The edge-neighbours of vertex `p`, ascending and unique: the vertices
// joined to it by a face edge (a quad's four sides, not its split diagonal;
// a segment's other end). The frame of SPEC v2 §3 takes the first that
// qualifies. Reads only p's faces (not stored: #V x valence entries).
void VertexNeighbors(const Mesh& mesh, const MeshTopology& topo, int64_t p,
                     std::vector<int32_t>* out);

// The primitives of the faces incident to vertex `p` (SPEC §4's one-ring,
// which a ray from p ignores), ascending: PrimitivesOf(p) and, for a
// quad, its other triangle. Reads only the one-ring's entries.
void OneRingPrimitives(const MeshTopology& topo, int64_t p,
                       std::vector<int32_t>* out);

}  // namespace meshgauge
