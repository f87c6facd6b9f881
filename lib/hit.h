// Double-precision ray/primitive geometry of SPEC §4 and §6.
#pragma once

#include "lib/mesh.h"
#include "lib/topology.h"

namespace meshgauge {

struct HitGeometry {
  double t = 0;          // distance along the unit direction.
  Vec3 m;                // (b-a) x (c-a) (3D) or perp(b-a) (2D).
  double d_dot_m = 0;    // d . m, nonzero.
  double lambda[3] = {}; // barycentric coordinates of the hit point.
};

// Recomputes the hit of origin + t d with `prim` in double precision:
// t = ((a - x) . m) / (d . m). Returns false when d . m == 0 or t is not a
// finite positive number (the caller then treats the ray as a miss).
inline bool EvaluateHit(const Mesh& mesh, const Primitive& prim,
                        const Vec3& x, const Vec3& d, HitGeometry* out) {
  const Vec3& a = mesh.positions[prim.v[0]];
  const Vec3& b = mesh.positions[prim.v[1]];
  const bool segment = prim.v[2] < 0;
  const Vec3 ab = b - a;
  const Vec3 ac = segment ? Vec3() : mesh.positions[prim.v[2]] - a;
  out->m = segment ? Perp(ab) : Cross(ab, ac);
  out->d_dot_m = Dot(d, out->m);
  if (out->d_dot_m == 0) return false;
  out->t = Dot(a - x, out->m) / out->d_dot_m;
  if (!(out->t > 0) || !std::isfinite(out->t)) return false;
  const Vec3 ah = (x + d * out->t) - a;
  if (segment) {
    const double s = Dot(ah, ab) / Dot(ab, ab);
    out->lambda[0] = 1 - s;
    out->lambda[1] = s;
    out->lambda[2] = 0;
  } else {
    const double mm = Dot(out->m, out->m);
    const double beta = Dot(Cross(ah, ac), out->m) / mm;
    const double gamma = Dot(Cross(ab, ah), out->m) / mm;
    out->lambda[0] = 1 - beta - gamma;
    out->lambda[1] = beta;
    out->lambda[2] = gamma;
  }
  return true;
}

}  // namespace meshgauge
