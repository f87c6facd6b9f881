// The inscribed ball of one vertex (SPEC v2 §5b) over a whole mesh: a
// shrinking ball over a BallTree, started from the primitive the axis' ray
// meets.
#pragma once

#include <cstdint>

#include "absl/types/span.h"
#include "lib/core/inscribed_ball.h"
#include "lib/core/mesh_geometry.h"
#include "lib/embree/ball_tree.h"
#include "lib/embree/ray_scene.h"

namespace meshgauge {

struct BallLimits {
  double cap = 0;         // the largest radius looked for: max_distance / 2.
  double min_radius = 0;  // radii below it are self-hits (ignored).
  double cos_beta = 0.5;  // cos of the contact cone's half-angle.
  // For the first estimate, a ray along the axis.
  RayScene::FanLimits fan;
};

struct VertexBall {
  int32_t prim = -1;  // the touching primitive; -1 when none within the cap.
  BallContact contact;
};

// The smallest ball over the primitives not in `excluded` (ascending: the
// vertex's one-ring) with radius in [limits.min_radius, limits.cap]; among
// equal radii the lowest primitive index. The result depends on the
// geometry alone, not on the BVH (every primitive that could touch the
// final ball is examined). `axis` is a unit vector.
VertexBall InscribedBall(const MeshGeometry& geometry, const RayScene& scene,
                         const BallTree& tree, const Vec3& x, const Vec3& axis,
                         absl::Span<const int32_t> excluded,
                         const BallLimits& limits);

}  // namespace meshgauge
