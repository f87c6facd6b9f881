// Stateful SDF evaluation: owns a validated mesh and its Embree BVH so that
// an optimiser can move vertices (UpdatePositions, a BVH refit) and evaluate
// again without rebuilding. The one-shot entry point is ComputeSdf (sdf.h).
#pragma once

#include <tbb/task_arena.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "absl/functional/function_ref.h"
#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/cone.h"
#include "lib/core/hit.h"
#include "lib/core/hit_table.h"
#include "lib/core/mesh.h"
#include "lib/core/mesh_geometry.h"
#include "lib/core/sdf_types.h"
#include "lib/core/topology.h"
#include "lib/embree/ray_scene.h"

namespace meshgauge {

namespace pass_state {
struct PassSetup;  // pass_state.h
}  // namespace pass_state

// Where a pass's rays start.
enum class RayStartMode {
  // At the sample (Embree walks the surface's boxes around it).
  kSurface,
  // Past a tangent ball proven empty within the rays' cone, where one is
  // found (ray_start.h); elsewhere at the sample, and so in an incremental
  // pass are an unmoved sample's rays when it retraces only a few
  // (sdf_evaluator.cc). 3D only.
  kPastEmptyBall,
  // kPastEmptyBall for 3D passes large enough that building the ball's
  // tree costs less than it saves (sdf_evaluator.cc), else kSurface.
  kAuto,
};

struct EvaluatorOptions {
  BvhUpdatePolicy bvh_policy = BvhUpdatePolicy::kRefit;
  // With kRefit: an update whose new generation is a BVH base
  // (IsBvhBase) builds the BVH from scratch at the new positions instead
  // of refitting it (a refitted BVH stays correct, but its quality degrades
  // as vertices move far). 0: never; >= 0.
  int rebuild_every_updates = 0;
  // generation() right after creation (>= 0): a session restored at a later
  // generation keeps counting from there.
  int64_t generation = 0;
  // kFast only to measure what the watertight test costs (it breaks SPEC
  // §4 on rays through shared edges).
  RayTest ray_test = RayTest::kWatertight;
  // Where a 3D pass starts its rays (ray_start.h). The others only to
  // measure what the empty ball saves and that it changes no bit.
  RayStartMode ray_start = RayStartMode::kAuto;
  // How a pass traces each sample's rays; nullopt: kCone on a 3D scene of
  // fewer than 2^13 primitives (2^15 for cones of more than one ray
  // narrower than kNarrowWalkMaxConeDegrees) with the watertight test, at most
  // ConeWalk::kMaxRays rays and a CPU with AVX2 and FMA, for one ray a fan
  // (normal rays) or where a pilot finds the walk's work small (kAuto or
  // kSurface starts; the pass then starts its rays at the surface,
  // whatever kAuto would have chosen); else kStream where the pass starts
  // its rays at the surface on such a scene and its cones open less than
  // kStreamMaxConeDegrees, and kPackets otherwise
  // (traversal_choice.h, WalksCones). A pass asked for kCone streams where the
  // walk would give up on its fans (ConeWalk::Intersect): it walks all samples
  // or none. The others only to measure them; none changed a value on the fans
  // tried (RayTraversalTest).
  std::optional<FanTraversal> fan_traversal = std::nullopt;
};

// True when the BVH of `generation` is built from scratch rather than
// refitted: every `rebuild_every_updates` generations (0: never), counted
// from generation 0 whatever the evaluator's history, so that evaluators
// restored at any generation agree.
bool IsBvhBase(int64_t generation, int rebuild_every_updates);

// A pass of the same evaluator, at an earlier generation or the same one,
// whose rays a new pass may reuse: its result and the hit table it filled.
struct PreviousPass {
  const SdfResult* result = nullptr;
  const HitTable* hits = nullptr;
};

// The bytes SdfEvaluator::Compute(params, control, &hits) returns and
// keeps for `mesh`: the hit table (5 per ray, 1 per sample, 24 per vertex)
// and the result (25 per sample, 24 more with opposite points), equal to
// PassBytes of the pass. Per-thread buffers and the ball tree of a kSphere
// pass or of rays started past empty balls (ray_start.h), freed when
// Compute returns, are not counted. For bounding a pass
// before it is traced (the server's memory budget); params must be valid
// (ResolveParams).
int64_t EstimatePassBytes(const Mesh& mesh, const SdfParams& params);
// The bytes a pass's result and hit table hold.
int64_t PassBytes(const SdfResult& result, const HitTable& hits);

class SdfEvaluator : public MeshGeometry {
 public:
  // Validates `mesh` (SPEC §1) and builds the BVH.
  // Errors: InvalidArgument from ValidateMesh; Internal from Embree.
  static absl::StatusOr<std::unique_ptr<SdfEvaluator>> Create(
      Mesh mesh, const EvaluatorOptions& options = {});

