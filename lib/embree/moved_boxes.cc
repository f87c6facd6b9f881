#include "lib/embree/moved_boxes.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "lib/embree/ray_hit.h"

namespace meshgauge {
namespace {

void BoxBounds(const RTCBoundsFunctionArguments* args) {
  const auto* boxes = static_cast<const Box*>(args->geometryUserPtr);
  const Box& b = boxes[args->primID];
  constexpr float kLow = -std::numeric_limits<float>::max();
  constexpr float kHigh = std::numeric_limits<float>::max();
  // Rounded outwards.
  auto down = [](double x) {
    return std::nextafter(static_cast<float>(x), kLow);
  };
  auto up = [](double x) {
    return std::nextafter(static_cast<float>(x), kHigh);
  };
  RTCBounds* out = args->bounds_o;
  out->lower_x = down(b.lo.x);
  out->lower_y = down(b.lo.y);
  out->lower_z = down(b.lo.z);
  out->upper_x = up(b.hi.x);
  out->upper_y = up(b.hi.y);
  out->upper_z = up(b.hi.z);
}

// Slab test of the (single-precision) ray against the box, in double.
bool RayCrossesBox(const Box& b, const RTCRay& ray) {
  const double o[3] = {ray.org_x, ray.org_y, ray.org_z};
  const double d[3] = {ray.dir_x, ray.dir_y, ray.dir_z};
  const double lo[3] = {b.lo.x, b.lo.y, b.lo.z};
  const double hi[3] = {b.hi.x, b.hi.y, b.hi.z};
  double t0 = 0, t1 = ray.tfar;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

void BoxOccluded(const RTCOccludedFunctionNArguments* args) {
  if (args->valid[0] == 0) return;
  const auto* boxes = static_cast<const Box*>(args->geometryUserPtr);
  auto* ray = reinterpret_cast<RTCRay*>(args->ray);  // N == 1.
  if (RayCrossesBox(boxes[args->primID], *ray)) {
    ray->tfar = -std::numeric_limits<float>::infinity();
  }
}

}  // namespace

absl::StatusOr<std::unique_ptr<MovedBoxes>> MovedBoxes::Create(
    std::vector<Box> boxes) {
  std::unique_ptr<MovedBoxes> m(new MovedBoxes());
  m->boxes_ = std::move(boxes);
  RTCDevice device = SharedDevice();
  if (!device) return absl::InternalError("rtcNewDevice failed");
  m->scene_ = rtcNewScene(device);
  rtcSetSceneFlags(m->scene_, RTC_SCENE_FLAG_ROBUST);
  m->geometry_ = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(m->geometry_, m->boxes_.size());
  rtcSetGeometryUserData(m->geometry_, m->boxes_.data());
  rtcSetGeometryBoundsFunction(m->geometry_, BoxBounds, nullptr);
  rtcSetGeometryOccludedFunction(m->geometry_, BoxOccluded);
  rtcCommitGeometry(m->geometry_);
  rtcAttachGeometry(m->scene_, m->geometry_);
  rtcCommitScene(m->scene_);
  if (rtcGetDeviceError(device) != RTC_ERROR_NONE) {
    return absl::InternalError("Embree failed to build the moved boxes");
  }
  return m;
}

MovedBoxes::~MovedBoxes() {
  if (geometry_) rtcReleaseGeometry(geometry_);
  if (scene_) rtcReleaseScene(scene_);
}

bool MovedBoxes::Crosses(const Vec3& origin, const Vec3& dir,
                         double t_end) const {
  if (boxes_.empty()) return false;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay ray = MakeRayHit(origin, dir, 0.0f,
                          std::nextafter(static_cast<float>(t_end),
                                         std::numeric_limits<float>::max()))
                   .ray;
  rtcOccluded1(scene_, &ctx, &ray);
  return ray.tfar < 0;
}

}  // namespace meshgauge
