// Embree ray set-up shared by the scene and the raw-Embree benchmark.
#pragma once

#include <embree3/rtcore.h>

#include "lib/core/vec3.h"

namespace meshgauge {

// A single ray (and empty hit) for rtcIntersect1 from double inputs.
RTCRayHit MakeRayHit(const Vec3& origin, const Vec3& dir, float t_near,
                     float t_far);

// One Embree device for the whole process (created on first use, never
// released; Embree devices are thread-safe), so that rebuilding a scene
// does not create a device. Null when Embree cannot create one.
RTCDevice SharedDevice();

// Bytes Embree holds now on the shared device (BVHs, geometry buffers and
// build memory of every scene of the process), from its memory monitor.
int64_t RayTracerBytes();

}  // namespace meshgauge
