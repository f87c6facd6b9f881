// meshgauge geometry core: public entry points.
//
//   ComputeSdf(mesh, params)      one-shot SDF of every vertex (SPEC §3-5).
//   SdfEvaluator                  stateful: owns the BVH, UpdatePositions.
//   IntegrateSdf(mesh, result)    the integral of SDF over the surface (§7).
//   ReadMesh / WriteQualityPly    mesh files (mesh_io.h).
#pragma once

#include "absl/status/statusor.h"
#include "lib/core/integrals.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"
#include "lib/embree/sdf_evaluator.h"

namespace meshgauge {

// Validates `mesh` (SPEC §1) and `params`, builds a BVH (MEDIUM quality) and
// returns per-vertex SDF values, statuses and counts.
// Errors: InvalidArgument (mesh or params), Cancelled, Internal (Embree).
absl::StatusOr<SdfResult> ComputeSdf(const Mesh& mesh, const SdfParams& params,
                                     const ComputeControl& control = {});

}  // namespace meshgauge
