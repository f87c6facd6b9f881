// 2D curves stored as OBJ polylines (`l` elements).
#pragma once

#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "lib/mesh.h"

namespace meshgauge {

// If the OBJ file at `path` has `l` elements, returns the 2D mesh they form
// (dimension 2; each polyline `l i0 i1 ... in` gives the segments
// (i0,i1), ..., (in-1,in); 1-based or negative relative indices; `v/vt`
// references use the vertex part; `g ID` with an integer ID puts the
// following polylines in region ID). Returns nullopt when the file has no `l`
// element (a 3D OBJ). Errors: InvalidArgument for an OBJ mixing `f` and `l`,
// unparsable numbers or a polyline with fewer than 2 vertices.
// The caller validates z == 0 via ValidateMesh.
absl::StatusOr<std::optional<Mesh>> ReadObjCurveIfAny(const std::string& path);

}  // namespace meshgauge
