// How closed shells nest: a cavity's shell lies inside its part's outer
// shell, an island inside the cavity inside that, and so on. A shell's
// correct orientation follows from its depth: outward (positive signed
// volume) at even depth, into the cavity (negative) at odd depth.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/core/mesh.h"

namespace meshgauge {

struct Component;

// For each component: how many of the other closed components enclose it
// (0 for components that are not closed; they enclose nothing either). A
// shell encloses a component when the shell's winding number at a point of
// that component (its first face's centroid) is at least 1/2 in magnitude,
// whatever the shell's orientation. Shells that cross or touch have no
// nesting to speak of: they count as enclosing where that point falls.
// Cost: O(F) per pair whose bounding boxes nest, none for one component.
// Precondition: face indices in range; components from ConnectedComponents.
std::vector<int32_t> NestingDepths(const Mesh& mesh,
                                   const std::vector<Component>& components);

// The winding number of the faces `faces` about `point` (3D: solid angles
// over 4 pi, quads as two triangles; 2D: segments' angles over 2 pi).
// Positive when the faces wind counter-clockwise about it (outward normals
// of a closed shell around it). Precondition: point on none of the faces.
double WindingNumber(const Mesh& mesh, const std::vector<int32_t>& faces,
                     const Vec3& point);

}  // namespace meshgauge
