#include "lib/embree/inscribed_ball_query.h"

#include <algorithm>

#include "lib/embree/hit_candidates.h"

namespace meshgauge {

VertexBall InscribedBall(const MeshGeometry& geometry, const RayScene& scene,
                         const BallTree& tree, const Vec3& x, const Vec3& axis,
                         absl::Span<const int32_t> excluded,
                         const BallLimits& limits) {
  VertexBall best;
  best.contact.radius = limits.cap;
  const ContactCone cone = MakeContactCone(axis, limits.cos_beta);
  auto consider = [&](int32_t prim) {
    if (std::binary_search(excluded.begin(), excluded.end(), prim)) {
      return best.contact.radius;
    }
    const PrimitiveCorners pc = geometry.Corners(prim);
    const double r = best.contact.radius;
    if (!MayTouchBall(pc, x, cone, r)) return r;
    const BallContact c = MinimumTangentBall(pc, x, axis, limits.cos_beta);
    if (!(c.radius >= limits.min_radius)) return r;
    if (c.radius < r ||
        (c.radius == r && (best.prim < 0 || prim < best.prim))) {
      best.contact = c;
      best.prim = prim;
    }
    return best.contact.radius;
  };
  // A first ball from the primitive the axis' ray meets (its ball is at
  // most half the distance), then the tree's boxes that may hold a point
  // of the shrinking ball.
  const Vec3 dirs[1] = {axis};
  HitCandidates ray(static_cast<float>(MaxAbs(x - scene.origin())));
  scene.IntersectFan(x, dirs, limits.fan, excluded, absl::MakeSpan(&ray, 1));
  for (int i = 0; i < ray.count(); ++i) consider(ray[i].prim);
  tree.Visit(x, cone, best.contact.radius, consider);
  if (best.prim < 0) best.contact = BallContact();
  return best;
}

}  // namespace meshgauge
