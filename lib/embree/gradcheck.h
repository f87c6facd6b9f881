// Finite-difference verification of the SDF Jacobian, the VJP and the
// penalty gradient (SPEC §6 criterion), for users before they trust an
// optimisation (meshgauge gradcheck) and for the tests.
//
// For each sampled vertex j and coordinate c, x_j[c] is moved by +-step
// (step = relative_step x bounding-box diagonal) and everything is
// recomputed. A sample (row p, column j, c) is *clean* when p's hit
// primitives and kept set are identical at x, x + step and x - step (the
// derivative is then defined); otherwise it straddles an event, and the
// probe is repeated with steps 10 and 100 times smaller (each sample keeps
// its first clean attempt). Verdict: FAIL when a clean sample (or a VJP or
// penalty check) disagrees beyond `tolerance` (relative error, magnitude
// floored at 1e-2: derivatives of a length by a length are O(1);
// docs/sensitivities.md): the derivatives are wrong; INCONCLUSIVE when none
// disagrees but fewer than min_clean_fraction of the samples are clean even
// at the smallest step; PASS otherwise.
#pragma once

#include "absl/status/statusor.h"
#include "lib/core/gradcheck_types.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"
#include "lib/embree/sdf_evaluator.h"

namespace meshgauge {

// Precondition: none. Errors: InvalidArgument (mesh, params, options),
// FailedPrecondition (angle-weighted normals; a penalty over mostly missing
// values), Cancelled.
absl::StatusOr<GradCheckReport> RunGradCheck(
    const Mesh& mesh, const SdfParams& params, const GradCheckOptions& options,
    const ComputeControl& control = {});

// The same on an existing evaluator at its current positions: the probed
// vertices are moved and put back (three updates per probe: +h, -h and
// back; the positions end as they began, also on error).
absl::StatusOr<GradCheckReport> RunGradCheck(
    SdfEvaluator& ev, const SdfParams& params, const GradCheckOptions& options,
    const ComputeControl& control = {});

// Bytes RunGradCheck holds besides its evaluator, estimated before it runs:
// three passes' hit tables and values (the base and a probe's two), and the
// Jacobian at 2K + 32 entries per vertex for K rays (horse.ply has 155 at
// K = 100, rocker-arm.obj 61).
int64_t GradCheckWorkBytes(const Mesh& mesh, const SdfParams& params);

// What RunGradCheck refuses before it builds or traces anything:
// InvalidArgument (parameters, options, a vertex out of range, the
// penalty's parameters), FailedPrecondition (angle-weighted normals).
absl::Status ValidateGradCheck(const Mesh& mesh, const SdfParams& params,
                               const GradCheckOptions& options);

// The ray passes of a check without repeats: the base pass and two per
// probed coordinate (the listed vertices, or `samples` vertices on a face).
int64_t GradCheckPasses(const Mesh& mesh, const GradCheckOptions& options);

}  // namespace meshgauge
