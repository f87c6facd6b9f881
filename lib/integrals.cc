#include "lib/integrals.h"

#include <cmath>

namespace meshgauge {
namespace {

// 2-point Gauss on [0, 1]: points (1 -+ 1/sqrt 3)/2, weights 1/2.
constexpr double kGaussLo = 0.21132486540518711775;
constexpr double kGaussHi = 0.78867513459481288225;

// Degree-2 rule on a triangle: barycentric (2/3, 1/6, 1/6) and permutations,
// weights 1/3.
constexpr double kTriMajor = 2.0 / 3.0;
constexpr double kTriMinor = 1.0 / 6.0;

double TriangleIntegral(double area, double a, double b, double c,
                        const std::function<double(double)>& phi) {
  if (!phi) return area * (a + b + c) / 3;
  const double q0 = kTriMajor * a + kTriMinor * b + kTriMinor * c;
  const double q1 = kTriMinor * a + kTriMajor * b + kTriMinor * c;
  const double q2 = kTriMinor * a + kTriMinor * b + kTriMajor * c;
  return area * (phi(q0) + phi(q1) + phi(q2)) / 3;
}

}  // namespace

double FaceMeasure(const Mesh& mesh, const Face& f) {
  const auto& p = mesh.positions;
  if (f.size == 2) return Norm(p[f.v[1]] - p[f.v[0]]);
  double area = Norm(Cross(p[f.v[1]] - p[f.v[0]], p[f.v[2]] - p[f.v[0]])) / 2;
  if (f.size == 4) {
    area += Norm(Cross(p[f.v[2]] - p[f.v[0]], p[f.v[3]] - p[f.v[0]])) / 2;
  }
  return area;
}

IntegralResult IntegrateNodal(const Mesh& mesh,
                              const std::vector<double>& values,
                              const std::function<double(double)>& phi) {
  IntegralResult r;
  const auto& p = mesh.positions;
  for (const Face& f : mesh.faces) {
    bool finite = true;
    for (int k = 0; k < f.size; ++k) finite &= std::isfinite(values[f.v[k]]);
    if (!finite) {
      ++r.skipped_faces;
      continue;
    }
    if (f.size == 2) {
      const double len = Norm(p[f.v[1]] - p[f.v[0]]);
      const double a = values[f.v[0]], b = values[f.v[1]];
      r.value += phi ? len * (phi(kGaussHi * a + kGaussLo * b) +
                              phi(kGaussLo * a + kGaussHi * b)) / 2
                     : len * (a + b) / 2;
      r.measure += len;
      continue;
    }
    for (int t = 0; t + 2 < f.size; ++t) {
      const int i0 = f.v[0], i1 = f.v[t + 1], i2 = f.v[t + 2];
      const double area = Norm(Cross(p[i1] - p[i0], p[i2] - p[i0])) / 2;
      r.value += TriangleIntegral(area, values[i0], values[i1], values[i2], phi);
      r.measure += area;
    }
  }
  return r;
}

}  // namespace meshgauge
