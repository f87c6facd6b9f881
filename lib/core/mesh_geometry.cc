#include "lib/core/mesh_geometry.h"

#include <tbb/parallel_invoke.h>

#include "lib/core/spatial_order.h"

namespace meshgauge {

absl::Status MeshGeometry::Init(Mesh mesh) {
  if (absl::Status s = ValidateMesh(mesh); !s.ok()) return s;
  mesh_ = std::move(mesh);
  // Three reads of the mesh into separate members, side by side (the
  // topology's build is serial: a tenth of a second beside the Morton
  // order's sort and the edge lengths on a million vertices).
  tbb::parallel_invoke([&] { topo_ = MeshTopology::Build(mesh_); },
                       [&] { vertex_order_ = MortonOrder(mesh_.positions); },
                       [&] { RefreshDerivedGeometry(); });
  return absl::OkStatus();
}

namespace {

template <typename T>
int64_t Bytes(const std::vector<T>& v) {
  return static_cast<int64_t>(v.capacity() * sizeof(T));
}

int64_t Bytes(const Incidence& inc) {
  return Bytes(inc.offsets) + Bytes(inc.items);
}

}  // namespace

int64_t MeshGeometry::MeshBytes() const {
  return Bytes(mesh_.positions) + Bytes(mesh_.faces) +
         Bytes(mesh_.face_regions);
}

int64_t MeshGeometry::DerivedBytes() const {
  return Bytes(topo_.primitives) + Bytes(topo_.vertex_faces) +
         Bytes(topo_.vertex_primitives) + Bytes(topo_.vertex_direction) +
         Bytes(topo_.face_first_primitive) + Bytes(vertex_order_);
}

void MeshGeometry::RefreshDerivedGeometry() {
  mean_edge_length_ = MeanEdgeLength(mesh_);
  bbox_diagonal_ = BoundingBoxDiagonal(mesh_);
}

}  // namespace meshgauge
