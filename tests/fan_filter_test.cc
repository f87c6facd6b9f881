// FanFilter on packets with several valid lanes (Embree's packet traversal
// may call it so; on this machine's builds it passes one lane at a time, so
// RaySceneTest's fans never reach this path) and on single rays.
#include "lib/embree/fan_filter.h"

#include <gtest/gtest.h>

#include <vector>

namespace meshgauge {
namespace {

struct Lane {
  int32_t prim;
  float t, u, v;
  unsigned id = 0;  // the ray's id (a stream's index of the ray)
};

// Calls FanFilter once on a packet of lanes.size() lanes (laid out for
// that N, as Embree passes them), lane i valid when its prim is >= 0;
// returns the valid flags and, in `tfar`, the rays' tfar after the call.
std::vector<int> Filter(const FanContext& fan, const std::vector<Lane>& lanes,
                        std::vector<float>* tfar = nullptr) {
  const unsigned n = static_cast<unsigned>(lanes.size());
  RTCRay16 ray{};
  RTCHit16 hit{};
  auto* rays = reinterpret_cast<RTCRayN*>(&ray);
  auto* hits = reinterpret_cast<RTCHitN*>(&hit);
  std::vector<int> valid(n);
  for (unsigned i = 0; i < n; ++i) {
    valid[i] = lanes[i].prim >= 0 ? -1 : 0;
    RTCHitN_primID(hits, n, i) =
        static_cast<unsigned>(lanes[i].prim >= 0 ? lanes[i].prim : 999);
    RTCHitN_u(hits, n, i) = lanes[i].u;
    RTCHitN_v(hits, n, i) = lanes[i].v;
    RTCRayN_tfar(rays, n, i) = lanes[i].t;
    RTCRayN_id(rays, n, i) = lanes[i].id;
  }
  RTCFilterFunctionNArguments args{};
  args.valid = valid.data();
  args.context = const_cast<RTCIntersectContext*>(&fan.rtc);
  args.ray = rays;
  args.hit = hits;
  args.N = n;
  FanFilter(&args);
  if (tfar) {
    tfar->resize(n);
    for (unsigned i = 0; i < n; ++i) (*tfar)[i] = RTCRayN_tfar(rays, n, i);
  }
  return valid;
}

// `excluded` must outlive the context.
FanContext Context(const std::vector<int32_t>& excluded,
                   std::vector<HitCandidates>& out) {
  FanContext fan;
  rtcInitIntersectContext(&fan.rtc);
  fan.excluded = excluded;
  fan.t_min = 1;
  fan.near_below = 0.75f;
  fan.t_far = 2.5f;
  fan.out = out.data();
  return fan;
}

// Lanes 1, 4, 9 and 15 of 16 are valid: one is recorded (its tfar cut to
// t_far), one excluded, one below t_min (and near), one recorded at an
// edge; the invalid lanes are left alone, whatever their hits say.
TEST(FanFilterTest, EveryValidLaneOfAPacketIsFilteredOnItsOwn) {
  const std::vector<int32_t> excluded = {3, 104, 200};
  std::vector<HitCandidates> out(16);
  const FanContext fan = Context(excluded, out);
  std::vector<Lane> lanes(16, Lane{-1, 1.5f, 0.3f, 0.3f});
  lanes[1] = {101, 3.0f, 0.3f, 0.3f};
  lanes[4] = {104, 1.5f, 0.3f, 0.3f};
  lanes[9] = {109, 0.5f, 0.3f, 0.3f};
  lanes[15] = {115, 2.0f, 0.0001f, 0.5f};
  std::vector<float> tfar;
  const std::vector<int> valid = Filter(fan, lanes, &tfar);
  for (int i = 0; i < 16; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(valid[i], i == 1 || i == 15 ? -1 : 0);
    EXPECT_EQ(out[i].count(), i == 1 || i == 15 ? 1 : 0);
    EXPECT_EQ(out[i].near(), i == 9);
    if (i != 1 && i != 15) {
      EXPECT_EQ(tfar[i], lanes[i].t);
    }
  }
  EXPECT_EQ(out[1][0].prim, 101);
  EXPECT_EQ(out[1][0].t, 3.0f);
  EXPECT_FALSE(out[1][0].edge);
  EXPECT_EQ(tfar[1], fan.t_far);
  EXPECT_EQ(out[15][0].prim, 115);
  EXPECT_TRUE(out[15][0].edge);
  EXPECT_EQ(tfar[15], HitCandidates::Window(2.0f, 0));
}

// Every lane of a full packet valid: each records into its own candidates.
TEST(FanFilterTest, AFullPacketRecordsEveryLane) {
  std::vector<HitCandidates> out(16);
  const std::vector<int32_t> none;
  const FanContext fan = Context(none, out);
  std::vector<Lane> lanes(16);
  for (int i = 0; i < 16; ++i)
    lanes[i] = {10 + i, 1.0f + 0.05f * i, 0.2f, 0.2f};
  Filter(fan, lanes);
  for (int i = 0; i < 16; ++i) {
    ASSERT_EQ(out[i].count(), 1) << i;
    EXPECT_EQ(out[i][0].prim, 10 + i);
  }
}

// A single ray (N = 1) writes out[0]; a second primitive at the same t
// joins it, one beyond the window does not.
TEST(FanFilterTest, ASingleRayCollectsItsWindow) {
  std::vector<HitCandidates> out(1);
  const std::vector<int32_t> none;
  const FanContext fan = Context(none, out);
  std::vector<float> tfar;
  Filter(fan, {Lane{7, 2.0f, 0.2f, 0.2f}}, &tfar);
  EXPECT_EQ(tfar[0], HitCandidates::Window(2.0f, 0));
  Filter(fan, {Lane{8, 2.0f, 0.3f, 0.3f}});
  Filter(fan, {Lane{9, 2.1f, 0.3f, 0.3f}});
  ASSERT_EQ(out[0].count(), 2);
  EXPECT_EQ(out[0][0].prim, 7);
  EXPECT_EQ(out[0][1].prim, 8);
}

// A stream's rays reach the filter in groups Embree makes: with
// lanes_by_id each lane records into the candidates of its ray's id, not
// of its lane.
TEST(FanFilterTest, AStreamsLanesRecordIntoTheirRaysCandidates) {
  std::vector<HitCandidates> out(40);
  const std::vector<int32_t> none;
  FanContext fan = Context(none, out);
  fan.lanes_by_id = true;
  std::vector<Lane> lanes(8);
  for (int i = 0; i < 8; ++i) {
    lanes[i] = {20 + i, 1.5f, 0.2f, 0.2f, static_cast<unsigned>(39 - 3 * i)};
  }
  Filter(fan, lanes);
  for (int k = 0; k < 40; ++k) {
    const bool traced = k <= 39 && (39 - k) % 3 == 0 && (39 - k) / 3 < 8;
    ASSERT_EQ(out[k].count(), traced ? 1 : 0) << k;
    if (traced) {
      EXPECT_EQ(out[k][0].prim, 20 + (39 - k) / 3) << k;
    }
  }
}

}  // namespace
}  // namespace meshgauge
