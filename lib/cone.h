// The cone of rays of SPEC §3 and the frame that maps it to world space.
#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "lib/vec3.h"

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

// World frame for a unit cone axis.
//  * 3D: u, v are the images of x^, y^ under the Rodrigues rotation taking
//    z^ to the axis; within 1e-6 of -z^ the rotation about x^ by pi
//    (u = x^, v = -y^).
//  * 2D: u = (-axis.y, axis.x, 0) (the axis turned by +90 degrees), v = 0.
struct ConeFrame {
  Vec3 u, v, axis;
};
ConeFrame MakeFrame(int dimension, const Vec3& axis);

// Vector-Jacobian product of the frame: given covectors g_u = dL/du and
// g_v = dL/dv, returns g_u^T du/daxis + g_v^T dv/daxis, the axis treated as
// a free 3-vector (callers project onto the sphere's tangent plane). Zero in
// the -z^ cap, where the frame is constant.
Vec3 FrameVjp(int dimension, const Vec3& axis, const Vec3& g_u,
              const Vec3& g_v);

}  // namespace meshgauge
