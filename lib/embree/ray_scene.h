// Embree 3 scene over a mesh's primitives (SPEC §4).
//
// 3D: one triangle geometry (quads split). 2D: each segment is a quad
// extruded along z over [-H, H] (H = bounding-box diagonal + 1) and rays stay
// in the plane z = 0, so Embree finds segment hits. Embree works in single
// precision and only *chooses* the primitive; callers recompute t in double.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/mesh.h"
#include "lib/core/topology.h"
#include "lib/embree/cone_walk.h"
#include "lib/embree/hit_candidates.h"
#include "lib/embree/hub_fans.h"

// Embree's opaque handles (embree3/rtcore.h typedefs RTCScene etc. as
// pointers to these), so that this header does not pull Embree in.
struct RTCDeviceTy;
struct RTCSceneTy;
struct RTCGeometryTy;

namespace meshgauge {

enum class BvhUpdatePolicy {
  // Each UpdatePositions rebuilds the BVH (scene quality MEDIUM).
  kRebuild,
  // The geometry is built once (SAH) and UpdatePositions only refits its
  // bounds (scene quality LOW + geometry quality REFIT, a two-level BVH).
  kRefit,
};

// The origin of the coordinates Embree sees: the centroid of the vertices
// that faces use (an unused vertex far away would otherwise leave the faces
// without single-precision resolution), rounded to a multiple of the power
// of two at or above the bounding-box diagonal.
// Coordinates relative to it keep their precision whatever the part's
// offset (CAD coordinates), it depends on the current positions alone (a
// refitted scene and one built at the same positions see the same
// single-precision coordinates, so hits do not depend on the history), and
// it changes only when the mesh moves by about its size.
Vec3 SceneOrigin(const Mesh& mesh);

// OK when the ray tracer can take the mesh's positions: the check RayScene
// makes on Create and UpdatePositions (its errors), without a scene, so that
// a store can refuse positions before it commits them.
absl::Status CheckTraceable(const Mesh& mesh);

// How RayScene::IntersectFan traces a fan's rays. All found the same
// candidates under the watertight test on every fan tried (RaySceneTest,
// RayTraversalTest, ConeWalkTest); only the time differs.
enum class FanTraversal {
  // Packets of 16 consecutive rays (rtcIntersect16; single rays where
  // Embree has no 16-wide packets): each ray walks the BVH on its own.
  kPackets,
  // All of the fan's rays as one coherent stream (rtcIntersect1M with
  // RTC_INTERSECT_CONTEXT_FLAG_COHERENT): Embree walks
  // the BVH once per group of rays with a frustum test, which pays where a
  // few large primitives fill the cone (coarse meshes, CAD parts) and
  // costs where the cone spreads over many small ones.
  kStream,
  // meshgauge's own walk (cone_walk.h): one descent per fan for all its
  // rays, each candidate triangle tested against the rays that can meet it.
  // On 3D scenes of at most ConeWalk::kMaxPrimitives primitives; a fan it
  // gives up on (a ray over 80 degrees from the axis, over 512 rays, a CPU
  // without AVX2) goes to Embree as kStream would.
  kCone,
};

// The ray-primitive test Embree runs.
enum class RayTest {
  // Embree's ROBUST mode, a watertight test: a ray through an edge or
  // vertex shared by primitives does not slip between them (measured:
  // RaySceneTest, docs/benchmarks.md), as SPEC §4's closest hit needs. The
  // default everywhere.
  kWatertight,
  // Embree's faster default test, for measuring what the watertight one
  // costs (meshgauge_bench): a ray through a shared edge can slip between
  // its primitives and meet a farther surface or none (docs/benchmarks.md
  // counts how often on the shared meshes).
  kFast,
};

// Who traces the triangles of hub fans (hub_fans.h).
enum class FanTracing {
  // HubFans' own tree (the default everywhere): linear in a hub's valence.
  kHubFans,
  // Embree, like every other primitive: for tests and measurements.
  kEmbree,
};

class RayScene {
 public:
  // Builds the BVH. `topo` must outlive the scene. Errors: InvalidArgument
  // for a mesh too large for Embree's single precision (bounding-box
  // diagonal x (longest edge)^2 over 1e38, a diagonal over 1e17, or a
  // face's vertex over 1e17 from SceneOrigin(mesh));
  // Internal on Embree failure (message from rtcGetDeviceError).
  static absl::StatusOr<std::unique_ptr<RayScene>> Create(
      const Mesh& mesh, const MeshTopology& topo, BvhUpdatePolicy policy,
      RayTest test = RayTest::kWatertight,
      FanTracing fan_tracing = FanTracing::kHubFans);
  ~RayScene();
  RayScene(const RayScene&) = delete;
  RayScene& operator=(const RayScene&) = delete;

  // Copies mesh.positions (same vertex count) into the Embree buffers and
  // refits or rebuilds per the policy. Not while a fan is traced. The
  // coordinates Embree sees are a function of the current positions alone
  // (SceneOrigin), as after Create. Errors: InvalidArgument as Create's (the
  // scene is unchanged).
  absl::Status UpdatePositions(const Mesh& mesh);

  // The origin of the coordinates Embree sees (SceneOrigin) and, in 2D, the
  // extrusion's half height: what a hit depends on besides the geometry.
  const Vec3& origin() const { return origin_; }
  // The hub fans traced without Embree's BVH (empty with FanTracing::kEmbree).
  const HubFans& hub_fans() const { return fans_; }
  float extrude_half_height() const { return extrude_half_height_; }

