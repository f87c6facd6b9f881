#include "bench/raw_embree_pass.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <limits>

#include "lib/core/normals.h"
#include "lib/core/topology.h"
#include "lib/core/vertex_cone.h"
#include "lib/embree/ray_hit.h"

namespace meshgauge::bench {

absl::StatusOr<RawPassResult> RunRawPass(const Mesh& mesh,
                                         const SdfParams& params) {
  if (mesh.dimension != 3) {
    return absl::InvalidArgumentError("the raw pass is for 3D meshes");
  }
  const MeshTopology topo = MeshTopology::Build(mesh);
  const ResolvedParams resolved = ResolveParams(params, 3);
  auto cone = MakeCone(3, resolved.aperture_radians, resolved.rays,
                       resolved.min_weight_angle);
  if (!cone.ok()) return cone.status();
  if (params.method == SdfMethod::kNormalRay) {
    *cone = {{Vec3(0, 0, 1), 0.0, 1.0}};
  }
  const std::vector<Vec3> normals =
      UnnormalizedNormals(mesh, topo, NormalWeighting::kArea);

  RTCDevice device = rtcNewDevice(nullptr);
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);  // as meshgauge's scene.
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 4 * sizeof(float),
      mesh.positions.size()));
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    vb[4 * i] = static_cast<float>(mesh.positions[i].x);
    vb[4 * i + 1] = static_cast<float>(mesh.positions[i].y);
    vb[4 * i + 2] = static_cast<float>(mesh.positions[i].z);
    vb[4 * i + 3] = 0;
  }
  auto* ib = static_cast<uint32_t*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                              3 * sizeof(uint32_t), topo.primitives.size()));
  for (size_t i = 0; i < topo.primitives.size(); ++i) {
    for (int k = 0; k < 3; ++k) ib[3 * i + k] = topo.primitives[i].v[k];
  }
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);

  const float t_near =
      static_cast<float>(params.self_hit_epsilon * MeanEdgeLength(mesh));
  const float t_far = static_cast<float>(BoundingBoxDiagonal(mesh));
  std::atomic<int64_t> rays{0}, hits{0};
  const int threads =
      params.threads > 0 ? params.threads : tbb::info::default_concurrency();
  tbb::task_arena arena(threads);
  const auto start = std::chrono::steady_clock::now();
  arena.execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<int64_t>(0, mesh.num_vertices(), 64),
        [&](const tbb::blocked_range<int64_t>& r) {
          int64_t local_rays = 0, local_hits = 0;
          RTCIntersectContext ctx;
          rtcInitIntersectContext(&ctx);
          for (int64_t p = r.begin(); p < r.end(); ++p) {
            if (topo.vertex_faces.Of(p).empty()) continue;
            const VertexCone vc = MakeVertexCone(mesh, topo, p, normals[p]);
            if (!vc.valid) continue;
            const Vec3& x = mesh.positions[p];
            for (const ConeRay& ray : *cone) {
              const Vec3 d = RayDirection(vc.frame, ray);
              RTCRayHit rh = MakeRayHit(x, d, t_near, t_far);
              rtcIntersect1(scene, &ctx, &rh);
              ++local_rays;
              local_hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
            }
          }
          rays += local_rays;
          hits += local_hits;
        },
        tbb::simple_partitioner());
  });
  RawPassResult result;
  result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  result.rays = rays;
  result.hits = hits;
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
  return result;
}

}  // namespace meshgauge::bench
