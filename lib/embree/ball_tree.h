// A bounding-volume hierarchy for the inscribed-ball queries (SPEC v2 §5b):
// Embree's SAH builder (rtcBuildBVH) over the primitives' boxes, traversed
// here, because a shrinking tangent ball moves its centre and its contact
// cone culls whole subtrees, neither of which Embree's point query can do.
#pragma once

#include <cstdint>
#include <memory>

#include "absl/functional/function_ref.h"
#include "absl/status/statusor.h"
#include "lib/core/inscribed_ball.h"
#include "lib/core/mesh.h"
#include "lib/core/topology.h"

struct RTCBVHTy;

namespace meshgauge {

class BallTree {
 public:
  // How the tree is built.
  enum class Build {
    // Embree's SAH builder (MEDIUM): for long searches (the inscribed ball).
    kSah,
    // Its Morton builder (LOW): about three times faster to build (igea:
    // 0.027 s against 0.09 s); short queries (ray_start.h) do as well.
    kMorton,
  };
  // Boxes of topo.primitives at mesh.positions, relative to the mesh's
  // centre and rounded outward to single precision; a node's four children
  // are tested at once (SSE) with margins that keep every box a
  // double-precision test would. The build changes the work of a query,
  // never its result. Errors: Internal from Embree.
  static absl::StatusOr<std::unique_ptr<BallTree>> Create(
      const Mesh& mesh, const MeshTopology& topo, Build build = Build::kSah);
  ~BallTree();
  BallTree(const BallTree&) = delete;
  BallTree& operator=(const BallTree&) = delete;

  // Calls visit(prim) for every primitive whose box may hold a point within
  // the ball of radius r tangent at x (centre x + r cone.axis) and within
  // the contact cone around x, or a point within `near_radius` of x (a
  // plain ball; 0 for none), the box likeliest to hold a smaller ball
  // first (the order changes the work, not the result); r starts at
  // `radius` and is what visit returns after each call (it may only
  // shrink; a negative r ends the visit). Thread-safe.
  void Visit(const Vec3& x, const ContactCone& cone, double radius,
             absl::FunctionRef<double(int32_t prim)> visit,
             double near_radius = 0) const;

 private:
  BallTree() = default;
  RTCBVHTy* bvh_ = nullptr;
  const void* root_ = nullptr;
  Vec3 origin_;       // the boxes are relative to it.
  double reach_ = 0;  // the largest coordinate relative to origin_.
};

}  // namespace meshgauge
