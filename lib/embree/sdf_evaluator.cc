#include "lib/embree/sdf_evaluator.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>

#include "absl/strings/str_cat.h"
#include "lib/core/estimator.h"
#include "lib/core/hit.h"
#include "lib/core/normalized_sdf.h"
#include "lib/core/spatial_order.h"
#include "lib/core/vertex_cone.h"

namespace meshgauge {
namespace {

constexpr int64_t kVertexBlock = 64;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Serialises the user's hooks and throttles progress reports.
class ControlGate {
 public:
  ControlGate(const ComputeControl& control, int64_t total)
      : control_(control), total_(total) {}
  // Returns false once cancellation was requested.
  bool Poll() {
    if (stop_.load(std::memory_order_relaxed)) return false;
    if (!control_.cancelled) return true;
    std::lock_guard<std::mutex> lock(mu_);
    if (control_.cancelled()) stop_ = true;
    return !stop_;
  }
  void Done(int64_t n) {
    const int64_t done = done_.fetch_add(n) + n;
    if (!control_.progress) return;
    std::lock_guard<std::mutex> lock(mu_);
    if (done * 100 / total_ > reported_ * 100 / total_ || done == total_) {
      reported_ = std::max(reported_, done);
      control_.progress(reported_, total_);
    }
  }
  bool stopped() const { return stop_; }

 private:
  const ComputeControl& control_;
  const int64_t total_;
  std::mutex mu_;
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> done_{0};
  int64_t reported_ = 0;
};

// The closest of a ray's candidates (SPEC §3, §4): the smallest distance
// recomputed in double precision, ties broken by the lower primitive index;
// a distance that is not a positive number (a ray along the primitive's
// plane) only when no candidate has one. -1 when there is no candidate. `t`
// receives the distance (NaN for none).
int32_t PickClosest(const MeshGeometry& geometry, const HitCandidates& c,
                    const Vec3& x, const Vec3& d, double* t) {
  int32_t best = -1;
  *t = kNaN;
  for (int i = 0; i < c.count(); ++i) {
    const double ti = HitDistance(geometry.Corners(c[i].prim), x, d);
    const bool better =
        best < 0 || (!std::isnan(ti) && (std::isnan(*t) || ti < *t ||
                                         (ti == *t && c[i].prim < best)));
    if (better) {
      best = c[i].prim;
      *t = ti;
    }
  }
  return best;
}

}  // namespace

absl::StatusOr<std::unique_ptr<SdfEvaluator>> SdfEvaluator::Create(
    Mesh mesh, const EvaluatorOptions& options) {
  if (options.rebuild_every_updates < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("rebuild_every_updates must be >= 0, got ",
                     options.rebuild_every_updates));
  }
  std::unique_ptr<SdfEvaluator> ev(new SdfEvaluator());
  if (absl::Status s = ev->Init(std::move(mesh)); !s.ok()) return s;
  ev->policy_ = options.bvh_policy;
  ev->rebuild_every_updates_ = options.rebuild_every_updates;
  ev->generation_ = options.generation;
  ev->order_ = MortonOrder(ev->mesh_.positions);
  if (absl::Status s = ev->RebuildBvh(); !s.ok()) return s;
  return ev;
}

bool IsBvhBase(int64_t generation, int rebuild_every_updates) {
  return rebuild_every_updates > 0 && generation % rebuild_every_updates == 0;
}

absl::Status SdfEvaluator::RebuildBvh() {
  auto scene = RayScene::Create(mesh_, topo_, policy_);
  if (!scene.ok()) return scene.status();
  scene_ = std::move(*scene);
  ++builds_;
  return absl::OkStatus();
}

