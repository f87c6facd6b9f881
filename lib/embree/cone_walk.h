// A traversal built for cones (issue 52): one descent of a BVH per fan for
// all of its rays, which share their origin and lie in a narrow cone, with
// every candidate triangle tested against the groups of rays that can meet
// it, eight at a time. RayScene::IntersectFan uses it for
// FanTraversal::kCone and falls back to Embree where it gives up.
//
// What it finds is what FanFilter finds through Embree: for each ray, every
// primitive within HitCandidates' window of its closest hit, so the pick in
// double precision (PickClosest) sees the same primitive. Its
// single-precision test is a sheared watertight test (Woop et al.) in the
// frame of the fan's axis: each corner is sheared along the ray and the
// edge functions are 2D cross products of two corners, which the two
// triangles of a shared edge compute as exact negations, so a ray through
// an edge or a corner meets at least one of them. Embree's robust test
// (Plücker coordinates with a tolerance) rounds differently: near an edge
// the two may report different primitives (docs/numerics.md "The cone
// walk").
#pragma once

#include <cstdint>
#include <vector>

#include "absl/types/span.h"
#include "lib/core/topology.h"
#include "lib/core/vec3.h"
#include "lib/embree/hit_candidates.h"

namespace meshgauge {

struct FanContext;  // fan_filter.h

class ConeWalk {
 public:
  // Scenes of more primitives get no walk (its BVH would hold tens of
  // megabytes); passes left to choose walk cones on far smaller ones
  // (EvaluatorOptions::fan_traversal).
  static constexpr int64_t kMaxPrimitives = int64_t{1} << 18;
  // Fans of more rays go to Embree.
  static constexpr int kMaxRays = 512;

  // Whether this CPU runs the walk (AVX2 and FMA); without, every fan
  // gives up.
  static bool Supported();
  // Whether Intersect takes every fan of at most `rays` rays within
  // `half_angle` radians of their axis on a scene of `primitives`
  // primitives in `dimension` (a walk is built for it and it gives up on
  // none of them).
  static bool TakesEveryFan(int64_t primitives, int dimension, int rays,
                            double half_angle);

  // Builds the BVH over the triangles `primitives` (3D; every v[2] >= 0)
  // at `vertices`, 4 floats (x, y, z, unused) per mesh vertex in the
  // tracer's coordinates (RayScene's vertex buffer). Hub fans' triangles
  // (hub_fans.h) are ordinary triangles here. O(n log n).
  void Build(const float* vertices, absl::Span<const Primitive> primitives);
  bool empty() const { return nodes_.empty(); }

  // As RayScene::IntersectFan with `fan` set up as for FanFilter (excluded,
  // t_min, near_below, t_far): out[k] receives ray k's candidates, found
  // from `origin` (tracer coordinates) along dirs[k] over (start(k), t_far]
  // with start(k) = starts[k], or t_near when `starts` is empty. Every ray
  // is tested in the frame of `axis` (unit; null: the rays' mean
  // direction), so that its candidates depend on the ray, the origin and
  // the axis alone, not on which other rays share the fan (an incremental
  // pass retraces some of a sample's rays: give the sample's cone axis).
  // Returns false, leaving `out` to be reset, when it gives up: no walk, a
  // CPU without AVX2 and FMA (or not x86-64), no ray or more than kMaxRays
  // rays, or a ray more than 80 degrees from the axis (a half-angle). It
  // never gives up for the number of triangles it meets, so that whether a
  // sample walks does not depend on which of its rays a pass traces.
  // `group_tests` (unless null) is increased by the number of (triangle,
  // group of 8 rays) tests the walk made: its work, which grows with the
  // triangles a cone meets (a pass's pilot, traversal_choice.cc).
  // Thread-safe.
  bool Intersect(const Vec3& origin, absl::Span<const Vec3> dirs,
                 const Vec3* axis, absl::Span<const float> starts, float t_near,
                 const FanContext& fan, absl::Span<HitCandidates> out,
                 int64_t* group_tests = nullptr) const;

  // The walk's BVH (cone_walk.cc): nodes of up to kWidth children, each a
  // node or a leaf of triangles, with their bounding spheres (structure of
  // arrays, tested together).
  static constexpr int kWidth = 8;
  struct Node {
    alignas(32) float x[kWidth], y[kWidth], z[kWidth], radius[kWidth];
    int32_t child[kWidth];  // >= 0: a node; -1: triangles [first, + count).
    int32_t first[kWidth], count[kWidth];
    int32_t children = 0;
  };
  struct Triangle {
    float a[3], b[3], c[3];
    int32_t prim;
  };

 private:
  std::vector<Node> nodes_;
  std::vector<Triangle> triangles_;  // in leaf order.
  float slack_ = 0;                  // added to every node's radius (Build).
};

}  // namespace meshgauge