  // Computes SDF values for every vertex (SPEC §3-5), or every face
  // centroid with params.samples == kFaces (SPEC v2 §5c; faces in file
  // order). When `hits` is not null it receives the hit table for
  // sensitivities (memory: 5 bytes x samples x K and 25 x #V). Const and
  // thread-safe: concurrent Computes on one evaluator are fine; UpdatePositions
  // must not run concurrently with anything. With `previous` (a pass of this
  // evaluator with the same parameters whose hit table was kept), only the rays
  // whose hit may have changed since are traced (docs/numerics.md, "Incremental
  // passes"); the result and the hit table's primitives and kept flags are the
  // full pass's, bit for bit, and rays_traced counts the rays traced. A
  // previous pass that does not fit (other parameters, another frame of the ray
  // tracer, over half the vertices moved) gives a full pass, as does every
  // kSphere pass (the ball has no rays to reuse; it builds its own BVH,
  // ball_tree.h) and every face-sample pass. Errors: InvalidArgument for
  // bad params or control.threads; Cancelled when control.cancelled() returned
  // true; Internal from Embree.
  absl::StatusOr<SdfResult> Compute(
      const SdfParams& params, const ComputeControl& control = {},
      HitTable* hits = nullptr, const PreviousPass* previous = nullptr) const;

  // Replaces all vertex positions (#V entries, finite) and refits or
  // rebuilds the BVH. Topology never changes. The new positions are
  // validated like a new mesh (no zero-area face); on error nothing changes.
  // Errors: InvalidArgument (wrong count, non-finite, degenerate faces).
  absl::Status UpdatePositions(absl::Span<const Vec3> positions);
  // Same for a subset: positions[i] is the new position of vertex
  // indices[i] (each index in range, no repeats).
  absl::Status UpdatePositions(absl::Span<const int32_t> indices,
                               absl::Span<const Vec3> positions);

  const RayScene& scene() const { return *scene_; }

  // BVH builds (creation, kRebuild updates, base generations) and refits
  // (other kRefit updates): each update counts once.
  // Safe to read while another thread updates the positions.
  int64_t builds() const { return builds_.load(); }
  int64_t refits() const { return refits_.load(); }

 private:
  SdfEvaluator() = default;
  absl::Status CommitPositions(std::vector<Vec3> old_positions);
  struct ReusePlan;
  // What of `previous` a pass can reuse; null when nothing.
  // (Among others, nothing when the two passes' rules chose different
  // tracers: `walks_cones`, HitTable::walks_cones.)
  absl::StatusOr<std::unique_ptr<ReusePlan>> PlanReuse(
      const PreviousPass& previous, const std::vector<ConeRay>& cone,
      const ResolvedParams& resolved, bool walks_cones, float t_near,
      double t_min, double t_max) const;
  // The rays of vertex p (at x, cone axis `axis`) that a pass reusing
  // `plan` traces again (docs/numerics.md, "Incremental passes"), into
  // `retrace`; prims gets the previous pass's hits and t the distances of
  // those it measured. `directions` fills `dirs` when they are needed.
  void RaysToRetrace(const ReusePlan& plan, int64_t p, const Vec3& x,
                     const Vec3& axis, double cone_half_angle, double reach,
                     float t_far, absl::FunctionRef<void()> directions,
                     absl::Span<const Vec3> dirs, absl::Span<int32_t> prims,
                     absl::Span<double> t, std::vector<int32_t>* retrace) const;
  // Whether a pass of `setup` left to choose walks cones (WalksCones,
  // traversal_choice.h, run in the pass's `arena`), with its pilot into
  // *pilot; from walk_choice_ when it holds them.
  bool ChooseWalk(const pass_state::PassSetup& setup, tbb::task_arena& arena,
                  double* pilot) const;
  // Builds the BVH from scratch at the current positions.
  absl::Status RebuildBvh();
  // One pass's work on one sample (sdf_evaluator.cc).
  class SampleTracer;

  BvhUpdatePolicy policy_ = BvhUpdatePolicy::kRefit;
  RayTest ray_test_ = RayTest::kWatertight;
  RayStartMode ray_start_ = RayStartMode::kAuto;
  std::optional<FanTraversal> fan_traversal_;
  int rebuild_every_updates_ = 0;
  std::atomic<int64_t> builds_{0}, refits_{0};
  std::unique_ptr<RayScene> scene_;
  // The last choice of a pass left to choose whether to walk cones, and
  // its pilot (traversal_choice.h, WalksCones): a function of the positions
  // (the generation) and of the parameters but for the range, kept for
  // the next pass at the same ones (another range, the values then the
  // hit table).
  struct WalkChoice {
    int64_t generation = -1;
    SdfParams params;
    bool walks = false;
    double pilot = 0;
  };
  mutable std::mutex walk_choice_mu_;
  mutable WalkChoice walk_choice_;
};

}  // namespace meshgauge
