// Exact sensitivities of the SDF (SPEC §6) with hit primitives and kept sets
// frozen at the last ray pass.
//
// For vertex p with kept rays k (weights w_k, W = sum w_k):
//   SDF_p = sum_k w_k t_k / W,  t_k = ((a_k - x_p) . m_k) / (d_k . m_k)
//   dt/dx_p = -m/(d.m),  dt/dd = -t m/(d.m),  dt/dx_j = lambda_j m/(d.m)
//   d_k = l_x u + l_y v + l_z a,  a = +-n,  n = N/|N|,
//   dn/dN = (I - n n^T)/|N|,  N = sum over primitives containing p.
// kSphere: T_p = 2 rho of the touching primitive's closed form, frozen with
// the primitive (lib/core/inscribed_ball.h), through x_p, the axis and the
// primitive's corners.
// docs/sensitivities.md derives the chain and says what is frozen.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/exact_sum.h"
#include "lib/core/hit_table.h"
#include "lib/core/mesh_geometry.h"

namespace meshgauge {

// Row-compressed sparse Jacobian dSDF/dx: row p lists (column vertex j,
// dSDF_p/dx_j as a 3-vector; z = 0 in 2D), columns ascending and unique.
// One row per sample (vertex, or face with SampleSet::kFaces: its centroid
// and normal move with its corners), or per sample of a range pass's range;
// rows without a value are empty.
struct SparseJacobian {
  std::vector<int64_t> row_offsets;  // samples + 1
  std::vector<int32_t> columns;
  std::vector<Vec3> values;
  int64_t nonzeros() const { return std::ssize(columns); }
};

// `hits` is the table an SdfEvaluator's Compute(params, control, &hits)
// filled at the geometry's current generation (an SdfEvaluator is a
// MeshGeometry). Errors: FailedPrecondition when it is from another
// generation (the vertices moved since) or when the values used
// angle-weighted normals (no derivative is provided for them); Cancelled via
// control; InvalidArgument for control.threads out of range.
absl::StatusOr<SparseJacobian> ComputeJacobian(
    const MeshGeometry& geometry, const HitTable& hits,
    const ComputeControl& control = {});

// An upper bound on the bytes ComputeJacobian returns for this hit table
// (per sample: 3 entries per kept ray, or 2 in 2D, plus the vertices of
// the sample's point, frame edge and normal; 4 + 24 bytes an entry, 8 a
// row), to bound a Jacobian before it is made (the server's memory
// budget). Close on fine meshes; loose where rays hit the same primitives
// (a 502-vertex knight: 13x). ComputeJacobian reserves its entries (pages
// it does not fill are never touched). Errors: as ComputeJacobian.
absl::StatusOr<int64_t> JacobianBytesBound(const MeshGeometry& geometry,
                                           const HitTable& hits);

// Vector-Jacobian product: out_j = sum_p g_p dSDF_p/dx_j (#V 3-vectors).
// g has one entry per sample, #V or #F, or per sample of a range pass's
// range (ignored where a sample has no value; must be finite).
// Each sample's row is summed in doubles (a sample is never split); the sum
// over samples is exact and rounded once (ExactSum), so the result does not
// depend on the thread count or on how the samples are split (a sample
// range's partial sums, ComputeVjpSums, merged exactly give these bits).
// Only the rows of samples with g_p != 0 are computed (a one-sided penalty's
// weights are 0 away from its thin parts), so the time follows those samples;
// control.progress counts them.
// O(#V) memory (the exact sums, about 48 bytes a vertex, and the order the
// weighted samples are visited in, 4 bytes each: along a Morton curve, for
// the cache, the geometry's vertex_order() filtered, or for face samples
// their centroids sorted, about 48 bytes a weighted face more while that
// order is made, before the sums exist), no dense matrix.
// Errors: as ComputeJacobian, InvalidArgument for a wrong-size or non-finite
// g.
absl::StatusOr<std::vector<Vec3>> ComputeVjp(const MeshGeometry& geometry,
                                             const HitTable& hits,
                                             absl::Span<const double> g,
                                             const ComputeControl& control = {});

// ComputeVjp's exact sums before rounding: x, y, z of vertex j at 3j,
// 3j + 1, 3j + 2.
absl::StatusOr<ExactSums> ComputeVjpSums(
    const MeshGeometry& geometry, const HitTable& hits,
    absl::Span<const double> g, const ComputeControl& control = {});

// Rounds x, y, z sums (3 per vertex, as ComputeVjpSums) to vectors.
std::vector<Vec3> RoundVectors(const ExactSums& xyz);

}  // namespace meshgauge
