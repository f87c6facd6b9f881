// Connected components of a mesh and the diagnostics of a file a user loads
// (SPEC §1 and v2): inward-oriented closed components, double-sided faces,
// open meshes.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lib/core/mesh.h"

namespace meshgauge {

struct Component {
  std::vector<int32_t> faces;  // ascending.
  bool closed = false;         // every edge of its faces used by exactly two.
  double signed_volume = 0;    // 3D volume (2D area); meaningful when closed.
};

// Components of faces joined by shared vertices, ordered by their first
// face. Precondition: face indices in range.
std::vector<Component> ConnectedComponents(const Mesh& mesh);

struct MeshDiagnostics {
  int64_t components = 0;
  // Every edge (2D: every used vertex) used exactly twice (IsClosed).
  bool closed = false;
  // Closed components with negative signed volume (faces point into the
  // solid), by index in ConnectedComponents order, with their face counts.
  std::vector<int64_t> inward_components;
  std::vector<int64_t> inward_component_faces;
  // Faces that have an exactly coincident face of opposite orientation
  // (same corners, reversed): a double-sided surface.
  int64_t double_sided_faces = 0;
  // Edges used by one face only (3D) or vertices used by one segment (2D).
  int64_t boundary_edges = 0;
  // One sentence per finding, for summaries and SessionInfo.
  std::vector<std::string> warnings;
};

// Precondition: ValidateMesh(mesh) is OK.
MeshDiagnostics DiagnoseMesh(const Mesh& mesh);

// Reverses every face of each closed component with negative signed volume
// (and nothing else); returns how many components were flipped.
// Precondition: ValidateMesh(mesh) is OK.
int64_t ReorientInwardComponents(Mesh& mesh);

}  // namespace meshgauge
