// HubFans as an Embree user geometry: one user primitive per fan, whose
// intersection callback traces the fan's tree and hands each triangle hit to
// the context's filter (rtcFilterIntersection) as Embree does for its own
// triangles, so that RayScene::IntersectFan's FanFilter sees fan triangles
// and Embree's alike (the primitive number is the MeshTopology one).
#pragma once

#include <embree3/rtcore.h>

#include "lib/embree/hub_fans.h"

namespace meshgauge {

// A committed-ready user geometry over `fans` (which must outlive it and is
// read by Embree's build and traversal threads), or null on Embree failure.
// After fans->Update, rtcCommitGeometry makes Embree read the new bounds.
RTCGeometry NewHubFanGeometry(RTCDevice device, const HubFans* fans);

}  // namespace meshgauge
