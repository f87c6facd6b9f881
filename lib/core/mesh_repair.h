// The opt-in repairs of a loaded or uploaded mesh (dropping zero-area faces,
// reorienting components), its SPEC §1 validation and its diagnostics, in
// one step shared by the CLI and the server, so both name the same defects
// in the same words.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/components.h"
#include "lib/core/mesh.h"
#include "lib/core/weld.h"

namespace meshgauge {

struct RepairOptions {
  // WeldVertices first, with weld_tolerance (relative; 0: exact duplicates).
  bool weld = false;
  double weld_tolerance = 0;
  bool drop_degenerate_faces = false;  // DropDegenerateFaces before checks.
  bool reorient = false;               // ReorientComponents after them.
  int threads = 0;  // for validation and the checks' sorts (0: all).
};

// A valid mesh and what was done to it.
struct RepairedMesh {
  Mesh mesh;
  // With options.weld: the vertices merged and the input's indexing.
  Weld weld;
  int64_t dropped_faces = 0;
  Reorientation reorientation;
  // Of the repaired mesh; its warnings start with one sentence per repair
  // that changed something, then DiagnoseMesh's findings.
  MeshDiagnostics diagnostics;
  double signed_volume = 0;  // SignedVolume of the repaired mesh.
};

// Welds (when asked), drops zero-area faces (when asked), validates
// (ValidateMesh), reorients
// (when asked) and diagnoses. O(F log F + V). Errors: InvalidArgument with
// ValidateMesh's message; for zero-area faces it names the repair that
// removes them.
absl::StatusOr<RepairedMesh> RepairAndDiagnose(Mesh mesh,
                                               const RepairOptions& options);

}  // namespace meshgauge
