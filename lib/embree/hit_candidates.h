// The candidates for a ray's closest hit, collected while Embree traverses
// (RayScene::IntersectFan) so that the primitive picked does not depend on
// the traversal order (SPEC §3: not on the BVH's history).
//
// Embree's single-precision test gives each primitive a distance t_f; which
// of several primitives at (nearly) the same t_f it reports depends on the
// order it visits them. Instead, every primitive with
//   t_f <= t* + Window(t*, reach),   t* = the smallest t_f,
// is kept (the `kMax` smallest by (t_f, primitive)), and the caller picks
// among them in double precision (PickClosest in sdf_evaluator.cc). The
// window is far wider than single-precision rounding (2^-16 of the
// coordinates' magnitude against about 2^-22), and its set depends only on
// each primitive's own test, not on the order of the tests.
#pragma once

#include <algorithm>
#include <cstdint>

namespace meshgauge {

class HitCandidates {
 public:
  static constexpr int kMax = 8;
  // A hit whose smallest barycentric coordinate is below this lies near
  // the primitive's boundary (Entry::edge).
  static constexpr float kEdge = 0x1p-10f;
  struct Entry {
    int32_t prim;
    float t;
    // Embree's barycentric coordinates put the hit within 2^-10 of the
    // primitive's boundary (where the closure of PickClosest looks at the
    // neighbours).
    bool edge;
  };

  // `reach`: the largest coordinate magnitude of the ray's origin in the
  // scene's coordinates (the rounding of t_f scales with it).
  explicit HitCandidates(float reach = 0) : reach_(reach) {}
  // As HitCandidates(reach), without writing the entries.
  void Reset(float reach) {
    reach_ = reach;
    near_ = false;
    count_ = 0;
  }
  // As Reset with the reach it has.
  void Clear() { Reset(reach_); }

  // Largest t_f still in the window of `best`.
  static float Window(float best, float reach) {
    return best + (reach + best) * 0x1p-16f;
  }
  // The distance up to which Embree must still report primitives.
  float Limit() const { return Window(entries_[0].t, reach_); }

  // Records a primitive hit at t_f = `t`. A primitive may be reported more
  // than once (a hub fan's neighbour by Embree and by HubFans, whose tests
  // round differently): it keeps its smallest t_f and that report's edge
  // flag (or'ed over reports at the same t_f), whatever the order.
  void Add(int32_t prim, float t, bool edge) {
    if (count_ > 0 && t > Limit()) return;
    for (int i = 0; i < count_; ++i) {
      if (entries_[i].prim != prim) continue;
      if (t == entries_[i].t) entries_[i].edge |= edge;
      if (t >= entries_[i].t) return;
      for (; i + 1 < count_; ++i) entries_[i] = entries_[i + 1];
      --count_;
      break;
    }
    int i = std::min(count_, kMax - 1);
    const Entry e{prim, t, edge};
    if (count_ == kMax && !Before(e, entries_[i])) return;
    for (; i > 0 && Before(e, entries_[i - 1]); --i) {
      entries_[i] = entries_[i - 1];
    }
    entries_[i] = e;
    count_ = std::min(count_ + 1, kMax);
    const float limit = Limit();
    while (entries_[count_ - 1].t > limit) --count_;
  }

  // Set when a primitive was met near the self-hit threshold (RayScene's
  // FanLimits::near_below), where a change of the threshold could change
  // the hit (the incremental pass retraces such rays when it changes).
  void MarkNear() { near_ = true; }
  bool near() const { return near_; }

  int count() const { return count_; }
  const Entry& operator[](int i) const { return entries_[i]; }

 private:
  static bool Before(const Entry& a, const Entry& b) {
    return a.t < b.t || (a.t == b.t && a.prim < b.prim);
  }

  float reach_;
  bool near_ = false;
  int count_ = 0;
  Entry entries_[kMax];
};

}  // namespace meshgauge
