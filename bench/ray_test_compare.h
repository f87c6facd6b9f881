// What Embree's watertight ray test costs and what dropping it would change:
// meshgauge's values pass with RayTest::kWatertight (the default) and with
// RayTest::kFast over the same rays, compared vertex by vertex.
#pragma once

#include <cstdint>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"

namespace meshgauge::bench {

struct RayTestComparison {
  int64_t rays = 0;  // rays traced by each pass.
  // Best rate of each pass over the rounds (rays per second).
  double watertight_rate = 0, fast_rate = 0;
  // Rays that hit within max_distance, summed over the vertices.
  int64_t watertight_hits = 0, fast_hits = 0;
  // Vertices whose value differs (bitwise, or present in one pass only),
  // and the largest relative difference among those present in both.
  int64_t vertices = 0, differing = 0;
  double max_relative_difference = 0;
};

// Runs both passes `rounds` times (interleaved; >= 1) with `params` on
// `threads` threads (0: all cores).
// Errors: those of SdfEvaluator::Create and Compute.
absl::StatusOr<RayTestComparison> CompareRayTests(const Mesh& mesh,
                                                  const SdfParams& params,
                                                  int threads, int rounds);

}  // namespace meshgauge::bench
