// Stateful SDF evaluation: owns a validated mesh and its Embree BVH so that
// an optimiser can move vertices (UpdatePositions, a BVH refit) and evaluate
// again without rebuilding. The one-shot entry point is ComputeSdf (sdf.h).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/cone.h"
#include "lib/hit.h"
#include "lib/mesh.h"
#include "lib/ray_scene.h"
#include "lib/sdf_types.h"
#include "lib/topology.h"

namespace meshgauge {

struct EvaluatorOptions {
  BvhUpdatePolicy bvh_policy = BvhUpdatePolicy::kRefit;
};

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
  absl::Span<const int32_t> Row(int64_t vertex) const {
    return absl::MakeConstSpan(primitives.data() + vertex * cone.size(),
                               cone.size());
  }
  absl::Span<const uint8_t> KeptRow(int64_t vertex) const {
    return absl::MakeConstSpan(kept.data() + vertex * cone.size(), cone.size());
  }
};

class SdfEvaluator {
 public:
  // Validates `mesh` (SPEC §1) and builds the BVH.
  // Errors: InvalidArgument from ValidateMesh; Internal from Embree.
  static absl::StatusOr<std::unique_ptr<SdfEvaluator>> Create(
      Mesh mesh, const EvaluatorOptions& options = {});

  // Computes SDF values for every vertex (SPEC §3-5). When `hits` is not
  // null it receives the hit table for sensitivities (memory: 5 bytes x #V x
  // K). Const and thread-safe: concurrent Computes on one evaluator are fine;
  // UpdatePositions must not run concurrently with anything.
  // Errors: InvalidArgument for bad params; Cancelled when
  // control.cancelled() returned true.
  absl::StatusOr<SdfResult> Compute(const SdfParams& params,
                                    const ComputeControl& control = {},
                                    HitTable* hits = nullptr) const;

  // Replaces all vertex positions (#V entries, finite) and refits or
  // rebuilds the BVH. Topology never changes. The new positions are
  // validated like a new mesh (no zero-area face); on error nothing changes.
  // Errors: InvalidArgument (wrong count, non-finite, degenerate faces).
  absl::Status UpdatePositions(absl::Span<const Vec3> positions);
  // Same for a subset: positions[i] is the new position of vertex
  // indices[i] (each index in range, no repeats).
  absl::Status UpdatePositions(absl::Span<const int32_t> indices,
                               absl::Span<const Vec3> positions);

  // Rebuilds the BVH from scratch at the current positions (a refitted BVH
  // stays correct but its quality degrades as vertices move far).
  absl::Status RebuildBvh();

  const Mesh& mesh() const { return mesh_; }
  const MeshTopology& topology() const { return topo_; }
  const RayScene& scene() const { return *scene_; }
  // Increments on every successful UpdatePositions; starts at 0.
  int64_t generation() const { return generation_; }
  // Corners of every primitive at the current positions (double).
  const std::vector<PrimitiveCorners>& corners() const { return corners_; }
  double mean_edge_length() const { return mean_edge_length_; }
  double bounding_box_diagonal() const { return bbox_diagonal_; }

 private:
  SdfEvaluator() = default;
  absl::Status CommitPositions(std::vector<Vec3> old_positions);
  void RefreshDerivedGeometry();

  Mesh mesh_;
  MeshTopology topo_;
  BvhUpdatePolicy policy_ = BvhUpdatePolicy::kRefit;
  std::unique_ptr<RayScene> scene_;
  std::vector<PrimitiveCorners> corners_;
  int64_t generation_ = 0;
  double mean_edge_length_ = 0;
  double bbox_diagonal_ = 0;
};

}  // namespace meshgauge
