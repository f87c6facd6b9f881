#include "lib/core/sensitivity.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "absl/strings/str_cat.h"
#include "lib/core/control_gate.h"
#include "lib/core/face_sample.h"
#include "lib/core/hit.h"
#include "lib/core/hit_batch.h"
#include "lib/core/inscribed_ball.h"
#include "lib/core/normals.h"
#include "lib/core/sensitivity_row.h"
#include "lib/core/spatial_order.h"
#include "lib/core/thread_count.h"
#include "lib/core/vertex_cone.h"

namespace meshgauge {
namespace {

// Samples per batch: the rows of a batch are computed in parallel while
// the batch before is scattered (into exact sums: deterministic). The two
// batches' rows are reused from batch to batch; small batches keep them in
// cache (horse, 100 rays: VJP 0.23 s with 4096 samples, 0.17 s with 1024;
// with the scatter overlapped, 2^16 row entries by their bounds beat 2^20:
// docs/benchmarks.md).
constexpr int64_t kBatch = 1024;
// At most this many row entries per batch by their bounds (RowEntriesBound;
// 2 MiB of terms): about 200 samples with 100 rays, 21 with 1024.
constexpr int64_t kBatchEntries = int64_t{1} << 16;

// Everything a sample's gradient needs, shared read-only by the workers.
struct Context {
  const MeshGeometry& ev;
  const HitTable& hits;
  bool faces = false;   // face samples (SPEC v2 §5c), else vertices.
  int64_t first = 0;    // the pass's samples: [first, first + samples),
  int64_t samples = 0;  // every vertex or face but for a range's pass.
  // The samples visited, in slots [first, first + slots): every sample in
  // sample order while `order` is empty, else slot first + i holds sample
  // order[i] (a VJP's: those with a nonzero weight).
  int64_t slots = 0;
  std::vector<int32_t> order;