  // Closest hit of origin + t * dir with t in [t_near, t_far] as Embree
  // reports it (single precision, plain rtcIntersect1; among primitives at
  // the same distance the one it visits first, so this depends on the BVH:
  // for pictures, not for values). `prim` indexes MeshTopology::primitives;
  // -1 for a miss. Thread-safe.
  struct Hit {
    int32_t prim = -1;
    float t = 0;
  };
  Hit Intersect(const Vec3& origin, const Vec3& dir, float t_near,
                float t_far) const;
  // The distances of a fan's rays (single precision): Embree reports
  // primitives within [t_near, t_far]; those closer than t_min (>= t_near)
  // are ignored; a primitive closer than NearBelow marks the ray's
  // candidates near() (SPEC §4's self-hit threshold: t_near a power of two
  // at or below t_min, near_below = 2 t_near, so that a threshold moving
  // within [t_near, near_below) changes only the rays marked).
  struct FanLimits {
    float t_near = 0, t_min = 0, near_below = 0, t_far = 0;
  };
  // Where candidates are marked near() for a fan from an origin `reach`
  // from the scene's origin (MaxAbs, tracer coordinates): below
  // limits.near_below, and below t_min + (reach + t_min) * 2^-16, within
  // which a candidate's double-precision distance may be below t_min
  // although its single-precision one is not (HitCandidates' window, far
  // wider than single-precision rounding; SdfEvaluator measures those).
  static float NearBelow(const FanLimits& limits, float reach) {
    return std::max(limits.near_below,
                    limits.t_min + (reach + limits.t_min) * 0x1p-16f);
  }
  // For every k, out[k] receives the candidates for the closest hit of
  // origin + t * dirs[k] within `limits`, ignoring the primitives in
  // `excluded` (ascending; SPEC §4's one-ring: OneRingPrimitives):
  // every primitive within HitCandidates' window of the closest, found
  // whatever the BVH's history (see hit_candidates.h). Traced as
  // `traversal` says (a cone's rays share their origin and are coherent):
  // a fan the cone walk gives up on (ConeWalk::Intersect) is streamed, and
  // a fan streamed goes in packets where Embree has no streams or a ray has
  // a direction component its streams mishandle (StreamMayLoseHits);
  // returns the way it traced. `axis` (unit, or null) is the walk's frame
  // (ConeWalk::Intersect): give the sample's cone axis, so that a ray's
  // candidates do not depend on the fan it came in. dirs.size() == out.size().
  // `starts`, when not empty (one per ray, each at or above limits.t_near),
  // replaces limits.t_near as ray k's start (ray_start.h: only past a stretch
  // proven empty). Thread-safe.
  FanTraversal IntersectFan(const Vec3& origin, absl::Span<const Vec3> dirs,
                            const FanLimits& limits,
                            absl::Span<const int32_t> excluded,
                            absl::Span<HitCandidates> out,
                            absl::Span<const float> starts = {},
                            FanTraversal traversal = FanTraversal::kPackets,
                            const Vec3* axis = nullptr) const;
  // The work of the cone walk on a fan (IntersectFan's arguments, from the
  // surface): its (triangle, group of 8 rays) tests (ConeWalk::Intersect),
  // or -1 where it would give up. `out`: the caller's scratch, at least
  // dirs.size() entries (the first receive the rays' hits). Builds the
  // walk if it is not built since the last position update. Thread-safe.
  int64_t ConeWalkTests(const Vec3& origin, absl::Span<const Vec3> dirs,
                        const FanLimits& limits,
                        absl::Span<const int32_t> excluded, const Vec3& axis,
                        absl::Span<HitCandidates> out) const;

 private:
  RayScene(const MeshTopology& topo, BvhUpdatePolicy policy, RayTest test)
      : topo_(topo), policy_(policy), test_(test) {}
  absl::Status AddHubFans();
  absl::Status Init(const Mesh& mesh);
  // Sets origin_ and extrude_half_height_ for `mesh` and copies its
  // positions into the vertex buffer.
  absl::Status FillVertices(const Mesh& mesh);
  absl::Status Commit();
  // The start of a fan's trace (IntersectFan, ConeWalkTests): its
  // candidates `out` emptied and its context for FanFilter and the cone
  // walk (limits, the origin's reach, the primitives it ignores) in *fan;
  // returns the origin in the scene's coordinates.
  Vec3 StartFan(const Vec3& origin, const FanLimits& limits,
                absl::Span<const int32_t> excluded,
                absl::Span<HitCandidates> out, FanContext* fan) const;
  // The cone walk over the coordinates Embree sees, built on a fan's first
  // use after each FillVertices (a pass that does not walk cones does not
  // pay for it). Built anew, not refitted: its tree then depends on the
  // positions alone, and so does a pass's pilot, which counts the walk's
  // work (traversal_choice.cc). Empty in 2D and on scenes of over
  // ConeWalk::kMaxPrimitives.
  const ConeWalk& cone_walk() const;

  const MeshTopology& topo_;
  BvhUpdatePolicy policy_;
  RayTest test_;
  int dimension_ = 3;
  float extrude_half_height_ = 1;
  Vec3 origin_;  // subtracted (in double) from every coordinate Embree sees.
  RTCDeviceTy* device_ = nullptr;  // the process-wide SharedDevice().
  RTCSceneTy* scene_ = nullptr;
  RTCGeometryTy* geometry_ = nullptr;
  float* vertex_buffer_ = nullptr;  // owned by geometry_.
  // Hub fans' triangles are points (v, v, v) in geometry_ and are traced by
  // fan_geometry_ (null without fans).
  HubFans fans_;
  RTCGeometryTy* fan_geometry_ = nullptr;
  // Over the coordinates Embree sees (cone_walk()).
  mutable ConeWalk cone_walk_;
  mutable std::unique_ptr<std::once_flag> cone_walk_built_;
};

}  // namespace meshgauge
