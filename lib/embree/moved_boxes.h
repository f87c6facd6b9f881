// The boxes swept by moved primitives (each the bounds of its corners before
// and after a move, enlarged), in an Embree BVH, for the incremental ray
// pass (SdfEvaluator::Compute with a PreviousPass): a ray whose segment
// crosses no box cannot have met a moved primitive, before or after.
#pragma once

#include <algorithm>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/vec3.h"

struct RTCSceneTy;
struct RTCGeometryTy;

namespace meshgauge {

struct Box {
  // Empty: the first Extend sets both corners.
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  // Grows the box to hold the box [a, b].
  void Extend(const Vec3& a, const Vec3& b) {
    lo = Vec3(std::min(lo.x, a.x), std::min(lo.y, a.y), std::min(lo.z, a.z));
    hi = Vec3(std::max(hi.x, b.x), std::max(hi.y, b.y), std::max(hi.z, b.z));
  }
};

class MovedBoxes {
 public:
  // `boxes` in the coordinates the caller will trace in (a RayScene's:
  // relative to its SceneOrigin), each already enlarged by the caller's
  // slack. Errors: Internal on Embree failure.
  static absl::StatusOr<std::unique_ptr<MovedBoxes>> Create(
      std::vector<Box> boxes);
  ~MovedBoxes();
  MovedBoxes(const MovedBoxes&) = delete;
  MovedBoxes& operator=(const MovedBoxes&) = delete;

  // True when origin + t * dir, t in [0, t_end], may cross a box
  // (conservative: the single-precision ray against the boxes). Thread-safe.
  bool Crosses(const Vec3& origin, const Vec3& dir, double t_end) const;

 private:
  MovedBoxes() = default;
  std::vector<Box> boxes_;
  RTCSceneTy* scene_ = nullptr;
  RTCGeometryTy* geometry_ = nullptr;
};

}  // namespace meshgauge
