// A spatially coherent visiting order of points (Z-order / Morton curve), so
// that neighbouring work items touch neighbouring memory and BVH nodes
// whatever the order the points came in.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/types/span.h"
#include "lib/core/vec3.h"

namespace meshgauge {

// Indices of `points` sorted along a Morton curve of their bounding box (21
// bits per axis; ties in index order, so the order is deterministic).
// O(n log n), in the caller's TBB arena. Precondition: finite points, fewer
// than 2^31.
std::vector<int32_t> MortonOrder(absl::Span<const Vec3> points);

}  // namespace meshgauge
