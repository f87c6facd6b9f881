// The inscribed-ball thickness of one vertex against one primitive (SPEC v2
// §5b): the smallest ball tangent at x to the plane normal to the axis that
// touches the primitive's admissible part, and its exact derivative.
//
// For a point s, rho(s) = |s - x|^2 / (2 a.(s - x)) is the radius of the
// ball tangent at x (centre x + rho a) whose sphere passes through s; s is
// admissible when the angle psi between a and s - x is at most beta. The
// balls are nested (rho < r exactly when s lies inside the ball of radius r),
// so rho is quasiconvex and its minimum over the convex admissible part of a
// triangle is one of a few closed forms: the minimum over the triangle's
// plane, a corner, a stationary point on an edge, an edge's crossing of the
// cone psi = beta, or the extreme point of the plane's conic psi = beta.
// MinimumTangentBall tries them all; TangentBallGradient differentiates the
// one that won (the case is piecewise constant in the positions, SPEC §6).
#pragma once

#include <limits>

#include "lib/core/hit.h"
#include "lib/core/vec3.h"

namespace meshgauge {

struct BallContact {
  // min rho over the primitive's admissible part (mesh units); +infinity
  // when no point is admissible.
  double radius = std::numeric_limits<double>::infinity();
  // Which closed form gives the minimiser (for TangentBallGradient); -1
  // when none.
  int kind = -1;
  // Barycentric coordinates of the touching point on the primitive (a
  // segment's third is 0).
  double lambda[3] = {};
};

// `axis` is a unit vector; cos_beta = cos(beta) with beta in (0, 90)
// degrees. x itself is not admissible. Computed relative to x: the result
// does not depend on where the part sits.
BallContact MinimumTangentBall(const PrimitiveCorners& pc, const Vec3& x,
                               const Vec3& axis, double cos_beta);

// The contact cone {w : axis.w >= cos_beta |w|} of one vertex, with what
// culling against it needs.
struct ContactCone {
  Vec3 axis;  // unit.
  double cos_beta = 0, sin_beta = 0;
  // The relative margin by which a point must lie beyond a plane through x
  // that leaves the cone on its other side before it can be culled:
  // MinimumTangentBall admits points a relative 1e-12 outside the cone.
  double cull_slack = 0;
};
ContactCone MakeContactCone(const Vec3& axis, double cos_beta);

// True when a plane through the cone's apex with normal nu (unit) leaves
// the cone on its side nu.w <= 0 and the point w (relative to the apex) lies
// beyond it by more than the cone's cull slack of `extent` (>= |w|).
inline bool BeyondCone(const ContactCone& cone, const Vec3& nu, const Vec3& w,
                       double extent) {
  return Dot(nu, w) > cone.cull_slack * extent;
}

// The normal nu = e cos(beta) - axis sin(beta) of such a plane, e the unit
// direction of `w` across the axis; false when w is on the axis.
bool SeparatingNormal(const ContactCone& cone, const Vec3& w, Vec3* nu);

// True when the primitive may meet the closed ball (centre, radius): its
// closest point to the centre (Ericson's Voronoi regions) lies within the
// radius, with a slack of a relative 1e-9 of the sizes involved, so that
// rounding never makes it false for a primitive that meets the ball. Best
// called with coordinates relative to a point near the centre.
bool ClosestPointWithin(const PrimitiveCorners& pc, const Vec3& centre,
                        double radius);

// False when no admissible point of the primitive lies in the closed ball
// of `radius` tangent at x (centre x + radius axis): the primitive is
// outside the ball or outside the contact cone. Conservative: rounding
// never makes it false for a primitive that has such a point.
bool MayTouchBall(const PrimitiveCorners& pc, const Vec3& x,
                  const ContactCone& cone, double radius);

// d radius / d (x, axis, corners) of contact `kind` (from
// MinimumTangentBall at the same arguments), by forward-mode automatic
// differentiation of its closed form. All zero for kind -1.
struct BallGradient {
  Vec3 x, axis, corner[3];
};
BallGradient TangentBallGradient(const PrimitiveCorners& pc, const Vec3& x,
                                 const Vec3& axis, double cos_beta, int kind);

}  // namespace meshgauge