  int64_t Sample(int64_t slot) const {
    return order.empty() ? slot : order[slot - first];
  }
  // Visits the samples in `visit`, in its order, alone.
  void Visit(std::vector<int32_t> visit) {
    order = std::move(visit);
    slots = std::ssize(order);
  }
};

void OriginTerms(const Context& ctx, int64_t p, const Vec3& g_x,
                 SampleRow& terms);
void AxisTerms(const Context& ctx, int64_t p, const VertexCone& vc,
               const Vec3& g_axis, SampleRow& terms);
void SphereTerms(const Context& ctx, int64_t p, const Vec3& x,
                 const VertexCone& vc, SampleRow& terms);

// Adds the terms dSDF_p/dx_j of sample p (a vertex, or a face's centroid)
// to `terms` (cleared first). Leaves it empty when p has no value.
void SampleTerms(const Context& ctx, int64_t p, SampleRow& terms,
                 HitBatch& batch, std::vector<int>& rays) {
  terms.Clear();
  const MeshGeometry& ev = ctx.ev;
  const Mesh& mesh = ev.mesh();
  const MeshTopology& topo = ev.topology();
  const auto& cone = ctx.hits.cone;
  const int num_rays = static_cast<int>(cone.size());
  if (!ctx.faces && topo.vertex_faces.Of(p).empty()) return;
  const bool sphere = ctx.hits.resolved.params.method == SdfMethod::kSphere;
  const SampleCone sample = MakeSampleCone(
      mesh, topo, ctx.hits.resolved.params.samples, p,
      [&] { return UnnormalizedNormal(mesh, topo, p, NormalWeighting::kArea); },
      /*frame=*/!sphere);
  const VertexCone& vc = sample.cone;
  if (!vc.valid) return;
  const Vec3& x = sample.x;
  if (sphere) {
    SphereTerms(ctx, p, x, vc, terms);
    return;
  }
  const auto row = ctx.hits.Row(p);
  // The kept set is frozen in the hit table (SPEC §6): only kept rays are
  // evaluated, in double precision, at the current positions.
  const auto kept_row = ctx.hits.KeptRow(p);
  // The kept rays' primitives' corners and directions first, in a loop of
  // loads alone: their cache misses overlap, which they hardly do in the
  // long loop below. The hits are then evaluated four at a time
  // (hit_batch.h: EvaluateHit's bits).
  batch.Reset(num_rays);
  rays.clear();
  PrimitiveCorners corners;
  for (int k = 0; k < num_rays; ++k) {
    if (!kept_row[k]) continue;
    LoadCorners(mesh, topo.primitives[row[k]], &corners);
    batch.Add(corners, RayDirection(vc.frame, cone[k]), cone[k].weight);
    rays.push_back(k);
  }
  batch.Evaluate(x);
  // A kept ray without a hit cannot happen at the positions of the ray
  // pass; after a move the table's generation no longer matches
  // (MakeContext rejects it).
  double weight_sum = 0;
  for (int i = 0; i < batch.size(); ++i) {
    if (batch.ok(i)) weight_sum += cone[rays[i]].weight;
  }
  if (weight_sum == 0) return;
  batch.Weigh(weight_sum);
  Vec3 d_origin, g_u, g_v, g_a;
  for (int i = 0; i < batch.size(); ++i) {
    if (!batch.ok(i)) continue;
    const ConeRay& ray = cone[rays[i]];
    const HitGeometry h = batch.hit(i);
    // c * m / (d.m), c = weight / weight_sum.
    const Vec3 dt_dx = h.m * batch.scale(i);
    d_origin -= dt_dx;
    const int32_t id = row[rays[i]];
    terms.AddCorners(id, topo.primitives[id],
                     [&](int j) { return dt_dx * h.lambda[j]; });
    const Vec3 g_d = dt_dx * (-h.t);  // c * dt/dd
    g_u += g_d * ray.local.x;
    g_v += g_d * ray.local.y;
    g_a += g_d * ray.local.z;
  }
  // Direction -> frame -> (axis, reference edge e = x_q - x_p); the axis
  // -> n -> N.
  const FrameGradient gf = FrameVjp(mesh.dimension, vc.frame, g_u, g_v);
  if (vc.frame.reference >= 0) {
    d_origin -= gf.edge;
    terms.Add(vc.frame.reference, gf.edge);
  }
  OriginTerms(ctx, p, d_origin, terms);
  AxisTerms(ctx, p, vc, g_a + gf.axis, terms);
}

// The terms of the inscribed ball (SPEC v2 §5b): T_p = 2 r with r the
// touching primitive's closed form (both frozen in the hit table: the
// primitive, and the form + 1 as its kept flag), differentiated through
// x_p, the axis and the primitive's corners.
void SphereTerms(const Context& ctx, int64_t p, const Vec3& x,
                 const VertexCone& vc, SampleRow& terms) {
  const int32_t prim = ctx.hits.Row(p)[0];
  if (prim < 0) return;
  const MeshGeometry& ev = ctx.ev;
  const int kind = ctx.hits.KeptRow(p)[0] - 1;
  const BallGradient g = TangentBallGradient(
      ev.Corners(prim), x, vc.axis(), ctx.hits.resolved.contact_cosine, kind);
  OriginTerms(ctx, p, g.x * 2, terms);
  const Primitive& corners = ev.topology().primitives[prim];
  for (int j = 0; j < 3 && corners.v[j] >= 0; ++j) {
    terms.Add(corners.v[j], g.corner[j] * 2);
  }
  AxisTerms(ctx, p, vc, g.axis * 2, terms);
}

// Adds the terms of g_x . d x / dx_j for the sample's point: the vertex
// itself, or the mean of the face's corners.
void OriginTerms(const Context& ctx, int64_t p, const Vec3& g_x,
                 SampleRow& terms) {
  if (!ctx.faces) {
    terms.Add(static_cast<int32_t>(p), g_x);
    return;
  }
  const Face& face = ctx.ev.mesh().faces[p];
  for (int k = 0; k < face.size; ++k) {
    terms.Add(face.v[k], g_x / face.size);
  }
}

// Adds the terms of g_axis . d axis / dx: axis = sign n, n = N/|N|,
// N the sum over the primitives of vertex p (SPEC §2) or of face p.
void AxisTerms(const Context& ctx, int64_t p, const VertexCone& vc,
               const Vec3& g_axis, SampleRow& terms) {
  const Mesh& mesh = ctx.ev.mesh();
  const MeshTopology& topo = ctx.ev.topology();
  const Vec3 g_n = g_axis * vc.sign;
  const Vec3 g_big_n = (g_n - vc.n * Dot(vc.n, g_n)) / vc.normal_length;
  Vec3 grad[3];
  auto add = [&](int32_t prim_id) {
    const Primitive& prim = topo.primitives[prim_id];
    PrimitiveNormalVjp(mesh, prim, g_big_n, grad);
    for (int j = 0; j < 3 && prim.v[j] >= 0; ++j) {
      terms.Add(prim.v[j], grad[j]);
    }
  };
  if (ctx.faces) {
    const auto [first, count] = topo.PrimitiveRangeOfFace(p);
    for (int32_t q = first; q < first + count; ++q) add(q);
  } else {
    for (int32_t q : topo.PrimitivesOf(p)) add(q);
  }
}

// Starts loading every primitive sample p's rays hit (two samples ahead of
// SampleTerms), or their corners (one sample ahead), so they are in cache
// when SampleTerms(p) runs.
void PrefetchPrimitives(const Context& ctx, int64_t p) {
  for (int32_t prim : ctx.hits.Row(p)) {
    if (prim >= 0) ctx.ev.PrefetchPrimitive(prim);
  }
}
void PrefetchCorners(const Context& ctx, int64_t p) {
  for (int32_t prim : ctx.hits.Row(p)) {
    if (prim >= 0) ctx.ev.PrefetchCorners(prim);
  }
}

absl::StatusOr<Context> MakeContext(const MeshGeometry& ev,
                                    const HitTable& table) {
  const HitTable* hits = &table;
  const bool faces = hits->resolved.params.samples == SampleSet::kFaces;
  auto range = ResolveRange(ev.mesh(), hits->resolved.params);
  if (!range.ok()) return range.status();
  const int64_t samples = range->end - range->begin;
  if (hits->generation != ev.generation() ||
      std::ssize(hits->primitives) != samples * std::ssize(hits->cone)) {
    return absl::FailedPreconditionError(absl::StrCat(
        "sensitivities need the hit table of a ray pass at the current "
        "positions (generation ",
        ev.generation(), "), got one from generation ", hits->generation));
  }
  if (!faces &&
      hits->resolved.params.normal_weighting != NormalWeighting::kArea) {
    return absl::FailedPreconditionError(
        "sensitivities are only available with area-weighted normals; "
        "recompute with area weighting (--normals area, the default)");
  }
  return Context{ev, *hits, faces, range->begin, samples, samples, {}};
}

// An upper bound on the entries of sample p's row: the corners of the
// primitive each kept ray hit (or the ball's), the frame's reference edge,
// and the vertices of the sample's point and axis: the face's corners, or
// the vertex and the other corners of its primitives.
int64_t RowEntriesBound(const Context& ctx, int64_t p) {
  const Mesh& mesh = ctx.ev.mesh();
  const int corners = mesh.dimension == 3 ? 3 : 2;
  int64_t hit = 0;
  if (ctx.hits.resolved.params.method == SdfMethod::kSphere) {
    hit = ctx.hits.Row(p)[0] >= 0;
  } else {
    for (uint8_t k : ctx.hits.KeptRow(p)) hit += k != 0;
  }
  const int64_t around =
      ctx.faces
          ? mesh.faces[p].size
          : 1 + (corners - 1) * std::ssize(ctx.ev.topology().PrimitivesOf(p));
  return std::min<int64_t>(mesh.num_vertices(), corners * hit + around + 1);
}

// The sum of RowEntriesBound over every sample.
int64_t EntriesBound(const Context& ctx) {
  int64_t entries = 0;
  for (int64_t p = ctx.first; p < ctx.first + ctx.samples; ++p) {
    entries += RowEntriesBound(ctx, p);
  }
  return entries;
}

// The samples whose weight in g (one per sample, from first) is nonzero,
// along a Morton curve of their points (vertices: the geometry's order;
// faces' centroids: sorted here): neighbouring samples' rays hit
// neighbouring primitives, so visited in this order their corners and their
// vertices' sums are mostly in cache. For the VJP, whose exact sums do not
// depend on the order, and to which a sample of weight 0 adds nothing (a
// one-sided penalty's weights are 0 away from its thin parts).
std::vector<int32_t> VisitingOrder(const Context& ctx,
                                   absl::Span<const double> g,
                                   const ComputeControl& control) {
  const int64_t first = ctx.first;
  auto weighted = [&](int64_t p) { return g[p - first] != 0; };
  if (!ctx.faces) {
    return ctx.ev.VerticesInOrder(first, first + ctx.samples, weighted);
  }
  std::vector<int32_t> faces;
  for (int64_t f = first; f < first + ctx.samples; ++f) {
    if (weighted(f)) faces.push_back(static_cast<int32_t>(f));
  }
  std::vector<Vec3> centroids(faces.size());
  for (size_t k = 0; k < faces.size(); ++k) {
    centroids[k] = FaceCentroid(ctx.ev.mesh(), faces[k]);
  }
  tbb::task_arena arena(ThreadCount(control.threads));
  const std::vector<int32_t> morton =
      arena.execute([&] { return MortonOrder(centroids); });
  std::vector<int32_t> order(faces.size());
  for (size_t k = 0; k < faces.size(); ++k) order[k] = faces[morton[k]];
  return order;
}

// The rows of the slots [begin, end) (ctx.Sample(slot) is the slot's
// sample): rows[slot - begin] is its sample's (the vectors are reused from
// batch to batch and keep their capacity).
struct Batch {
  int64_t begin = 0, end = 0;
  std::vector<std::vector<RowTerm>> rows;
};

// Computes the terms of each slot's sample, a batch at a time in parallel (at
// most kBatch samples and, but for a single sample, kBatchEntries of their
// rows' bounds, so that the rows' memory is bounded whatever the ray
// count), and hands each batch to consume(batch), one batch after the
// other in the order of ctx's slots, each while the next batch is computed.
// control.progress follows the consumed batches (ControlGate: at most once
// a percent).
template <typename Consume>
absl::Status ForEachBatch(const Context& ctx, const ComputeControl& control,
                          Consume consume) {
  if (absl::Status s = ValidateControl(control); !s.ok()) return s;
  const int64_t ns = ctx.first + ctx.slots;  // the end of the slots.
  const size_t num_rays = ctx.hits.cone.size();
  if (ctx.slots == 0) {  // nothing to compute (a VJP's weights all 0).
    return control.cancelled && control.cancelled()
               ? absl::CancelledError("sensitivity computation cancelled")
               : absl::OkStatus();
  }
  ControlGate gate(control, ctx.slots);
  // Double-buffered: batch[computing] is filled while the other is consumed.
  Batch batch[2];
  int computing = 0;
  tbb::task_arena arena(ThreadCount(control.threads));
  // One SampleRow per thread slot of the arena (at most its concurrency),
  // each on its own cache lines (its vector's end moves with every new
  // entry).
  struct alignas(64) ThreadRow {
    std::optional<SampleRow> row;
  };
  std::vector<ThreadRow> thread_rows(arena.max_concurrency());
  auto compute = [&] {
    Batch& b = batch[computing];
    tbb::parallel_for(
        tbb::blocked_range<int64_t>(b.begin, b.end, 64),
        [&](const tbb::blocked_range<int64_t>& r) {
          HitBatch hit_batch;
          std::vector<int> rays;
          rays.reserve(num_rays);
          std::optional<SampleRow>& row =
              thread_rows[tbb::this_task_arena::current_thread_index()].row;
          if (!row) row.emplace();
          PrefetchPrimitives(ctx, ctx.Sample(r.begin()));
          if (r.size() > 1) PrefetchPrimitives(ctx, ctx.Sample(r.begin() + 1));
          PrefetchCorners(ctx, ctx.Sample(r.begin()));
          for (int64_t slot = r.begin(); slot < r.end(); ++slot) {
            if (slot + 2 < r.end()) {
              PrefetchPrimitives(ctx, ctx.Sample(slot + 2));
            }
            if (slot + 1 < r.end()) PrefetchCorners(ctx, ctx.Sample(slot + 1));
            SampleTerms(ctx, ctx.Sample(slot), *row, hit_batch, rays);
            row->TakeTerms(b.rows[slot - b.begin]);
          }
        });
  };
  auto consume_ready = [&] {
    Batch& b = batch[computing ^ 1];
    if (b.end == b.begin) return;
    consume(b);
    gate.Done(b.end - b.begin);
  };
  for (int64_t begin = ctx.first, end = 0; begin < ns; begin = end) {
    if (!gate.Poll()) {
      return absl::CancelledError("sensitivity computation cancelled");
    }
    int64_t entries = 0;
    for (end = begin; end < ns && end - begin < kBatch; ++end) {
      entries += RowEntriesBound(ctx, ctx.Sample(end));
      if (end > begin && entries > kBatchEntries) break;
    }
    Batch& b = batch[computing];
    b.begin = begin;
    b.end = end;
    if (std::ssize(b.rows) < end - begin) b.rows.resize(end - begin);
    arena.execute([&] { tbb::parallel_invoke(compute, consume_ready); });
    computing ^= 1;
  }
  consume_ready();
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<SparseJacobian> ComputeJacobian(const MeshGeometry& geometry,
                                               const HitTable& hits,
                                               const ComputeControl& control) {
  auto ctx = MakeContext(geometry, hits);
  if (!ctx.ok()) return ctx.status();
  SparseJacobian jac;
  const int64_t bound = EntriesBound(*ctx);
  jac.columns.reserve(bound);
  jac.values.reserve(bound);
  jac.row_offsets.reserve(ctx->samples + 1);
  jac.row_offsets.push_back(0);
  // No visiting order: the slots are the samples, so the rows go in sample
  // order.
  absl::Status s = ForEachBatch(*ctx, control, [&jac](Batch& batch) {
    for (int64_t p = batch.begin; p < batch.end; ++p) {
      std::vector<RowTerm>& terms = batch.rows[p - batch.begin];
      std::sort(terms.begin(), terms.end(),
                [](const RowTerm& a, const RowTerm& b) {
                  return a.vertex < b.vertex;
                });
      for (const RowTerm& t : terms) {
        jac.columns.push_back(t.vertex);
        jac.values.push_back(t.d);
      }
      jac.row_offsets.push_back(jac.nonzeros());
    }
  });
  if (!s.ok()) return s;
  return jac;
}

absl::StatusOr<int64_t> JacobianBytesBound(const MeshGeometry& geometry,
                                           const HitTable& hits) {
  auto ctx = MakeContext(geometry, hits);
  if (!ctx.ok()) return ctx.status();
  return EntriesBound(*ctx) *
             static_cast<int64_t>(sizeof(int32_t) + sizeof(Vec3)) +
         (ctx->samples + 1) * static_cast<int64_t>(sizeof(int64_t));
}

absl::StatusOr<ExactSums> ComputeVjpSums(
    const MeshGeometry& geometry, const HitTable& hits,
    absl::Span<const double> g, const ComputeControl& control) {
  const int64_t nv = geometry.mesh().num_vertices();
  auto ctx = MakeContext(geometry, hits);
  if (!ctx.ok()) return ctx.status();
  const int64_t ns = ctx->samples;
  const int64_t first = ctx->first;
  const char* sample = SampleName(hits.resolved.params.samples);
  if (std::ssize(g) != ns) {
    return absl::InvalidArgumentError(
        absl::StrCat("VJP weights must have one value per ", sample,
                     hits.resolved.params.range.all() ? "" : " of the range",
                     ": expected ", ns, ", got ", g.size()));
  }
  for (int64_t i = 0; i < ns; ++i) {
    if (!std::isfinite(g[i])) {
      return absl::InvalidArgumentError(absl::StrCat(
          "VJP weight of ", sample, " ", first + i, " is not finite"));
    }
  }
  if (absl::Status s = ValidateControl(control); !s.ok()) return s;
  ctx->Visit(VisitingOrder(*ctx, g, control));
  ExactSums out(3 * nv);
  // Each batch is scattered by one task while the next is computed; the
  // sums are exact, so neither the order nor the threads change them.
  absl::Status s = ForEachBatch(*ctx, control, [&](Batch& batch) {
    for (int64_t slot = batch.begin; slot < batch.end; ++slot) {
      const double gp = g[ctx->Sample(slot) - first];
      out.AddScaledTerms(batch.rows[slot - batch.begin], gp);
    }
  });
  if (!s.ok()) return s;
  return out;
}

std::vector<Vec3> RoundVectors(const ExactSums& xyz) {
  std::vector<Vec3> out(xyz.size() / 3);
  for (int64_t j = 0; j < std::ssize(out); ++j) {
    out[j] = {xyz.Round(3 * j), xyz.Round(3 * j + 1), xyz.Round(3 * j + 2)};
  }
  return out;
}

absl::StatusOr<std::vector<Vec3>> ComputeVjp(const MeshGeometry& geometry,
                                             const HitTable& hits,
                                             absl::Span<const double> g,
                                             const ComputeControl& control) {
  auto sums = ComputeVjpSums(geometry, hits, g, control);
  if (!sums.ok()) return sums.status();
  return RoundVectors(*sums);
}

}  // namespace meshgauge
