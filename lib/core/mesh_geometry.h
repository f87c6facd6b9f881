// A validated mesh with the derived state that the SDF's values and
// derivatives read: topology, a Morton order of the vertices, the mean edge
// length, the bounding-box diagonal and a generation counter; ray primitives'
// corners are read from the positions in double precision. SdfEvaluator
// (lib/embree) adds the BVH and the ray pass; the sensitivities and penalties
// (lib/core) need only this.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "absl/types/span.h"
#include "lib/core/hit.h"
#include "lib/core/mesh.h"
#include "lib/core/topology.h"

namespace meshgauge {

class MeshGeometry {
 public:
  const Mesh& mesh() const { return mesh_; }
  const MeshTopology& topology() const { return topo_; }
  // Increments on every successful position update; starts at 0 (or at
  // EvaluatorOptions::generation).
  int64_t generation() const { return generation_; }
  // Corners of primitive `prim` at the current positions (double), read
  // from the positions (an array of corners would hold 80 bytes a
  // primitive, more than the mesh).
  PrimitiveCorners Corners(int32_t prim) const {
    return CornersOf(mesh_, topo_.primitives[prim]);
  }
  // Starts loading primitive `prim`'s corner indices (Corners reads them
  // first).
  void PrefetchPrimitive(int32_t prim) const {
    __builtin_prefetch(&topo_.primitives[prim]);
  }
  // Starts loading primitive `prim`'s corner positions (best after
  // PrefetchPrimitive(prim) had time to arrive).
  void PrefetchCorners(int32_t prim) const {
    for (int32_t v : topo_.primitives[prim].v) {
      if (v >= 0) __builtin_prefetch(&mesh_.positions[v]);
    }
  }
  // The vertices along a Morton curve of their positions at creation (kept
  // across updates): the order the ray pass and the VJP visit them in, for
  // the cache (results do not depend on it).
  absl::Span<const int32_t> vertex_order() const { return vertex_order_; }
  // The vertices v of [begin, end) with keep(v), in vertex_order(): a range
  // pass's vertices, or a VJP's weighted ones.
  template <typename Keep>
  std::vector<int32_t> VerticesInOrder(int64_t begin, int64_t end,
                                       Keep keep) const {
    std::vector<int32_t> out;
    for (int32_t v : vertex_order_) {
      if (v >= begin && v < end && keep(v)) out.push_back(v);
    }
    return out;
  }
  double mean_edge_length() const { return mean_edge_length_; }
  double bounding_box_diagonal() const { return bbox_diagonal_; }
  // Bytes of the mesh's arrays (positions, faces, regions) and of what is
  // derived from it (topology, the vertex order).
  int64_t MeshBytes() const;
  int64_t DerivedBytes() const;

 protected:
  MeshGeometry() = default;
  // Validates `mesh` (SPEC §1) and derives the rest. Errors: InvalidArgument
  // from ValidateMesh.
  absl::Status Init(Mesh mesh);
  // After positions changed: mean edge length, diagonal.
  void RefreshDerivedGeometry();

  Mesh mesh_;
  MeshTopology topo_;
  std::vector<int32_t> vertex_order_;
  int64_t generation_ = 0;
  double mean_edge_length_ = 0;
  double bbox_diagonal_ = 0;
};

}  // namespace meshgauge
