// The baseline of the benchmarks: a plain Embree rtcIntersect1 pass over
// exactly the rays meshgauge traces (same origins, same cone directions),
// with no filter callback, no double-precision recomputation and no
// estimator.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"

namespace meshgauge::bench {

struct RawPassResult {
  int64_t rays = 0;
  int64_t hits = 0;
  double seconds = 0;
};

// Builds a MEDIUM-quality, ROBUST (watertight, as meshgauge's) Embree scene of
// the mesh's triangles (3D only) and traces, for every vertex with faces, the
// resolved cone of `params` with tnear = eps * h and tfar = bounding-box
// diagonal, over vertices in a oneTBB parallel_for with `params.threads`
// threads. Only the ray pass is timed.
absl::StatusOr<RawPassResult> RunRawPass(const Mesh& mesh,
                                         const SdfParams& params);

}  // namespace meshgauge::bench
