// Embree 3 scene over a mesh's primitives (SPEC §4).
//
// 3D: one triangle geometry (quads split). 2D: each segment is a quad
// extruded along z over [-H, H] (H = bounding-box diagonal + 1) and rays stay
// in the plane z = 0, so Embree finds segment hits. Embree works in single
// precision and only *chooses* the primitive; callers recompute t in double.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/mesh.h"
#include "lib/core/topology.h"

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

class RayScene {
 public:
  // Builds the BVH. `topo` must outlive the scene. Errors: InvalidArgument
  // for a mesh too large for Embree's single precision (bounding-box
  // diagonal x (longest edge)^2 over 1e38, a diagonal over 1e17, or a
  // face's vertex over 1e17 from the centroid of all vertices);
  // Internal on Embree failure (message from rtcGetDeviceError).
  static absl::StatusOr<std::unique_ptr<RayScene>> Create(
      const Mesh& mesh, const MeshTopology& topo, BvhUpdatePolicy policy);
  ~RayScene();
  RayScene(const RayScene&) = delete;
  RayScene& operator=(const RayScene&) = delete;

  // Copies mesh.positions (same vertex count) into the Embree buffers and
  // refits or rebuilds per the policy. Errors: InvalidArgument as Create's
  // (the scene is unchanged).
  absl::Status UpdatePositions(const Mesh& mesh);

  // Closest hit of origin + t * dir with t in [t_near, t_far] (single
  // precision, plain rtcIntersect1, in coordinates relative to the mesh's
  // centroid at creation). `prim` indexes
  // MeshTopology::primitives; -1 for a miss. Thread-safe. The one-ring
  // exclusion of SPEC §4 is the caller's (TraceExcluding in sdf_pass.h), so
  // that its face lookup can use prefetched memory.
  struct Hit {
    int32_t prim = -1;
    float t = 0;
  };
  Hit Intersect(const Vec3& origin, const Vec3& dir, float t_near,
                float t_far) const;
  // out[k] = Intersect(origin, dirs[k], t_near, t_far) for every k, traced
  // in packets of 16 rays (a cone's rays share their origin and are
  // coherent). dirs.size() == out.size().
  void IntersectFan(const Vec3& origin, absl::Span<const Vec3> dirs,
                    float t_near, float t_far, absl::Span<Hit> out) const;

 private:
  RayScene(const MeshTopology& topo, BvhUpdatePolicy policy)
      : topo_(topo), policy_(policy) {}
  absl::Status Init(const Mesh& mesh);
  void FillVertices(const Mesh& mesh);
  absl::Status Commit();

  const MeshTopology& topo_;
  BvhUpdatePolicy policy_;
  int dimension_ = 3;
  float extrude_half_height_ = 1;
  Vec3 origin_;  // subtracted (in double) from every coordinate Embree sees.
  RTCDeviceTy* device_ = nullptr;  // the process-wide SharedDevice().
  RTCSceneTy* scene_ = nullptr;
  RTCGeometryTy* geometry_ = nullptr;
  float* vertex_buffer_ = nullptr;  // owned by geometry_.
};

}  // namespace meshgauge
