// The frozen result of a ray pass, the input of the sensitivities.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/types/span.h"
#include "lib/core/cone.h"
#include "lib/core/sdf_types.h"
#include "lib/core/table_allocator.h"
#include "lib/core/vec3.h"

namespace meshgauge {

// The frozen result of a ray pass: for every vertex p and ray k, the hit
// primitive (index into MeshTopology::primitives) or -1, and whether the ray
// was kept by the filter. Row-major #V x K. kSphere (K = 1): the touching
// primitive and its closed form.
// Sensitivities (SPEC §6) hold these fixed and differentiate the rest.
struct HitTable {
  ResolvedParams resolved;
  std::vector<ConeRay> cone;
  TableVector<int32_t> primitives;
  // #V x K: 1 where the ray passed the filter. kSphere (K = 1): the
  // touching primitive's closed form + 1 (BallContact::kind), 0 for none,
  // so that a change of form counts as an event like a change of hit.
  TableVector<uint8_t> kept;
  double t_min = 0;  // self-hit threshold, mesh units.
  double t_max = 0;  // miss distance, mesh units.
  int64_t generation = -1;
  // What a later pass needs to reuse this one's rays (SdfEvaluator::Compute
  // with a PreviousPass): the positions, per vertex whether a ray met a
  // primitive near the self-hit threshold (RayScene::FanLimits), and the
  // ray tracer's frame and single-precision self-hit distance.
  std::vector<Vec3> positions;
  std::vector<uint8_t> near;
  Vec3 scene_origin;
  float extrude_half_height = 0;
  float t_near = 0;
  int64_t num_primitives = 0;  // of the topology the pass was traced on.
  // A sample range's pass holds the rows of its samples only, the first
  // being this sample's (resolved.params.range.begin).
  int64_t first_sample = 0;
  // Whether the pass's rule chose the cone walk (SdfEvaluator: it depends
  // on the positions, and the walk and Embree may record different
  // primitives at a tie, so a pass reuses only one that chose alike).
  bool walks_cones = false;
  // Bytes held: 5 per ray (a primitive index and a kept flag) and 25 per
  // vertex.
  int64_t Bytes() const {
    return static_cast<int64_t>(
        primitives.capacity() * sizeof(int32_t) + kept.capacity() +
        positions.capacity() * sizeof(Vec3) + near.capacity());
  }
  absl::Span<const int32_t> Row(int64_t vertex) const {
    return absl::MakeConstSpan(
        primitives.data() + (vertex - first_sample) * cone.size(),
        cone.size());
  }
  absl::Span<const uint8_t> KeptRow(int64_t vertex) const {
    return absl::MakeConstSpan(
        kept.data() + (vertex - first_sample) * cone.size(), cone.size());
  }
};

}  // namespace meshgauge
