// Double-precision ray/primitive geometry of SPEC §4 and §6.
#pragma once

#include <cmath>
#include <limits>

#include "lib/core/mesh.h"
#include "lib/core/topology.h"

namespace meshgauge {

struct HitGeometry {
  double t = 0;           // distance along the unit direction.
  Vec3 m;                 // (b-a) x (c-a) (3D) or perp(b-a) (2D).
  double d_dot_m = 0;     // d . m, nonzero.
  double lambda[3] = {};  // barycentric coordinates of the hit point.
};

// The corners of one primitive in double precision, read from the
// positions for one hit evaluation. `segment` is true for 2D segments (c
// unused).
struct PrimitiveCorners {
  Vec3 a, b, c;
  int32_t face = -1;  // the mesh face the primitive belongs to.
  bool segment = false;
};

// Writes `prim`'s corners into *out in place (c = 0 for a segment), as
// CornersOf returns them; a copy of a returned PrimitiveCorners into an
// array went through the stack.
inline void LoadCorners(const Mesh& mesh, const Primitive& prim,
                        PrimitiveCorners* out) {
  out->a = mesh.positions[prim.v[0]];
  out->b = mesh.positions[prim.v[1]];
  out->face = prim.face;
  out->segment = prim.v[2] < 0;
  out->c = out->segment ? Vec3() : mesh.positions[prim.v[2]];
}

inline PrimitiveCorners CornersOf(const Mesh& mesh, const Primitive& prim) {
  PrimitiveCorners pc;
  LoadCorners(mesh, prim, &pc);
  return pc;
}

// m = (b-a) x (c-a) (3D) or perp(b-a) (2D).
inline Vec3 PrimitiveNormalOf(const PrimitiveCorners& pc) {
  const Vec3 ab = pc.b - pc.a;
  return pc.segment ? Perp(ab) : Cross(ab, pc.c - pc.a);
}

// Where the ray x + t d meets the primitive's plane, whatever the sign:
// t = ((a - x) . m) / (d . m); infinite or NaN when d . m == 0.
inline double PlaneDistance(const PrimitiveCorners& pc, const Vec3& x,
                            const Vec3& d) {
  const Vec3 m = PrimitiveNormalOf(pc);
  return Dot(pc.a - x, m) / Dot(d, m);
}

// Hit distance only (the value pass): PlaneDistance, or NaN when it is not
// a finite positive number (a miss).
inline double HitDistance(const PrimitiveCorners& pc, const Vec3& x,
                          const Vec3& d) {
  const double t = PlaneDistance(pc, x, d);
  return t > 0 && std::isfinite(t) ? t
                                   : std::numeric_limits<double>::quiet_NaN();
}

// The hit with m, d . m and the barycentric coordinates of the hit point
// (the sensitivities). out->t is bit-identical to HitDistance. Returns false
// exactly when HitDistance returns NaN.
inline bool EvaluateHit(const PrimitiveCorners& pc, const Vec3& x,
                        const Vec3& d, HitGeometry* out) {
  out->m = PrimitiveNormalOf(pc);
  out->d_dot_m = Dot(d, out->m);
  out->t = Dot(pc.a - x, out->m) / out->d_dot_m;
  if (!(out->t > 0) || !std::isfinite(out->t)) return false;
  const Vec3 ab = pc.b - pc.a;
  const Vec3 ah = (x + d * out->t) - pc.a;
  if (pc.segment) {
    const double s = Dot(ah, ab) / Dot(ab, ab);
    out->lambda[0] = 1 - s;
    out->lambda[1] = s;
    out->lambda[2] = 0;
  } else {
    const Vec3 ac = pc.c - pc.a;
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
