#include "lib/ray_scene.h"

#include <algorithm>
#include <limits>

#include "absl/strings/str_cat.h"

namespace meshgauge {
namespace {

// RTCIntersectContext extended with what the filter needs; Embree passes the
// context pointer through to the filter unchanged.
struct FilterContext {
  RTCIntersectContext base;
  const int32_t* prim_face;
  absl::Span<const int32_t> excluded_faces;
  float t_min;
};

void OneRingFilter(const RTCFilterFunctionNArguments* args) {
  // Called with N == 1 for rtcIntersect1.
  const auto* ctx = reinterpret_cast<const FilterContext*>(args->context);
  const float t = RTCRayN_tfar(args->ray, args->N, 0);
  const unsigned prim = RTCHitN_primID(args->hit, args->N, 0);
  if (t < ctx->t_min ||
      std::binary_search(ctx->excluded_faces.begin(),
                         ctx->excluded_faces.end(), ctx->prim_face[prim])) {
    args->valid[0] = 0;
  }
}

absl::Status DeviceStatus(RTCDevice device, const char* what) {
  const RTCError err = rtcGetDeviceError(device);
  if (err == RTC_ERROR_NONE) return absl::OkStatus();
  return absl::InternalError(
      absl::StrCat("Embree error ", static_cast<int>(err), " in ", what));
}

}  // namespace

absl::StatusOr<std::unique_ptr<RayScene>> RayScene::Create(
    const Mesh& mesh, const MeshTopology& topo, BvhUpdatePolicy policy) {
  std::unique_ptr<RayScene> scene(new RayScene(topo, policy));
  if (absl::Status s = scene->Init(mesh); !s.ok()) return s;
  return scene;
}

RayScene::~RayScene() {
  if (geometry_) rtcReleaseGeometry(geometry_);
  if (scene_) rtcReleaseScene(scene_);
  if (device_) rtcReleaseDevice(device_);
}

absl::Status RayScene::Init(const Mesh& mesh) {
  dimension_ = mesh.dimension;
  device_ = rtcNewDevice(nullptr);
  if (!device_) return absl::InternalError("rtcNewDevice failed");
  scene_ = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene_, policy_ == BvhUpdatePolicy::kRefit
                                      ? RTC_BUILD_QUALITY_LOW
                                      : RTC_BUILD_QUALITY_MEDIUM);
  const size_t nv = mesh.positions.size();
  const size_t np = topo_.primitives.size();
  prim_face_.resize(np);
  for (size_t i = 0; i < np; ++i) prim_face_[i] = topo_.primitives[i].face;
  if (dimension_ == 3) {
    geometry_ = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* idx = static_cast<uint32_t*>(
        rtcSetNewGeometryBuffer(geometry_, RTC_BUFFER_TYPE_INDEX, 0,
                                RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), np));
    if (!idx) return DeviceStatus(device_, "index buffer");
    for (size_t i = 0; i < np; ++i) {
      for (int k = 0; k < 3; ++k) idx[3 * i + k] = topo_.primitives[i].v[k];
    }
  } else {
    // Vertex i at z = -H is 2i, at z = +H is 2i + 1.
    extrude_half_height_ = static_cast<float>(BoundingBoxDiagonal(mesh) + 1);
    geometry_ = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_QUAD);
    auto* idx = static_cast<uint32_t*>(
        rtcSetNewGeometryBuffer(geometry_, RTC_BUFFER_TYPE_INDEX, 0,
                                RTC_FORMAT_UINT4, 4 * sizeof(uint32_t), np));
    if (!idx) return DeviceStatus(device_, "index buffer");
    for (size_t i = 0; i < np; ++i) {
      const uint32_t a = topo_.primitives[i].v[0];
      const uint32_t b = topo_.primitives[i].v[1];
      idx[4 * i + 0] = 2 * a;
      idx[4 * i + 1] = 2 * b;
      idx[4 * i + 2] = 2 * b + 1;
      idx[4 * i + 3] = 2 * a + 1;
    }
  }
  // Embree reads vertex buffers with 16-byte loads: pad one float.
  const size_t num_embree_vertices = dimension_ == 3 ? nv : 2 * nv;
  vertex_buffer_ = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry_, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
      4 * sizeof(float), num_embree_vertices));
  if (!vertex_buffer_) return DeviceStatus(device_, "vertex buffer");
  FillVertices(mesh);
  rtcSetGeometryIntersectFilterFunction(geometry_, OneRingFilter);
  if (policy_ == BvhUpdatePolicy::kRefit) {
    rtcSetGeometryBuildQuality(geometry_, RTC_BUILD_QUALITY_REFIT);
  }
  rtcCommitGeometry(geometry_);
  rtcAttachGeometry(scene_, geometry_);
  return Commit();
}

void RayScene::FillVertices(const Mesh& mesh) {
  const size_t nv = mesh.positions.size();
  for (size_t i = 0; i < nv; ++i) {
    const Vec3& p = mesh.positions[i];
    if (dimension_ == 3) {
      float* dst = vertex_buffer_ + 4 * i;
      dst[0] = static_cast<float>(p.x);
      dst[1] = static_cast<float>(p.y);
      dst[2] = static_cast<float>(p.z);
      dst[3] = 0;
    } else {
      for (int level = 0; level < 2; ++level) {
        float* dst = vertex_buffer_ + 4 * (2 * i + level);
        dst[0] = static_cast<float>(p.x);
        dst[1] = static_cast<float>(p.y);
        dst[2] = level == 0 ? -extrude_half_height_ : extrude_half_height_;
        dst[3] = 0;
      }
    }
  }
}

absl::Status RayScene::Commit() {
  rtcCommitScene(scene_);
  ++builds_;
  return DeviceStatus(device_, "rtcCommitScene");
}

absl::Status RayScene::UpdatePositions(const Mesh& mesh) {
  FillVertices(mesh);
  rtcUpdateGeometryBuffer(geometry_, RTC_BUFFER_TYPE_VERTEX, 0);
  rtcCommitGeometry(geometry_);
  rtcCommitScene(scene_);
  if (policy_ == BvhUpdatePolicy::kRefit) {
    ++refits_;
  } else {
    ++builds_;
  }
  return DeviceStatus(device_, "rtcCommitScene (update)");
}

int32_t RayScene::Trace(const Vec3& origin, const Vec3& dir, float t_min,
                        float t_max,
                        absl::Span<const int32_t> excluded_faces) const {
  FilterContext ctx;
  rtcInitIntersectContext(&ctx.base);
  ctx.prim_face = prim_face_.data();
  ctx.excluded_faces = excluded_faces;
  ctx.t_min = t_min;
  RTCRayHit rh;
  rh.ray.org_x = static_cast<float>(origin.x);
  rh.ray.org_y = static_cast<float>(origin.y);
  rh.ray.org_z = static_cast<float>(origin.z);
  rh.ray.dir_x = static_cast<float>(dir.x);
  rh.ray.dir_y = static_cast<float>(dir.y);
  rh.ray.dir_z = static_cast<float>(dir.z);
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = t_max;
  rh.ray.time = 0.0f;
  rh.ray.mask = std::numeric_limits<unsigned>::max();
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &ctx.base, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return -1;
  return static_cast<int32_t>(rh.hit.primID);
}

}  // namespace meshgauge
