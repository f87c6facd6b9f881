// The boxes swept by moved primitives (each the bounds of its corners before
// and after a move, enlarged), in an Embree BVH, for the incremental ray
// pass (SdfEvaluator::Compute with a PreviousPass): a ray whose segment
// crosses no box cannot have met a moved primitive, before or after.
#pragma once

#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/box.h"
#include "lib/core/vec3.h"

struct RTCSceneTy;
struct RTCGeometryTy;

namespace meshgauge {

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
