// Minimum-thickness penalty (SPEC §7): P = integral of phi(t) over the
// surface, t the linearly interpolated SDF, and its gradient
// dP/dx = sum_p dP/dt_p dSDF_p/dx (through the SDF, frozen hits)
//       + sum_elements sum_q w_q phi(t_q) d|e|/dx (the explicit dependence of
//         the element measures on x, which the thesis left out).
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/sdf_evaluator.h"

namespace meshgauge {

enum class PenaltyForm {
  kOneSided,  // phi(t) = max(0, 1 - t/t_min)^n: penalises thin only (default).
  kThesis,    // phi(t) = (t/t_min - 1)^n (thesis eq. 4.1); n must be an
              // integer.
};

struct PenaltyParams {
  double t_min = 0;  // minimum thickness, mesh units, > 0.
  PenaltyForm form = PenaltyForm::kOneSided;
  double power = 2;  // n >= 1.
};

// InvalidArgument naming the bad parameter.
absl::Status ValidatePenaltyParams(const PenaltyParams& params);

struct PenaltyResult {
  double value = 0;           // P, in length^(dim-1).
  int64_t skipped_faces = 0;  // faces with a vertex without a value.
  std::vector<double> dp_dt;  // dP/dt_p per vertex (#V).
  // With gradient: dP/dx per vertex (#V; z = 0 in 2D), and its explicit
  // measure part alone (already included in `gradient`).
  std::vector<Vec3> gradient;
  std::vector<Vec3> measure_gradient;
};

// Penalty of `values` (#V, NaN where there is no value: an SdfResult of the
// evaluator at its current positions). With `hits_for_gradient` (the hit
// table of that Compute) the gradient is computed too; see ComputeVjp.
// Errors: InvalidArgument (params, wrong sizes), FailedPrecondition (hit
// table of another generation), Cancelled.
absl::StatusOr<PenaltyResult> ComputePenalty(const SdfEvaluator& evaluator,
                                             const std::vector<double>& values,
                                             const PenaltyParams& params,
                                             const HitTable* hits_for_gradient,
                                             const ComputeControl& control = {},
                                             int threads = 0);

}  // namespace meshgauge
