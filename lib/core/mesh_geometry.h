// A validated mesh with the derived state that the SDF's values and
// derivatives read: topology, every ray primitive's corners in double
// precision, the mean edge length, the bounding-box diagonal and a
// generation counter. SdfEvaluator (lib/embree) adds the BVH and the ray
// pass; the sensitivities and penalties (lib/core) need only this.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
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
  // Corners of every primitive at the current positions (double).
  const std::vector<PrimitiveCorners>& corners() const { return corners_; }
  double mean_edge_length() const { return mean_edge_length_; }
  double bounding_box_diagonal() const { return bbox_diagonal_; }

 protected:
  MeshGeometry() = default;
  // Validates `mesh` (SPEC §1) and derives the rest. Errors: InvalidArgument
  // from ValidateMesh.
  absl::Status Init(Mesh mesh);
  // After positions changed: corners, mean edge length, diagonal.
  void RefreshDerivedGeometry();

  Mesh mesh_;
  MeshTopology topo_;
  std::vector<PrimitiveCorners> corners_;
  int64_t generation_ = 0;
  double mean_edge_length_ = 0;
  double bbox_diagonal_ = 0;
};

}  // namespace meshgauge
