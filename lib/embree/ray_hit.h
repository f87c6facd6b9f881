// Embree ray set-up shared by the scene and the raw-Embree benchmark.
#pragma once

#include <embree3/rtcore.h>

#include "lib/core/vec3.h"

namespace meshgauge {

// A single ray (and empty hit) for rtcIntersect1 from double inputs.
RTCRayHit MakeRayHit(const Vec3& origin, const Vec3& dir, float t_near,
                     float t_far);

// Whether a direction component, in single precision, lies in (-1e-18, 0).
// Embree 3.13 forms a component below 1e-18 in magnitude as +1e-18 when it
// takes the reciprocal, while its coherent streams (rtcIntersect1M with
// RTC_INTERSECT_CONTEXT_FLAG_COHERENT) group rays by the component's sign:
// a stream holding such a ray loses hits of the rays walked with it
// (EmbreeStreamTest: 7 of spot's vertices, on its plane of symmetry).
inline bool JustBelowZero(float c) { return c < 0 && c > -1e-18f; }
// Whether a ray has such a component: a coherent stream must not hold it.
inline bool StreamMayLoseHits(const RTCRay& ray) {
  return JustBelowZero(ray.dir_x) || JustBelowZero(ray.dir_y) ||
         JustBelowZero(ray.dir_z);
}

// Lane `lane` of an Embree packet (RTCRayHit4/8/16) as MakeRayHit's ray.
template <typename RayHitN>
void SetPacketRay(RayHitN& rh, int lane, const Vec3& origin, const Vec3& dir,
                  float t_near, float t_far) {
  rh.ray.org_x[lane] = static_cast<float>(origin.x);
  rh.ray.org_y[lane] = static_cast<float>(origin.y);
  rh.ray.org_z[lane] = static_cast<float>(origin.z);
  rh.ray.dir_x[lane] = static_cast<float>(dir.x);
  rh.ray.dir_y[lane] = static_cast<float>(dir.y);
  rh.ray.dir_z[lane] = static_cast<float>(dir.z);
  rh.ray.tnear[lane] = t_near;
  rh.ray.tfar[lane] = t_far;
  rh.ray.time[lane] = 0;
  rh.ray.mask[lane] = ~0u;
  rh.ray.id[lane] = 0;
  rh.ray.flags[lane] = 0;
  rh.hit.geomID[lane] = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0][lane] = RTC_INVALID_GEOMETRY_ID;
}

// One Embree device for the whole process (created on first use, never
// released; Embree devices are thread-safe), so that rebuilding a scene
// does not create a device. Null when Embree cannot create one.
RTCDevice SharedDevice();

// Bytes Embree holds now on the shared device (BVHs, geometry buffers and
// build memory of every scene of the process), from its memory monitor.
int64_t RayTracerBytes();

}  // namespace meshgauge
