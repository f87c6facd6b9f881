// The cone of rays of SPEC §3 and the frames that map it to world space.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/vec3.h"

namespace meshgauge {

// One ray of the cone in the local frame (u, v, axis): the world direction
// is d = local.x * u + local.y * v + local.z * axis (unit length).
struct ConeRay {
  Vec3 local;
  double angle = 0;   // |theta_k|, radians, angle between ray and axis.
  double weight = 0;  // w_k = 1 / max(|theta_k|, theta_min).
};

// Builds the K rays of SPEC §3.
//  * 2D: theta_k = -alpha/2 + alpha (k + 1/2) / K, local = (sin, 0, cos).
//  * 3D: golden-angle spiral uniform in solid angle over the cap of half
//    angle alpha/2.
// aperture_radians: full opening angle alpha in (0, pi). rays: K in
// [1, 4096]. min_weight_angle: theta_min > 0 in radians.
// Errors: InvalidArgument naming the parameter and its range.
absl::StatusOr<std::vector<ConeRay>> MakeCone(int dimension,
                                              double aperture_radians, int rays,
                                              double min_weight_angle);

// An orthonormal frame (u, v, axis) for a unit cone axis.
//  * `reference` >= 0: the mesh-attached frame of SPEC v2 §3, u = w/|w| with
//    w = e - (e.axis) axis, e = x_q - x_p the edge to neighbour q =
//    reference, v = axis x u. `edge` is e and `w_norm` is |w| (needed by the
//    derivative).
//  * `reference` == -1: the world frame (SPEC v1): 3D, the Rodrigues rotation
//    taking z^ to the axis (within 1e-6 of -z^ the rotation about x^ by pi);
//    2D, u = (-axis.y, axis.x, 0) and v = 0.
struct ConeFrame {
  Vec3 u, v, axis;
  int32_t reference = -1;
  Vec3 edge;
  double w_norm = 0;
};

// The world frame (see ConeFrame). Used in 2D, and in 3D only as the
// fallback for a degenerate one-ring.
ConeFrame MakeWorldFrame(int dimension, const Vec3& axis);

// SPEC v2 §3: the first of `neighbors` (edge-neighbours of vertex p in
// increasing index) whose edge e = positions[q] - x_p has a component
// orthogonal to `axis` of length >= 1e-3 |e| defines u. Falls back to
// MakeWorldFrame(3, axis) (reference == -1) when none qualifies.
// Preconditions: |axis| == 1; every neighbour index is valid in `positions`.
ConeFrame MakeAttachedFrame(const Vec3& axis, const Vec3& x_p,
                            absl::Span<const int32_t> neighbors,
                            absl::Span<const Vec3> positions);

// Vector-Jacobian product of a frame: given covectors g_u = dL/du and
// g_v = dL/dv, `axis` receives dL/daxis (the axis treated as a free
// 3-vector; callers project onto the sphere's tangent plane) and `edge`
// receives dL/de, e = x_q - x_p (so dL/dx_q = edge, dL/dx_p = -edge; zero
// for the world frame). The world frame's derivative is zero in the -z^
// cap, where it is constant.
struct FrameGradient {
  Vec3 axis;
  Vec3 edge;
};
FrameGradient FrameVjp(int dimension, const ConeFrame& frame, const Vec3& g_u,
                       const Vec3& g_v);

}  // namespace meshgauge
