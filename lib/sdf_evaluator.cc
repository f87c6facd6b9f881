#include "lib/sdf_evaluator.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>

#include "absl/strings/str_cat.h"
#include "lib/estimator.h"
#include "lib/hit.h"
#include "lib/normalized_sdf.h"
#include "lib/vertex_cone.h"

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

}  // namespace

absl::StatusOr<std::unique_ptr<SdfEvaluator>> SdfEvaluator::Create(
    Mesh mesh, const EvaluatorOptions& options) {
  if (absl::Status s = ValidateMesh(mesh); !s.ok()) return s;
  std::unique_ptr<SdfEvaluator> ev(new SdfEvaluator());
  ev->mesh_ = std::move(mesh);
  ev->topo_ = MeshTopology::Build(ev->mesh_);
  ev->mean_edge_length_ = MeanEdgeLength(ev->mesh_);
  ev->bbox_diagonal_ = BoundingBoxDiagonal(ev->mesh_);
  auto scene = RayScene::Create(ev->mesh_, ev->topo_, options.bvh_policy);
  if (!scene.ok()) return scene.status();
  ev->scene_ = std::move(*scene);
  return ev;
}

absl::StatusOr<SdfResult> SdfEvaluator::Compute(const SdfParams& params,
                                                const ComputeControl& control,
                                                bool keep_hits) {
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
  hits_.generation = -1;
  std::vector<int32_t> table;
  if (keep_hits) table.assign(nv * num_rays, -1);

  ControlGate gate(control, nv);
  std::atomic<int64_t> rays_traced{0};
  const auto start = std::chrono::steady_clock::now();
  const float t_min_f = static_cast<float>(t_min);
  // Slightly beyond t_max so the double-precision check below decides.
  const float t_max_f = std::nextafter(static_cast<float>(t_max),
                                       std::numeric_limits<float>::max());
  auto process = [&](const tbb::blocked_range<int64_t>& range) {
    if (!gate.Poll()) return;
    std::vector<double> t(num_rays);
    std::vector<uint8_t> kept(num_rays);
    std::vector<double> scratch;
    scratch.reserve(num_rays);
    int64_t traced = 0;
    for (int64_t p = range.begin(); p < range.end(); ++p) {
      const auto one_ring = topo_.vertex_faces.Of(p);
      if (one_ring.empty()) {
        result.status[p] = VertexStatus::kNoFaces;
        continue;
      }
      const VertexCone vc = MakeVertexCone(mesh_.dimension, normals[p],
                                           topo_.vertex_direction[p]);
      if (!vc.valid) {
        result.status[p] = VertexStatus::kDegenerateNormal;
        continue;
      }
      const Vec3& x = mesh_.positions[p];
      for (int k = 0; k < num_rays; ++k) {
        const Vec3 d = RayDirection(vc.frame, cone[k]);
        int32_t prim = scene_->Trace(x, d, t_min_f, t_max_f, one_ring);
        HitGeometry hg;
        if (prim >= 0 &&
            !(EvaluateHit(mesh_, topo_.primitives[prim], x, d, &hg) &&
              hg.t <= t_max)) {
          prim = -1;
        }
        t[k] = prim >= 0 ? hg.t : kNaN;
        if (keep_hits) table[p * num_rays + k] = prim;
      }
      traced += num_rays;
      const ConeEstimate est =
          EstimateCone(t, cone, params.kappa, absl::MakeSpan(kept), scratch);
      result.hits[p] = est.hits;
      result.kept[p] = est.kept;
      if (est.kept == 0) {
        result.status[p] = VertexStatus::kNoHit;
      } else {
        result.values[p] = est.value;
      }
    }
    rays_traced += traced;
    gate.Done(range.size());
  };
  const int threads =
      params.threads > 0 ? params.threads : tbb::info::default_concurrency();
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, nv, kVertexBlock),
                      process, tbb::simple_partitioner());
  });
  if (gate.stopped()) return absl::CancelledError("SDF computation cancelled");
  result.trace_seconds = std::chrono::duration<double>(
                             std::chrono::steady_clock::now() - start)
                             .count();
  result.rays_traced = rays_traced;
  result.normalized = NormalizedSdf(result.values);
  if (keep_hits) {
    hits_.resolved = resolved;
    hits_.cone = std::move(cone);
    hits_.primitives = std::move(table);
    hits_.t_min = t_min;
    hits_.t_max = t_max;
    hits_.generation = generation_;
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
  if (indices.size() != positions.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("got ", indices.size(), " indices but ",
                     positions.size(), " positions"));
  }
  std::vector<uint8_t> seen(mesh_.positions.size(), 0);
  for (size_t i = 0; i < indices.size(); ++i) {
    const int32_t v = indices[i];
    if (v < 0 || v >= mesh_.num_vertices()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "vertex index ", v, " at position ", i, " is out of range [0, ",
          mesh_.num_vertices(), ")"));
    }
    if (seen[v]++) {
      return absl::InvalidArgumentError(
          absl::StrCat("vertex index ", v, " is repeated in the update"));
    }
  }
  std::vector<Vec3> old = mesh_.positions;
  for (size_t i = 0; i < indices.size(); ++i) {
    mesh_.positions[indices[i]] = positions[i];
  }
  return CommitPositions(std::move(old));
}

absl::Status SdfEvaluator::CommitPositions(std::vector<Vec3> old_positions) {
  if (absl::Status s = ValidateMesh(mesh_); !s.ok()) {
    mesh_.positions = std::move(old_positions);
    return absl::InvalidArgumentError(
        absl::StrCat("position update rejected: ", s.message()));
  }
  if (absl::Status s = scene_->UpdatePositions(mesh_); !s.ok()) return s;
  mean_edge_length_ = MeanEdgeLength(mesh_);
  bbox_diagonal_ = BoundingBoxDiagonal(mesh_);
  ++generation_;
  return absl::OkStatus();
}

}  // namespace meshgauge
