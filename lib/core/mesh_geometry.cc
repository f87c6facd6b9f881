#include "lib/core/mesh_geometry.h"

namespace meshgauge {

absl::Status MeshGeometry::Init(Mesh mesh) {
  if (absl::Status s = ValidateMesh(mesh); !s.ok()) return s;
  mesh_ = std::move(mesh);
  topo_ = MeshTopology::Build(mesh_);
  RefreshDerivedGeometry();
  return absl::OkStatus();
}

void MeshGeometry::RefreshDerivedGeometry() {
  mean_edge_length_ = MeanEdgeLength(mesh_);
  bbox_diagonal_ = BoundingBoxDiagonal(mesh_);
  corners_.resize(topo_.primitives.size());
  for (size_t i = 0; i < corners_.size(); ++i) {
    corners_[i] = CornersOf(mesh_, topo_.primitives[i]);
  }
}

}  // namespace meshgauge
