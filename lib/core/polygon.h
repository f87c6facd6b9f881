// Triangulation of the simple polygons that OBJ and OFF files may hold
// (SPEC v2 §1): ear clipping in the polygon's best-fit plane.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/vec3.h"

namespace meshgauge {

// Most corners a polygon may have (ear clipping is O(n^2) per polygon).
inline constexpr int kMaxPolygonCorners = 256;

// corners: the polygon's n >= 3 corner positions in order. Projects them on
// the plane normal to their Newell normal and clips ears; returns n - 2
// triangles as indices into `corners`, each with the polygon's orientation.
// Errors: InvalidArgument when n < 3 or n > kMaxPolygonCorners, when the
// polygon has no area in that plane, or when it is not simple there (two
// edges cross or touch, or a corner repeats).
absl::StatusOr<std::vector<std::array<int32_t, 3>>> TriangulatePolygon(
    absl::Span<const Vec3> corners);

}  // namespace meshgauge
