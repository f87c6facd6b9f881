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
  // Its edges used by one face (2D: vertices used by one segment); not
  // closed without any: an edge is shared by more than two faces.
  int64_t boundary_edges = 0;
  // Closed components enclosing it (NestingDepths): 0 for a part's outer
  // shell, 1 for a cavity's shell, 2 for an island inside the cavity.
  int32_t nesting_depth = 0;
  // Closed and oriented against its nesting: faces pointing into the solid
  // (an outer shell or island with negative signed volume, a cavity's
  // shell with positive), so INWARD cones look out of the material.
  bool inverted() const {
    return closed && (nesting_depth % 2 == 0 ? signed_volume < 0
                                             : signed_volume > 0);
  }
};

// Components of faces joined by shared vertices, ordered by their first
// face. Precondition: face indices in range.
std::vector<Component> ConnectedComponents(const Mesh& mesh);

struct MeshDiagnostics {
  int64_t components = 0;
  // Every edge (2D: every used vertex) used exactly twice (IsClosed).
  bool closed = false;
  // Closed components oriented against their nesting (Component::
  // inverted: faces point into the solid), by index in ConnectedComponents
  // order, with their face counts.
  std::vector<int64_t> inward_components;
  std::vector<int64_t> inward_component_faces;
  // Faces that have an exactly coincident face of opposite orientation
  // (same corners, reversed): a double-sided surface.
  int64_t double_sided_faces = 0;
  // Edges used by one face only (3D) or vertices used by one segment (2D).
  int64_t boundary_edges = 0;
  // Edges used by more than two faces (2D: vertices by more than two
  // segments): non-manifold.
  int64_t shared_edges = 0;
  // Ends of boundary edges at exactly the position of another such end:
  // unwelded seams (welded, the boundaries would join).
  int64_t coincident_boundary_vertices = 0;
  // Edges used by exactly two faces in the same direction (2D: vertices
  // where two segments both start or both end): neighbours whose
  // orientations disagree; and the components (ConnectedComponents order)
  // that have such edges.
  int64_t inconsistent_edges = 0;
  std::vector<int64_t> inconsistent_components;
  // One sentence per finding, for summaries and SessionInfo.
  std::vector<std::string> warnings;
};

// Precondition: ValidateMesh(mesh) is OK.
MeshDiagnostics DiagnoseMesh(const Mesh& mesh);

// What ReorientComponents changed.
struct Reorientation {
  // Faces reversed to agree with their neighbours, and the components they
  // were in.
  int64_t faces_made_consistent = 0;
  int64_t components_made_consistent = 0;
  // Closed components then reversed because they were inverted (faces
  // pointing into the solid, judged with their nesting).
  int64_t components_turned_outward = 0;
  // Components that no choice of orientations makes consistent across
  // their edges of exactly two faces (a Moebius band), left with a few
  // disagreeing edges. Edges of more than two faces join nothing here.
  int64_t non_orientable_components = 0;
};

// Makes each component's faces agree across every edge shared by exactly
// two faces (reversing, in each patch of faces joined by such edges, the
// smaller set of faces; ties keep the lowest face's orientation), then
// reverses each inverted closed component (a shell at even nesting depth
// with negative signed volume, at odd depth with positive: a cavity's
// shell keeps facing into the cavity). O(F log F), plus NestingDepths'.
// Precondition: ValidateMesh(mesh) is OK.
Reorientation ReorientComponents(Mesh& mesh);

// ReorientComponents, then DiagnoseMesh of the result, sharing one analysis
// of the edges (the same results as the two calls). Precondition as theirs.
MeshDiagnostics ReorientAndDiagnose(Mesh& mesh, Reorientation* reorientation);

}  // namespace meshgauge