absl::StatusOr<SdfResult> SdfEvaluator::Compute(const SdfParams& params,
                                                const ComputeControl& control,
                                                HitTable* hits) const {
  const bool keep_hits = hits != nullptr;
  if (absl::Status s = ValidateParams(params); !s.ok()) return s;
  const ResolvedParams resolved = ResolveParams(params, mesh_.dimension);
  std::vector<ConeRay> cone;
  if (params.method == SdfMethod::kNormalRay) {
    cone.push_back({Vec3(0, 0, 1), 0.0, 1.0});
  } else {
    auto made = MakeCone(mesh_.dimension, resolved.aperture_radians,
                         resolved.rays, resolved.min_weight_angle);
    if (!made.ok()) return made.status();
    cone = std::move(*made);
  }
  const int64_t nv = mesh_.num_vertices();
  const int num_rays = static_cast<int>(cone.size());
  const double t_min = params.self_hit_epsilon * mean_edge_length_;
  const double t_max =
      params.max_distance > 0 ? params.max_distance : bbox_diagonal_;
  const std::vector<Vec3> normals =
      UnnormalizedNormals(mesh_, topo_, params.normal_weighting);

  SdfResult result;
  result.resolved = resolved;
  result.values.assign(nv, kNaN);
  result.status.assign(nv, VertexStatus::kOk);
  result.hits.assign(nv, 0);
  result.kept.assign(nv, 0);
  std::vector<int32_t> table;
  std::vector<uint8_t> kept_table;
  if (keep_hits) {
    table.assign(nv * num_rays, -1);
    kept_table.assign(nv * num_rays, 0);
  }

  ControlGate gate(control, nv);
  std::atomic<int64_t> rays_traced{0}, world_frame_vertices{0};
  const auto start = std::chrono::steady_clock::now();
  const float t_min_f = static_cast<float>(t_min);
  // Slightly beyond t_max so the double-precision check below decides.
  const float t_max_f = std::nextafter(static_cast<float>(t_max),
                                       std::numeric_limits<float>::max());
  auto process = [&](const tbb::blocked_range<int64_t>& range) {
    if (!gate.Poll()) return;
    std::vector<double> t(num_rays);
    std::vector<int32_t> prims(num_rays);
    std::vector<HitCandidates> candidates(num_rays);
    std::vector<int32_t> excluded;
    std::vector<Vec3> dirs(num_rays);
    std::vector<uint8_t> kept(num_rays);
    std::vector<double> scratch;
    scratch.reserve(num_rays);
    int64_t traced = 0, world_frames = 0;
    for (int64_t i = range.begin(); i < range.end(); ++i) {
      const int64_t p = order_[i];
      if (topo_.vertex_faces.Of(p).empty()) {
        result.status[p] = VertexStatus::kNoFaces;
        continue;
      }
      const VertexCone vc = MakeVertexCone(mesh_, topo_, p, normals[p]);
      if (!vc.valid) {
        result.status[p] = VertexStatus::kDegenerateNormal;
        continue;
      }
      world_frames += vc.world_frame;
      const Vec3& x = mesh_.positions[p];
      // Trace all rays first (in packets), prefetching each hit primitive,
      // then evaluate the hits in double precision once it has arrived.
      for (int k = 0; k < num_rays; ++k) {
        dirs[k] = RayDirection(vc.frame, cone[k]);
      }
      OneRingPrimitives(topo_, p, &excluded);
      scene_->IntersectFan(x, dirs, t_min_f, t_max_f, excluded,
                           absl::MakeSpan(candidates));
      for (int k = 0; k < num_rays; ++k) {
        if (candidates[k].count() > 0) PrefetchPrimitive(candidates[k][0].prim);
      }
      for (int k = 0; k < num_rays; ++k) {
        if (candidates[k].count() > 0) PrefetchCorners(candidates[k][0].prim);
      }
      for (int k = 0; k < num_rays; ++k) {
        prims[k] = PickClosest(*this, candidates[k], x, dirs[k], &t[k]);
        if (!(t[k] <= t_max)) {
          t[k] = kNaN;
          prims[k] = -1;
        }
        if (keep_hits) table[p * num_rays + k] = prims[k];
      }
      traced += num_rays;
      const ConeEstimate est =
          EstimateCone(t, cone, params.kappa, absl::MakeSpan(kept), scratch);
      if (keep_hits) {
        std::copy(kept.begin(), kept.end(), kept_table.begin() + p * num_rays);
      }
      result.hits[p] = est.hits;
      result.kept[p] = est.kept;
      if (est.kept == 0) {
        result.status[p] = VertexStatus::kNoHit;
      } else {
        result.values[p] = est.value;
      }
    }
    rays_traced += traced;
    world_frame_vertices += world_frames;
    gate.Done(range.size());
  };
  const int threads =
      params.threads > 0 ? params.threads : tbb::info::default_concurrency();
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, nv, kVertexBlock), process,
                      tbb::simple_partitioner());
  });
  if (gate.stopped()) return absl::CancelledError("SDF computation cancelled");
  result.trace_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  result.rays_traced = rays_traced;
  result.world_frame_vertices = world_frame_vertices;
  result.normalized = NormalizedSdf(result.values);
  result.missing = CountMissing(mesh_, result.values);
  if (keep_hits) {
    hits->resolved = resolved;
    hits->cone = std::move(cone);
    hits->primitives = std::move(table);
    hits->kept = std::move(kept_table);
    hits->t_min = t_min;
    hits->t_max = t_max;
    hits->generation = generation_;
  }
  return result;
}

absl::Status SdfEvaluator::UpdatePositions(absl::Span<const Vec3> positions) {
  if (std::ssize(positions) != mesh_.num_vertices()) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected ", mesh_.num_vertices(), " positions, got ",
                     positions.size()));
  }
  std::vector<Vec3> old = std::move(mesh_.positions);
  mesh_.positions.assign(positions.begin(), positions.end());
  return CommitPositions(std::move(old));
}

absl::Status SdfEvaluator::UpdatePositions(absl::Span<const int32_t> indices,
                                           absl::Span<const Vec3> positions) {
  std::vector<Vec3> old = mesh_.positions;
  if (absl::Status s = MoveVertices(indices, positions, &mesh_.positions);
      !s.ok()) {
    return s;
  }
  return CommitPositions(std::move(old));
}

absl::Status SdfEvaluator::CommitPositions(std::vector<Vec3> old_positions) {
  if (absl::Status s = ValidateMesh(mesh_); !s.ok()) {
    mesh_.positions = std::move(old_positions);
    return absl::InvalidArgumentError(
        absl::StrCat("position update rejected: ", s.message()));
  }
  const bool rebuild = policy_ == BvhUpdatePolicy::kRebuild ||
                       IsBvhBase(generation_ + 1, rebuild_every_updates_);
  absl::Status s = policy_ == BvhUpdatePolicy::kRefit && rebuild
                       ? RebuildBvh()
                       : scene_->UpdatePositions(mesh_);
  if (!s.ok()) {
    mesh_.positions = std::move(old_positions);
    return absl::Status(
        s.code(), absl::StrCat("position update rejected: ", s.message()));
  }
  if (policy_ == BvhUpdatePolicy::kRebuild) {
    ++builds_;
  } else if (!rebuild) {
    ++refits_;
  }
  RefreshDerivedGeometry();
  ++generation_;
  return absl::OkStatus();
}

}  // namespace meshgauge
