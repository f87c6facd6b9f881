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

#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "lib/core/penalty.h"
#include "lib/core/sdf_types.h"

namespace meshgauge {

struct GradCheckOptions {
  int samples = 12;   // vertices sampled (with a face), >= 1.
  uint64_t seed = 1;  // sampling seed.
  // Explicit vertices to perturb; when not empty, samples and seed are
  // ignored.
  std::vector<int32_t> vertices;
  // Also check dP/dx (or dG/dx for the KS form) against central differences.
  std::optional<PenaltyParams> penalty;
  double relative_step = 1e-7;
  double tolerance = 1e-5;
  double min_clean_fraction = 0.9;
};

enum class GradCheckVerdict { kPass, kFail, kInconclusive };

struct GradCheckRow {
  int32_t row = -1;     // the SDF of this vertex; -1 for the penalty.
  int32_t vertex = -1;  // the vertex moved.
  int coordinate = 0;   // 0, 1, 2 = x, y, z.
  double analytic = 0, fd = 0, relative_error = 0;
  bool clean = false;  // false: an event (hit or kept set changed).
  double step = 0;     // the step of the attempt kept (mesh units).
  // Penalty rows: the explicit element-measure part of `analytic`.
  double measure_part = 0;
};

struct GradCheckReport {
  std::vector<GradCheckRow> rows;          // SDF entries with a nonzero side.
  std::vector<GradCheckRow> penalty_rows;  // one per (vertex, coordinate).
  int64_t clean = 0, passed = 0;
  double worst = 0;  // largest relative error of a clean row.
  int64_t vjp_checks = 0, vjp_passed = 0;  // g^T J against sum_p g_p FD_p.
  int64_t penalty_clean = 0, penalty_passed = 0;
  // Norms |dSDF_p/dx_j| over the Jacobian's nonzero entries.
  double max_abs_derivative = 0, median_abs_derivative = 0;
  int64_t world_frame_vertices = 0;
  double min_clean_fraction = 0.9;
  // Rays traced by all passes (each probe reuses the base pass's rays
  // where the probed vertex cannot change them) and by one full pass.
  int64_t rays_traced = 0, full_pass_rays = 0;

  // Probe repeats with a smaller step (up to 2 per probe) because a sample
  // crossed an event.
  int64_t retried = 0;

  // SPEC §6: every clean sample (and every VJP and clean penalty row)
  // within tolerance, and enough clean samples.
  GradCheckVerdict Verdict() const;
  bool Passed() const { return Verdict() == GradCheckVerdict::kPass; }
};

// Precondition: none. Errors: InvalidArgument (mesh, params, options),
// FailedPrecondition (angle-weighted normals; a penalty over mostly missing
// values), Cancelled.
absl::StatusOr<GradCheckReport> RunGradCheck(
    const Mesh& mesh, const SdfParams& params, const GradCheckOptions& options,
    const ComputeControl& control = {});

// |fd - analytic| / max(|analytic|, |fd|, 1e-2).
double GradCheckRelativeError(double fd, double analytic);

}  // namespace meshgauge
