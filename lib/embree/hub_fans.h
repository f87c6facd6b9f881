// Fans of long thin triangles around a hub vertex, traced without Embree.
//
// CAD exports cap cones and disks with fans: every triangle of the cap
// shares one hub vertex. A BVH of axis-aligned boxes is at its worst there:
// each thin triangle's box holds the hub's side of the cap, so a ray near it
// visits every box of the fan and a pass over a closed fan-capped cone grows
// with the square of its valence (docs/benchmarks.md, "Valence").
//
// HubFans traces those triangles with a tree of its own instead. Its nodes
// group triangles by their direction from the hub and store the box of their
// corners relative to the hub. The plane through the ray and the hub meets a
// triangle of the fan only where the triangle has corners on both sides of
// it (or at the hub), so a node whose corners all lie on one side is
// skipped whatever its box: a ray visits O(log valence) nodes per crossing
// of the fan instead of O(valence) boxes.
//
// Watertightness (SPEC §4: a ray through a shared edge or vertex hits): the
// ray-triangle test here is a double-precision Plücker test whose value for
// an edge is computed from the edge's ends in ascending vertex order, so the
// two triangles of a shared edge see the same number with opposite signs.
// Embree's single-precision test is consistent only with itself, so no edge
// or vertex may have Embree triangles on one side and HubFans triangles on
// the other: every triangle outside the fan with a corner in it (its
// "neighbours") is traced here as well as by Embree near that corner (the
// candidates of a primitive reported twice are merged: hit_candidates.h).
//
// Which primitives form fans depends on the topology alone; the trees are
// rebuilt from the single-precision coordinates Embree sees on every
// Update, so hits are a function of the current positions (SPEC §3).
#pragma once

#include <cstdint>
#include <vector>

#include "absl/functional/function_ref.h"
#include "lib/core/box.h"
#include "lib/core/mesh.h"
#include "lib/core/topology.h"
#include "lib/core/vec3.h"

namespace meshgauge {

class HubFans {
 public:
  // A hub is a vertex in more than this many primitives. A fan primitive has
  // exactly one hub corner (an edge shared by many triangles, whose two ends
  // are hubs, stays with Embree: its triangles are short and their boxes
  // small). Below it Embree is about as fast: on a fan-capped cylinder of
  // 512 rim vertices its rays take 0.6 times HubFans' time, on a cone 3
  // times (`meshgauge_valence_bench`, docs/benchmarks.md).
  static constexpr size_t kHubValence = 512;

  // The fans of a 3D mesh's triangles (none in 2D or without a hub).
  static HubFans Find(const MeshTopology& topo, size_t num_vertices);
  // At least the bytes Find and Update hold for `mesh` (its triangles in
  // fans, their neighbours, their trees), from its faces alone: for memory
  // budgets before a scene is built. 0 without fans.
  static int64_t EstimateBytes(const Mesh& mesh);

  bool empty() const { return fans_.empty(); }
  int num_fans() const { return static_cast<int>(fans_.size()); }
  // Whether `prim` belongs to a fan (then Embree does not trace it; a
  // neighbour is traced by both).
  bool Owns(int32_t prim) const {
    return !hub_of_.empty() && hub_of_[prim] >= 0;
  }
  // The hub of `prim` when Owns(prim).
  int32_t HubOf(int32_t prim) const;
  int64_t num_owned() const;
  // The bytes held (after Update).
  int64_t bytes() const;

  // Rebuilds every fan's tree from the coordinates Embree sees: vertex v at
  // vertices[4 v], [4 v + 1], [4 v + 2]. `reach` bounds, for every ray, the
  // largest coordinate of its origin plus the distance of any hit (the
  // coordinates' largest magnitude plus the bounding-box diagonal).
  void Update(const float* vertices, double reach);

  // The box of fan `f`'s triangles (owned and neighbours).
  const Box& Bounds(int f) const { return fans_[f].box; }

  // A triangle of the fan met by the ray: `u`, `v` are the barycentric
  // weights of the primitive's corners v[1] and v[2] (Embree's convention).
  struct Hit {
    int32_t prim;
    double t, u, v;
    Vec3 normal;  // (v1 - v0) x (v2 - v0), unnormalised.
  };
  // Work done by Trace, for tests that bound it by count.
  struct Counts {
    int64_t nodes = 0;      // nodes whose tests ran.
    int64_t triangles = 0;  // ray-triangle tests.
  };
  // Calls on_hit for every triangle of fan `f` (owned or neighbour) that
  // the ray origin + t dir meets with t in [t_near, t_far], where t_far is
  // what the last on_hit returned (at first the argument). Coordinates are
  // Embree's (relative to the scene's origin). Thread-safe.
  void Trace(int f, const Vec3& origin, const Vec3& dir, double t_near,
             double t_far, absl::FunctionRef<double(const Hit&)> on_hit,
             Counts* counts = nullptr) const;

 private:
  struct Triangle {
    Vec3 p[3];     // corners in the primitive's order.
    int32_t v[3];  // their vertex numbers.
    int32_t prim;
    // A neighbour's corners in the fan (bit k: v[k]); 0 for the fan's own
    // triangles. A neighbour is reported only for hits within 2^-16 (reach
    // + t) of `region`, the box of those corners, as HitCandidates' window:
    // far more than single-precision rounding there, and the only place
    // where Embree's test could decide otherwise than HubFans' (elsewhere
    // Embree reports it).
    uint8_t shared = 0;
    Box region;
  };
  struct Node {
    Box box;           // of the triangles.
    Box corners;       // of their corners other than the hub, relative to it.
    double reach = 0;  // the largest |corner - hub| among them.
    bool neighbours = false;       // holds neighbours: no plane test.
    int32_t first = 0, count = 0;  // a leaf's triangles; count 0: internal.
    int32_t right = 0;  // an internal node's second child (first: next).
  };
  struct Fan {
    int32_t hub;
    std::vector<int32_t> prims;  // owned, then neighbours.
    int32_t owned = 0;
    Vec3 hub_point;
    Box box;
    std::vector<Triangle> triangles;  // in tree order.
    std::vector<Node> nodes;          // depth first; nodes[0] is the root.
  };
  enum class Split { kByDirection, kByPosition };
  // The node over triangles [first, first + count) of the fan, a leaf.
  Node Cover(const Fan& fan, int32_t first, int32_t count) const;
  // Appends the subtree over those triangles (reordered) to fan.nodes.
  int32_t Build(Fan& fan, int32_t first, int32_t count, Split split);
  bool Hits(const Triangle& tri, const Vec3& o, const Vec3& d, double t_near,
            double t_far, Hit* hit) const;

  std::vector<Fan> fans_;
  std::vector<int32_t> hub_of_;  // per primitive; -1 when not owned.
  double region_pad_ = 0;        // the largest neighbour pad of any ray.
};

}  // namespace meshgauge
