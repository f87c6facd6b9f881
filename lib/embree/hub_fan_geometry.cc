#include "lib/embree/hub_fan_geometry.h"

#include <cmath>
#include <limits>

namespace meshgauge {
namespace {

void FanBounds(const RTCBoundsFunctionArguments* args) {
  const auto& fans = *static_cast<const HubFans*>(args->geometryUserPtr);
  const Box& box = fans.Bounds(static_cast<int>(args->primID));
  // Rounded outward, so that the single-precision box holds the fan.
  constexpr float kInf = std::numeric_limits<float>::infinity();
  RTCBounds& b = *args->bounds_o;
  b.lower_x = std::nextafter(static_cast<float>(box.lo.x), -kInf);
  b.lower_y = std::nextafter(static_cast<float>(box.lo.y), -kInf);
  b.lower_z = std::nextafter(static_cast<float>(box.lo.z), -kInf);
  b.upper_x = std::nextafter(static_cast<float>(box.hi.x), kInf);
  b.upper_y = std::nextafter(static_cast<float>(box.hi.y), kInf);
  b.upper_z = std::nextafter(static_cast<float>(box.hi.z), kInf);
}

Vec3 Origin(RTCRayN* ray, unsigned n, unsigned i) {
  return Vec3(RTCRayN_org_x(ray, n, i), RTCRayN_org_y(ray, n, i),
              RTCRayN_org_z(ray, n, i));
}
Vec3 Direction(RTCRayN* ray, unsigned n, unsigned i) {
  return Vec3(RTCRayN_dir_x(ray, n, i), RTCRayN_dir_y(ray, n, i),
              RTCRayN_dir_z(ray, n, i));
}

// Writes lane i of a hit.
void SetHit(RTCHitN* hit, unsigned n, unsigned i, const HubFans::Hit& h,
            unsigned geom_id) {
  RTCHitN_Ng_x(hit, n, i) = static_cast<float>(h.normal.x);
  RTCHitN_Ng_y(hit, n, i) = static_cast<float>(h.normal.y);
  RTCHitN_Ng_z(hit, n, i) = static_cast<float>(h.normal.z);
  RTCHitN_u(hit, n, i) = static_cast<float>(h.u);
  RTCHitN_v(hit, n, i) = static_cast<float>(h.v);
  RTCHitN_primID(hit, n, i) = static_cast<unsigned>(h.prim);
  RTCHitN_geomID(hit, n, i) = geom_id;
  RTCHitN_instID(hit, n, i, 0) = RTC_INVALID_GEOMETRY_ID;
}

void FanIntersect(const RTCIntersectFunctionNArguments* args) {
  const auto& fans = *static_cast<const HubFans*>(args->geometryUserPtr);
  const unsigned n = args->N;
  RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, n);
  RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, n);
  for (unsigned i = 0; i < n; ++i) {
    if (args->valid[i] != -1) continue;
    float& tfar = RTCRayN_tfar(ray, n, i);
    auto on_hit = [&](const HubFans::Hit& h) -> double {
      // As for Embree's own triangles: the filter sees tfar at the hit and
      // may reject it (tfar restored) or accept it with another tfar.
      const float before = tfar;
      tfar = static_cast<float>(h.t);
      alignas(64) RTCHit16 potential;
      auto* potential_n = reinterpret_cast<RTCHitN*>(&potential);
      SetHit(potential_n, n, i, h, args->geomID);
      int valid[16] = {};
      valid[i] = -1;
      RTCFilterFunctionNArguments filter{
          valid, args->geometryUserPtr, args->context, ray, potential_n, n};
      rtcFilterIntersection(args, &filter);
      if (valid[i] == -1) {
        SetHit(hit, n, i, h, args->geomID);
      } else {
        tfar = before;
      }
      return tfar;
    };
    fans.Trace(static_cast<int>(args->primID), Origin(ray, n, i),
               Direction(ray, n, i), RTCRayN_tnear(ray, n, i), tfar, on_hit);
  }
}

void FanOccluded(const RTCOccludedFunctionNArguments* args) {
  const auto& fans = *static_cast<const HubFans*>(args->geometryUserPtr);
  const unsigned n = args->N;
  for (unsigned i = 0; i < n; ++i) {
    if (args->valid[i] != -1) continue;
    float& tfar = RTCRayN_tfar(args->ray, n, i);
    fans.Trace(static_cast<int>(args->primID), Origin(args->ray, n, i),
               Direction(args->ray, n, i), RTCRayN_tnear(args->ray, n, i), tfar,
               [&](const HubFans::Hit&) {
                 tfar = -std::numeric_limits<float>::infinity();
                 return -1.0;
               });
  }
}

}  // namespace

RTCGeometry NewHubFanGeometry(RTCDevice device, const HubFans* fans) {
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
  if (!g) return nullptr;
  rtcSetGeometryUserPrimitiveCount(g, static_cast<unsigned>(fans->num_fans()));
  rtcSetGeometryUserData(g, const_cast<HubFans*>(fans));
  rtcSetGeometryBoundsFunction(g, FanBounds, nullptr);
  rtcSetGeometryIntersectFunction(g, FanIntersect);
  rtcSetGeometryOccludedFunction(g, FanOccluded);
  return g;
}

}  // namespace meshgauge
