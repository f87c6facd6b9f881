// One entry of a sample's row of the Jacobian: dSDF_p/dx_vertex.
#pragma once

#include <cstdint>

#include "lib/core/vec3.h"

namespace meshgauge {

struct RowTerm {
  int32_t vertex;
  Vec3 d;
};

}  // namespace meshgauge
