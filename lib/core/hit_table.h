// The frozen result of a ray pass, the input of the sensitivities.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/types/span.h"
#include "lib/core/cone.h"
#include "lib/core/sdf_types.h"

namespace meshgauge {

// The frozen result of a ray pass: for every vertex p and ray k, the hit
// primitive (index into MeshTopology::primitives) or -1, and whether the ray
// was kept by the filter. Row-major #V x K.
// Sensitivities (SPEC §6) hold these fixed and differentiate the rest.
struct HitTable {
  ResolvedParams resolved;
  std::vector<ConeRay> cone;
  std::vector<int32_t> primitives;
  std::vector<uint8_t> kept;  // #V x K: 1 where the ray passed the filter.
  double t_min = 0;           // self-hit threshold, mesh units.
  double t_max = 0;           // miss distance, mesh units.
  int64_t generation = -1;
  // Bytes held: 5 per ray (a primitive index and a kept flag).
  int64_t Bytes() const {
    return static_cast<int64_t>(primitives.capacity() * sizeof(int32_t) +
                                kept.capacity());
  }
  absl::Span<const int32_t> Row(int64_t vertex) const {
    return absl::MakeConstSpan(primitives.data() + vertex * cone.size(),
                               cone.size());
  }
  absl::Span<const uint8_t> KeptRow(int64_t vertex) const {
    return absl::MakeConstSpan(kept.data() + vertex * cone.size(), cone.size());
  }
};

}  // namespace meshgauge
