// Where a sample's rays start (issue 52): past an empty tangent ball.
//
// Every ray of a sample leaves the surface at the sample point x, inside the
// cone of half-angle max_angle around the axis. A general ray tracer walks
// each ray's BVH from x, through the dense boxes of the surface around it:
// started 2 mean edge lengths out, Embree's rays took about 0.7 of the time
// on igea (docs/benchmarks.md). A single query per sample on a BallTree
// certifies that no primitive but the excluded ones (the one-ring) has a
// point in the ball of radius r tangent at x (centre x + r axis) within
// the contact cone of half-angle max_angle + kAngleMargin: a ray at angle
// theta from the axis then meets nothing before it leaves the ball, at
// t = 2 r cos(theta), and Embree may start it there. The hits, candidates
// and near() marks of every ray are those of rays started at the surface
// (the start only skips a stretch proven empty): the values, hit tables and
// near flags stay the same bits.
//
// Why the single-precision rays keep that promise (docs/numerics.md,
// "Starting rays past an empty ball"):
//  * Embree traces from the origin and direction rounded to single
//    precision: within a = reach 2^-21 of x and 2^-20 of the direction, so
//    for t >= t_apex = a / (sin(kAngleMargin) - 2^-20) the traced ray stays
//    inside the wider contact cone. Nearer to x than t_apex + a it may not:
//    no primitive but the excluded ones may come within ApexRadius of x, or
//    the sample falls back to starting at the surface.
//  * The start is 2 r cos(theta) (1 - 2^-8). The ray crosses the sphere at
//    the angle theta to its normal, so the start lies 2 r cos^2(theta) 2^-8
//    inside the ball: at least reach 2^-18, because balls below
//    reach 2^-11 / cos^2(max_angle) fall back. That is 8 times the rounding
//    of the traced ray (a + 2 r 2^-20) and of Embree's distance to a
//    primitive met at an angle that is not grazing.
// Limit: Embree's single-precision distance to a primitive met at a
// grazing angle (nearly parallel to the ray) may be off by far more; such
// a primitive lying just past the ball, rounded to a distance before the
// start, would be reported from the surface and not from the start. No
// test mesh shows one (RayStartTest compares every ray).
// The ball looked for is at most kCapEdgeLengths mean edge lengths: where
// the part is thinner it shrinks to the far wall; its size changes the
// work, never a hit.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/types/span.h"
#include "lib/core/cone.h"
#include "lib/core/mesh_geometry.h"
#include "lib/core/vec3.h"
#include "lib/embree/ball_tree.h"
#include "lib/embree/ray_scene.h"

namespace meshgauge {

class RayStarts {
 public:
  // The contact cone is wider than the rays' by this many radians.
  static constexpr double kAngleMargin = 0.02;
  // A sample's ball is looked for up to this many mean edge lengths: rays
  // started 2 edge lengths out save about all that starting them farther
  // saves, and a larger ball touches more primitives (docs/benchmarks.md).
  static constexpr double kCapEdgeLengths = 2;
  // For the rays `cone` (3D); empty() when their half-angle plus the margin
  // is not below 80 degrees (the contact cone must stay narrow).
  explicit RayStarts(absl::Span<const ConeRay> cone);
  bool empty() const { return chord_cos_.empty(); }
  // cos of the contact cone's half-angle (the rays' plus kAngleMargin).
  double cos_beta() const { return cos_beta_; }

  // The largest radius, at most `cap`, of a ball tangent at x (centre x +
  // r axis, axis a unit vector) that no primitive outside `excluded`
  // (ascending) enters within the contact cone, when that ball is large
  // enough to start rays past it (see above) and nothing but the excluded
  // primitives comes within ApexRadius of x; else 0. `reach`: MaxAbs of x
  // relative to the scene's origin; `limits`: the pass's.
  double EmptyBall(const MeshGeometry& g, const BallTree& tree, const Vec3& x,
                   const Vec3& axis, absl::Span<const int32_t> excluded,
                   double cap, double reach,
                   const RayScene::FanLimits& limits) const;

  // starts[j] for the rays `rays` (indices of the cone's rays): where ray
  // rays[j] leaves the empty ball of radius `r` (from EmptyBall, > 0), not
  // below limits.t_near.
  void Fill(double r, absl::Span<const int> rays,
            const RayScene::FanLimits& limits,
            std::vector<float>* starts) const;

  // The radius around x within which no primitive but the excluded ones
  // may lie (see above).
  static double ApexRadius(double reach, const RayScene::FanLimits& limits);

 private:
  double cos_beta_ = 0;
  double min_radius_ = 0;          // of the reach: 2^-11 / cos^2(max_angle).
  std::vector<double> chord_cos_;  // per ray: 2 cos(theta) (1 - 2^-8).
};

}  // namespace meshgauge
