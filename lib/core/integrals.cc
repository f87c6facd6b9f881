#include "lib/core/integrals.h"

#include <cmath>

namespace meshgauge {

const std::vector<QuadraturePoint>& QuadratureRule(int n) {
  // 2-point Gauss on [0, 1]: points (1 -+ 1/sqrt 3)/2, weights 1/2.
  static const std::vector<QuadraturePoint> kSegment = {
      {0.5, {0.78867513459481288225, 0.21132486540518711775, 0}},
      {0.5, {0.21132486540518711775, 0.78867513459481288225, 0}}};
  // Degree 2 on a triangle: barycentric (2/3, 1/6, 1/6) and permutations.
  static const std::vector<QuadraturePoint> kTriangle = {
      {1.0 / 3, {2.0 / 3, 1.0 / 6, 1.0 / 6}},
      {1.0 / 3, {1.0 / 6, 2.0 / 3, 1.0 / 6}},
      {1.0 / 3, {1.0 / 6, 1.0 / 6, 2.0 / 3}}};
  return n == 2 ? kSegment : kTriangle;
}

void ElementMeasureGradient(const Mesh& mesh, const Element& e, Vec3 grad[3]) {
  const auto& p = mesh.positions;
  if (e.n == 2) {
    const Vec3 u = (p[e.v[1]] - p[e.v[0]]) / e.measure;
    grad[0] = -u;
    grad[1] = u;
    grad[2] = Vec3();
    return;
  }
  // A = |m| / 2 with m = (b-a) x (c-a): dA/dx = (m/|m|)^T dm/dx / 2.
  const Vec3 a = p[e.v[0]], b = p[e.v[1]], c = p[e.v[2]];
  const Vec3 m = Cross(b - a, c - a);
  const Vec3 g = m / (2 * Norm(m));
  grad[1] = Cross(c - a, g);
  grad[2] = Cross(g, b - a);
  grad[0] = -(grad[1] + grad[2]);
}

IntegralResult IntegrateNodal(const Mesh& mesh,
                              const std::vector<double>& values,
                              const std::function<double(double)>& phi) {
  IntegralResult r;
  r.skipped_faces = ForEachValuedElement(
      mesh, values, [&](const Element& e, const double* t) {
        double sum = 0;
        const auto& rule = QuadratureRule(e.n);
        for (size_t q = 0; q < rule.size(); ++q) {
          sum += rule[q].weight * (phi ? phi(t[q]) : t[q]);
        }
        r.value += e.measure * sum;
        r.measure += e.measure;
      });
  return r;
}

IntegralResult IntegrateFaceValues(const Mesh& mesh,
                                   const std::vector<double>& values) {
  IntegralResult r;
  int64_t last_skipped = -1;
  ForEachElement(mesh, [&](int64_t face, const Element& e) {
    if (!std::isfinite(values[face])) {
      r.skipped_faces += face != last_skipped;
      last_skipped = face;
      return;
    }
    r.value += e.measure * values[face];
    r.measure += e.measure;
  });
  return r;
}

IntegralResult IntegrateSdf(const Mesh& mesh, const SdfResult& result) {
  return result.resolved.params.samples == SampleSet::kFaces
             ? IntegrateFaceValues(mesh, result.values)
             : IntegrateNodal(mesh, result.values);
}

}  // namespace meshgauge
