// The Embree filter of RayScene::IntersectFan: collects each ray's
// candidates for its closest hit (hit_candidates.h) whatever the traversal
// order. Apart from ray_scene.cc so that tests can call it on packets with
// several valid lanes, which Embree's traversal may or may not produce.
#pragma once

#include <embree3/rtcore.h>

#include <cstdint>

#include "absl/types/span.h"
#include "lib/embree/hit_candidates.h"

namespace meshgauge {

// The context of one fan's traversal: Embree passes it to FanFilter.
struct FanContext {
  RTCIntersectContext rtc;             // first: Embree sees a pointer to it.
  absl::Span<const int32_t> excluded;  // ascending.
  float t_min = 0, near_below = 0, t_far = 0;
  bool segments = false;  // 2D: extruded quads, whose u runs along the segment.
  // out[lane] for packets, out[0] for N == 1; with lanes_by_id out[ray id]
  // (a stream, whose rays Embree regroups).
  HitCandidates* out = nullptr;
  bool lanes_by_id = false;
};

// Called by Embree (args->context is a FanContext) for every hit within a
// ray's current tfar, for the lanes of args->valid that are -1 (N <= 16).
// Per lane: rejects (valid = 0; Embree restores tfar) an excluded primitive
// or one closer than t_min, marking the candidates near() below
// near_below; records the others (HitCandidates::Add, with whether the hit
// lies within 2^-10 of the primitive's boundary in barycentric terms) and
// sets tfar to the candidates' window (at most t_far), so that every
// primitive in it is still reported.
void FanFilter(const RTCFilterFunctionNArguments* args);

// FanFilter's rule for a hit at t_f = `t` of a primitive not excluded, for
// other traversals (cone_walk.h): marks `c` near() below fan.near_below;
// ignores the hit below fan.t_min (false); else records it
// (HitCandidates::Add) and returns true, and the ray must then look no
// farther than min(c.Limit(), fan.t_far).
inline bool RecordHit(const FanContext& fan, HitCandidates& c, int32_t prim,
                      float t, bool edge) {
  if (t < fan.near_below) c.MarkNear();
  if (t < fan.t_min) return false;
  c.Add(prim, t, edge);
  return true;
}

}  // namespace meshgauge
