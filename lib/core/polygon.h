// Triangulation of the polygons that OBJ and OFF files may hold (SPEC v2.1
// §1): ear clipping in the polygon's best-fit plane, and for polygons that
// are not simple there the max-min triangulation of their corners.
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
// A polygon that is not simple in that plane (two edges cross or touch, a
// corner repeats, a non-planar face seen edge-on) or has no area there is
// triangulated instead by the triangulation of its corners in order whose
// smallest triangle is largest (O(n^3)): measured along the Newell normal,
// so the triangles face the polygon's way, or by unsigned area when no
// such triangulation has every triangle facing that way; `fallback_used`
// (optional) tells which. Errors: InvalidArgument when n < 3 or
// n > kMaxPolygonCorners, or when every triangulation has a triangle of no
// area (the zero-area test of ValidateMesh): the face is degenerate.
absl::StatusOr<std::vector<std::array<int32_t, 3>>> TriangulatePolygon(
    absl::Span<const Vec3> corners, bool* fallback_used = nullptr);

}  // namespace meshgauge
