#include "bench/raw_embree_pass.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <limits>

#include "absl/strings/str_cat.h"
#include "lib/core/normals.h"
#include "lib/core/stopwatch.h"
#include "lib/core/thread_count.h"
#include "lib/core/topology.h"
#include "lib/core/vertex_cone.h"
#include "lib/embree/ray_hit.h"

namespace meshgauge::bench {
namespace {

// Embree's packet call for a packet type.
void IntersectPacket(const int* valid, RTCScene s, RTCIntersectContext* c,
                     RTCRayHit4* rh) {
  rtcIntersect4(valid, s, c, rh);
}
void IntersectPacket(const int* valid, RTCScene s, RTCIntersectContext* c,
                     RTCRayHit8* rh) {
  rtcIntersect8(valid, s, c, rh);
}
void IntersectPacket(const int* valid, RTCScene s, RTCIntersectContext* c,
                     RTCRayHit16* rh) {
  rtcIntersect16(valid, s, c, rh);
}

// Traces rays from `x` along `dirs` in packets of N; returns the hits.
template <int N, typename RayHitN>
int64_t TracePackets(RTCScene scene, RTCIntersectContext* ctx, const Vec3& x,
                     const std::vector<Vec3>& dirs, float t_near, float t_far) {
  int64_t hits = 0;
  alignas(64) RayHitN rh;
  alignas(64) int valid[N];
  for (size_t first = 0; first < dirs.size(); first += N) {
    for (int j = 0; j < N; ++j) {
      const size_t k = first + j;
      valid[j] = k < dirs.size() ? -1 : 0;
      SetPacketRay(rh, j, x, dirs[k < dirs.size() ? k : first], t_near, t_far);
    }
    IntersectPacket(valid, scene, ctx, &rh);
    for (int j = 0; j < N; ++j) {
      hits += valid[j] != 0 && rh.hit.geomID[j] != RTC_INVALID_GEOMETRY_ID;
    }
  }
  return hits;
}

// Accepts every hit: Embree keeps the lanes of args->valid as they are.
void AcceptEveryHit(const RTCFilterFunctionNArguments*) {}

int64_t TraceVertex(RawTrace trace, bool noop_filter, RTCScene scene,
                    const Vec3& x, const std::vector<Vec3>& dirs, float t_near,
                    float t_far, std::vector<RTCRayHit>& stream) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  if (noop_filter) ctx.filter = AcceptEveryHit;
  int64_t hits = 0;
  switch (trace) {
    case RawTrace::kSingle:
      for (const Vec3& d : dirs) {
        RTCRayHit rh = MakeRayHit(x, d, t_near, t_far);
        rtcIntersect1(scene, &ctx, &rh);
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
      }
      return hits;
    case RawTrace::kPacket4:
      return TracePackets<4, RTCRayHit4>(scene, &ctx, x, dirs, t_near, t_far);
    case RawTrace::kPacket8:
      return TracePackets<8, RTCRayHit8>(scene, &ctx, x, dirs, t_near, t_far);
    case RawTrace::kPacket16:
      return TracePackets<16, RTCRayHit16>(scene, &ctx, x, dirs, t_near, t_far);
    case RawTrace::kStream:
      stream.resize(dirs.size());
      for (size_t k = 0; k < dirs.size(); ++k) {
        stream[k] = MakeRayHit(x, dirs[k], t_near, t_far);
        // Such a vertex's rays one at a time (the pass: in packets).
        if (StreamMayLoseHits(stream[k].ray)) {
          return TraceVertex(RawTrace::kSingle, noop_filter, scene, x, dirs,
                             t_near, t_far, stream);
        }
      }
      ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
      rtcIntersect1M(scene, &ctx, stream.data(),
                     static_cast<unsigned>(stream.size()), sizeof(RTCRayHit));
      for (const RTCRayHit& rh : stream) {
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
      }
      return hits;
  }
  return hits;
}

}  // namespace

std::string RawConfig::Name() const {
  static const char* const kTrace[] = {"rtcIntersect1", "rtcIntersect4",
                                       "rtcIntersect8", "rtcIntersect16",
                                       "rtcIntersect1M"};
  return absl::StrCat(
      high_quality ? "HIGH" : "MEDIUM", robust ? " ROBUST " : " plain ",
      kTrace[static_cast<int>(trace)], noop_filter ? " no-op filter" : "");
}

std::vector<RawConfig> RawConfigs() {
  std::vector<RawConfig> configs;
  for (bool robust : {true, false}) {
    for (RawTrace t :
         {RawTrace::kSingle, RawTrace::kPacket4, RawTrace::kPacket8,
          RawTrace::kPacket16, RawTrace::kStream}) {
      configs.push_back({.robust = robust, .trace = t});
    }
    for (RawTrace t : {RawTrace::kSingle, RawTrace::kPacket16}) {
      configs.push_back({.robust = robust, .high_quality = true, .trace = t});
    }
  }
  for (RawTrace t : {RawTrace::kSingle, RawTrace::kPacket4, RawTrace::kPacket8,
                     RawTrace::kPacket16, RawTrace::kStream}) {
    configs.push_back({.robust = true, .trace = t, .noop_filter = true});
  }
  return configs;
}

