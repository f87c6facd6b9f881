// An axis-aligned bounding box.
#pragma once

#include <algorithm>

#include "lib/core/vec3.h"

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

}  // namespace meshgauge
