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

void ForEachElement(
    const Mesh& mesh,
    const std::function<void(int64_t face, const Element&)>& fn) {
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

int64_t ForEachValuedElement(
    const Mesh& mesh, const std::vector<double>& values,
    const std::function<void(const Element&, const double* t)>& fn) {
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
