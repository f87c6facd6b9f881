#include "lib/embree/fan_filter.h"

#include <algorithm>
#include <bit>

namespace meshgauge {
namespace {

// Which of fan.out lane i's ray records into.
unsigned CandidatesIndex(const FanContext& fan,
                         const RTCFilterFunctionNArguments* args, unsigned i) {
  if (fan.lanes_by_id) return RTCRayN_id(args->ray, args->N, i);
  return args->N == 1 ? 0 : i;
}

// FanFilter's work on lane i.
void FilterLane(const FanContext& fan, const RTCFilterFunctionNArguments* args,
                unsigned i) {
  const auto prim = static_cast<int32_t>(RTCHitN_primID(args->hit, args->N, i));
  if (std::binary_search(fan.excluded.begin(), fan.excluded.end(), prim)) {
    args->valid[i] = 0;
    return;
  }
  HitCandidates& c = fan.out[CandidatesIndex(fan, args, i)];
  float& tfar = RTCRayN_tfar(args->ray, args->N, i);
  const float u = RTCHitN_u(args->hit, args->N, i);
  const float v = RTCHitN_v(args->hit, args->N, i);
  const bool edge = fan.segments
                        ? std::min(u, 1 - u) < HitCandidates::kEdge
                        : std::min({u, v, 1 - u - v}) < HitCandidates::kEdge;
  if (!RecordHit(fan, c, prim, tfar, edge)) {
    args->valid[i] = 0;
    return;
  }
  // Embree keeps a tfar that the filter set when it accepts the hit.
  tfar = std::min(c.Limit(), fan.t_far);
}

}  // namespace

void FanFilter(const RTCFilterFunctionNArguments* args) {
  const auto& fan = *reinterpret_cast<const FanContext*>(args->context);
  // Embree passes one valid lane when it traces a packet's rays one at a
  // time: find the valid lanes without a branch per lane.
  uint32_t lanes = 0;
  for (unsigned i = 0; i < args->N; ++i) {
    lanes |= static_cast<uint32_t>(args->valid[i] == -1) << i;
  }
  for (; lanes != 0; lanes &= lanes - 1) {
    FilterLane(fan, args, static_cast<unsigned>(std::countr_zero(lanes)));
  }
}

}  // namespace meshgauge