std::optional<size_t> SpecCeiling(absl::Span<const RawConfig> configs,
                                  absl::Span<const double> rate,
                                  absl::Span<const int64_t> hits) {
  if (rate.size() != configs.size() || hits.size() != configs.size()) {
    return std::nullopt;
  }
  int64_t most = 0;
  for (size_t c = 0; c < configs.size(); ++c) {
    if (configs[c].CeilingCandidate()) most = std::max(most, hits[c]);
  }
  std::optional<size_t> best;
  for (size_t c = 0; c < configs.size(); ++c) {
    if (!configs[c].CeilingCandidate() || hits[c] < most) continue;
    if (!best || rate[c] > rate[*best]) best = c;
  }
  return best;
}

RTCScene NewRawScene(RTCDevice device, const Mesh& mesh,
                     const MeshTopology& topo, const RawConfig& config) {
  RTCScene scene = rtcNewScene(device);
  int flags = config.robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE;
  if (config.noop_filter) flags |= RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION;
  rtcSetSceneFlags(scene, static_cast<RTCSceneFlags>(flags));
  rtcSetSceneBuildQuality(scene, config.high_quality
                                     ? RTC_BUILD_QUALITY_HIGH
                                     : RTC_BUILD_QUALITY_MEDIUM);
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
  return scene;
}

absl::StatusOr<RawRays> RawRays::Create(const Mesh& mesh,
                                        const MeshTopology& topo,
                                        const SdfParams& params) {
  if (mesh.dimension != 3) {
    return absl::InvalidArgumentError("the raw pass is for 3D meshes");
  }
  RawRays rays(mesh, topo);
  const ResolvedParams resolved = ResolveParams(params, 3);
  auto cone = MakeCone(3, resolved.aperture_radians, resolved.rays,
                       resolved.min_weight_angle);
  if (!cone.ok()) return cone.status();
  rays.cone_ = *std::move(cone);
  if (params.method == SdfMethod::kNormalRay) {
    rays.cone_ = {{Vec3(0, 0, 1), 0.0, 1.0}};
  }
  rays.normals_ = UnnormalizedNormals(mesh, topo, NormalWeighting::kArea);
  rays.t_near_ =
      static_cast<float>(params.self_hit_epsilon * MeanEdgeLength(mesh));
  rays.t_far_ = static_cast<float>(BoundingBoxDiagonal(mesh));
  return rays;
}

bool RawRays::Directions(int64_t p, std::vector<Vec3>& dirs) const {
  if (topo_.vertex_faces.Of(p).empty()) return false;
  const VertexCone vc = MakeVertexCone(mesh_, topo_, p, normals_[p]);
  if (!vc.valid) return false;
  dirs.resize(cone_.size());
  RayDirections(vc.frame, cone_, absl::MakeSpan(dirs));
  return true;
}

absl::StatusOr<RawPassResult> RunRawPass(const Mesh& mesh,
                                         const SdfParams& params, int threads,
                                         const RawConfig& config) {
  const MeshTopology topo = MeshTopology::Build(mesh);
  auto raw_rays = RawRays::Create(mesh, topo, params);
  if (!raw_rays.ok()) return raw_rays.status();

  RTCDevice device = rtcNewDevice(nullptr);
  RTCScene scene = NewRawScene(device, mesh, topo, config);
  tbb::task_arena arena(ThreadCount(threads));
  RawPassResult result;
  const Stopwatch build;
  arena.execute([&] { rtcCommitScene(scene); });
  result.build_seconds = build.Seconds();

  std::atomic<int64_t> rays{0}, hits{0};
  const Stopwatch pass;
  arena.execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<int64_t>(0, mesh.num_vertices(), 64),
        [&](const tbb::blocked_range<int64_t>& r) {
          int64_t local_rays = 0, local_hits = 0;
          std::vector<Vec3> dirs;
          std::vector<RTCRayHit> stream;
          for (int64_t p = r.begin(); p < r.end(); ++p) {
            if (!raw_rays->Directions(p, dirs)) continue;
            local_hits += TraceVertex(
                config.trace, config.noop_filter, scene, mesh.positions[p],
                dirs, raw_rays->t_near(), raw_rays->t_far(), stream);
            local_rays += std::ssize(dirs);
          }
          rays += local_rays;
          hits += local_hits;
        },
        tbb::simple_partitioner());
  });
  result.seconds = pass.Seconds();
  result.rays = rays;
  result.hits = hits;
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
  return result;
}

}  // namespace meshgauge::bench
