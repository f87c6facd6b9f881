// Minimum-thickness penalty and aggregated constraint (SPEC v2 §7).
//
// Penalty forms: P = integral of phi(t) over the surface, t the linearly
// interpolated SDF. Constraint form (KS): G = (1/rho) ln((1/|Gamma|)
// integral of exp(rho (1 - t/t_min))), a soft maximum of 1 - t/t_min.
// Gradients: through the SDF (sum_p dP/dt_p dSDF_p/dx, frozen hits) plus the
// explicit dependence of the element measures (and, for KS, of |Gamma|) on x,
// which the thesis left out.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/exact_sum.h"
#include "lib/core/hit_table.h"
#include "lib/core/mesh_geometry.h"

namespace meshgauge {

enum class PenaltyForm {
  kOneSided,  // phi(t) = max(0, 1 - t/t_min)^n: penalises thin only (default).
  kThesis,    // phi(t) = (t/t_min - 1)^n (thesis eq. 4.1); n must be an
              // integer.
  kKs,        // the aggregated constraint G above (dimensionless); G <= 0
              // asks for t >= t_min up to the KS slack (docs/sensitivities.md).
};

struct PenaltyParams {
  double t_min = 0;  // minimum thickness, mesh units, > 0.
  PenaltyForm form = PenaltyForm::kOneSided;
  double power = 2;  // n >= 1 (kOneSided, kThesis).
  double rho = 50;   // KS aggregation parameter, > 0 (kKs).
  // The call fails (FailedPrecondition) when the faces skipped for missing
  // values cover more than this fraction of the surface, in [0, 1].
  double max_missing_fraction = 0.5;
};

// InvalidArgument naming the bad parameter.
absl::Status ValidatePenaltyParams(const PenaltyParams& params);

struct PenaltyResult {
  double value = 0;       // P in length^(dim-1), or G (dimensionless) for kKs.
  MissingValues missing;  // what the integral skipped.
  // dP/dt_p per sample: #V, or #F for face samples (SPEC v2 §5c), whose
  // penalty is the sum over faces of |f| phi(t_f): t is constant on a face.
  std::vector<double> dp_dt;
  // With gradient: dP/dx per vertex (#V; z = 0 in 2D), and its explicit
  // measure part alone (already included in `gradient`).
  std::vector<Vec3> gradient;
  std::vector<Vec3> measure_gradient;
  // With the hit table of a range pass (a part of a fanned-out call,
  // docs/server.md): `gradient` is empty and this holds the VJP of dp_dt
  // over the range's samples as exact sums, x, y, z per vertex. The whole
  // call's gradient is PenaltyGradient of the parts' sums added exactly.
  ExactSums vjp_sums;
};

// Penalty or constraint of `sdf` (a Compute of the SdfEvaluator `geometry`
// at its current positions: every sample's values). With
// `hits_for_gradient` (the hit table of that Compute) the gradient is
// computed too; see ComputeVjp. With the hit table of a range pass over the
// same values (its samples' values are sdf's), only that range's part of
// the gradient: PenaltyResult::vjp_sums.
// Errors: InvalidArgument (params, wrong sizes); FailedPrecondition when the
// missing values cover more than params.max_missing_fraction of the surface
// (naming the fraction and the likely cause), when no face has values, or
// for a hit table of another generation; Cancelled.
absl::StatusOr<PenaltyResult> ComputePenalty(const MeshGeometry& geometry,
                                             const SdfResult& sdf,
                                             const PenaltyParams& params,
                                             const HitTable* hits_for_gradient,
                                             const ComputeControl& control = {});

// The gradient from the VJP of dp_dt (exact sums, x, y, z per vertex) and
// the explicit measure part: each sum rounded once, then the measure part
// added.
std::vector<Vec3> PenaltyGradient(const ExactSums& vjp_sums,
                                  absl::Span<const Vec3> measure_gradient);

const char* PenaltyFormName(PenaltyForm form);

}  // namespace meshgauge
