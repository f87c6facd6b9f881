// Surface integrals of nodal values (SPEC §7): values are interpolated
// linearly on each face and integrated with a 2-point Gauss rule (segments)
// or the 3-point degree-2 rule (triangles; quads as two triangles).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "lib/mesh.h"

namespace meshgauge {

struct IntegralResult {
  double value = 0;            // integral, in (value units) x length^(dim-1).
  double measure = 0;          // total length/area of the faces used.
  int64_t skipped_faces = 0;   // faces with a vertex whose value is not finite.
};

// Integral of phi(t) over the surface, t the interpolated nodal values
// (#V, NaN where there is no value). Faces with any non-finite vertex value
// are skipped and counted. phi defaults to the identity (the integral of the
// SDF, SPEC §7 first bullet).
IntegralResult IntegrateNodal(
    const Mesh& mesh, const std::vector<double>& values,
    const std::function<double(double)>& phi = nullptr);

// Measure of one face: segment length, triangle area, quad = two triangles.
double FaceMeasure(const Mesh& mesh, const Face& face);

}  // namespace meshgauge
