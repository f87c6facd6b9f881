// Surface integrals of nodal values (SPEC §7): values are interpolated
// linearly on each face and integrated with a 2-point Gauss rule (segments)
// or the 3-point degree-2 rule (triangles; quads as two triangles).
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"

namespace meshgauge {

struct IntegralResult {
  double value = 0;           // integral, in (value units) x length^(dim-1).
  double measure = 0;         // total length/area of the faces used.
  int64_t skipped_faces = 0;  // faces with a vertex whose value is not finite.
};

// Integral of phi(t) over the surface, t the interpolated nodal values
// (#V, NaN where there is no value). Faces with any non-finite vertex value
// are skipped and counted. phi defaults to the identity (the integral of the
// SDF, SPEC §7 first bullet).
IntegralResult IntegrateNodal(
    const Mesh& mesh, const std::vector<double>& values,
    const std::function<double(double)>& phi = nullptr);

// Integral of piecewise-constant face values (#F, NaN where there is no
// value: the face is skipped and counted), e.g. face samples (SPEC v2 §5c).
IntegralResult IntegrateFaceValues(const Mesh& mesh,
                                   const std::vector<double>& values);

// The integral of a pass's SDF (SPEC §7 first bullet): IntegrateNodal for
// vertex samples, IntegrateFaceValues for face samples.
IntegralResult IntegrateSdf(const Mesh& mesh, const SdfResult& result);

// One integration element: a segment (n = 2) or a triangle (n = 3; a quad
// gives two) with its vertex ids and measure (length or area).
struct Element {
  int n = 0;
  int32_t v[3] = {-1, -1, -1};
  double measure = 0;
};

// A quadrature point of an element: weight (summing to 1 over the element)
// and the linear shape functions N_i at the point.
struct QuadraturePoint {
  double weight;
  double shape[3];
};

// The rule of SPEC §7 for an element with n vertices: 2 Gauss points on a
// segment, 3 points (degree 2) on a triangle.
const std::vector<QuadraturePoint>& QuadratureRule(int n);

// Calls fn(face, element) for every integration element of every face, in
// face order; `face` is the mesh face index. (A template, as the callers'
// per-element work is small: a call through std::function per element was
// half of integrating a million-vertex mesh's SDF.)
template <typename Fn>
void ForEachElement(const Mesh& mesh, Fn&& fn) {
  const auto& p = mesh.positions;
  for (int64_t f = 0; f < mesh.num_faces(); ++f) {
    const Face& face = mesh.faces[f];
    if (face.size == 2) {
      Element e;
      e.n = 2;
      e.v[0] = face.v[0];
      e.v[1] = face.v[1];
      e.measure = Norm(p[face.v[1]] - p[face.v[0]]);
      fn(f, e);
      continue;
    }
    for (int t = 0; t + 2 < face.size; ++t) {
      Element e;
      e.n = 3;
      e.v[0] = face.v[0];
      e.v[1] = face.v[t + 1];
      e.v[2] = face.v[t + 2];
      e.measure = Norm(Cross(p[e.v[1]] - p[e.v[0]], p[e.v[2]] - p[e.v[0]])) / 2;
      fn(f, e);
    }
  }
}

// Calls fn(e, t) for every element whose vertices all have finite values,
// t[q] the value interpolated at quadrature point q of QuadratureRule(e.n);
// returns the number of faces skipped (a face with any non-finite vertex
// value).
template <typename Fn>
int64_t ForEachValuedElement(const Mesh& mesh,
                             const std::vector<double>& values, Fn&& fn) {
  int64_t skipped = 0, last_skipped = -1;
  ForEachElement(mesh, [&](int64_t face, const Element& e) {
    bool finite = true;
    for (int i = 0; i < e.n; ++i) finite &= std::isfinite(values[e.v[i]]);
    if (!finite) {
      if (face != last_skipped) ++skipped;
      last_skipped = face;
      return;
    }
    double t[3] = {0, 0, 0};
    const auto& rule = QuadratureRule(e.n);
    for (size_t q = 0; q < rule.size(); ++q) {
      for (int i = 0; i < e.n; ++i) t[q] += rule[q].shape[i] * values[e.v[i]];
    }
    fn(e, t);
  });
  return skipped;
}

// d(measure)/dx for the element's vertices (3 entries; z = 0 in 2D).
void ElementMeasureGradient(const Mesh& mesh, const Element& e, Vec3 grad[3]);

}  // namespace meshgauge
