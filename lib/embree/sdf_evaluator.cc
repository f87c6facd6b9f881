#include "lib/embree/sdf_evaluator.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

#include "absl/base/attributes.h"
#include "absl/strings/str_cat.h"
#include "lib/core/control_gate.h"
#include "lib/core/estimator.h"
#include "lib/core/face_sample.h"
#include "lib/core/hit.h"
#include "lib/core/normalized_sdf.h"
#include "lib/core/stopwatch.h"
#include "lib/core/thread_count.h"
#include "lib/core/vertex_cone.h"
#include "lib/embree/inscribed_ball_query.h"
#include "lib/embree/moved_boxes.h"
#include "lib/embree/pass_state.h"
#include "lib/embree/ray_start.h"
#include "lib/embree/traversal_choice.h"

namespace meshgauge {
namespace {

constexpr int64_t kVertexBlock = 64;
// A pass starts rays past empty balls when it traces at least this many
// rays a primitive and this many rays in all (ray_start.h): below them
// the tree's build and its walk per sample cost more than the starts saved
// (the knight, 50,200 rays, and the tray, 221,600, were 0.87 and 0.77
// times as fast with them, mostly for the walks; spot, 293,000, 1.15
// times as fast).
constexpr int64_t kStartsPerPrimitive = 8;
constexpr int64_t kStartsMinRays = int64_t{1} << 18;
// In an incremental pass that starts rays past balls, an unmoved sample
// looks for its ball only when it retraces at least this many rays: the
// walk of the tree costs about as much as starting ten rays past it saves
// (an estimate from igea's run in docs/benchmarks.md and a profile: the walk
// is about 1 us of a sample's thread time, a start saves about 0.1 us a
// ray).
constexpr size_t kStartsMinRetraced = 16;
// kAuto counts an incremental pass's rays as this many times its moved
// samples' rays: it retraces rays in the unmoved samples whose cones see
// the moved patch too, 0.5 to 2.0 times as many
// (meshgauge_incremental_bench on igea, rocker-arm and horse).
constexpr int64_t kIncrementalRaysPerMovedRay = 2;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Where a ray meets a primitive's plane: the distance t and how far the
// point lies inside the primitive (in its plane, the smallest distance to
// an edge; negative outside).
struct PlaneHit {
  double t, inside;
};
bool HitPlane(const PrimitiveCorners& pc, const Vec3& x, const Vec3& d,
              PlaneHit* out) {
  HitGeometry h;
  if (!EvaluateHit(pc, x, d, &h)) return false;
  out->t = h.t;
  if (pc.segment) {
    const double length = std::sqrt(Dot(h.m, h.m));
    out->inside = std::min(h.lambda[0], h.lambda[1]) * length;
    return true;
  }
  // lambda_i times the altitude over the edge opposite corner i.
  const double area2 = std::sqrt(Dot(h.m, h.m));
  const Vec3 corner[3] = {pc.a, pc.b, pc.c};
  out->inside = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    const Vec3 e = corner[(i + 2) % 3] - corner[(i + 1) % 3];
    out->inside =
        std::min(out->inside, h.lambda[i] * area2 / std::sqrt(Dot(e, e)));
  }
  return true;
}

constexpr double kNearHitMargin = 16;

// The hit of a ray among its candidates (SPEC §3, §4), in double
// precision: a primitive that contains the hit point before one that does
// not, then the smallest distance, then the lower primitive index. Where
// Embree hit a candidate near its boundary (HitCandidates::Entry::edge),
// the primitives around its corners are candidates too when the ray meets
// them within `slack` of their boundary and within `slack` of the closest
// candidate's distance (slack = 2^-16 of the coordinates' magnitude,
// `reach` + t): then the pick does not depend on which side of a shared
// edge Embree's single-precision test put the ray (it may differ between
// BVHs). A distance that is not a positive number (a ray along the
// primitive's plane) is picked only when no candidate has one. -1 when there
// is no candidate; `t` receives the distance (NaN for none).
int32_t PickClosest(const MeshGeometry& g, const HitCandidates& c,
                    absl::Span<const int32_t> excluded, double t_min,
                    double reach, const Vec3& x, const Vec3& d,
                    std::vector<int32_t>* around, double* t) {
  // The common case: one candidate, well inside.
  if (c.count() == 1 && !c[0].edge) {
    *t = HitDistance(g.Corners(c[0].prim), x, d);
    return c[0].prim;
  }
  int32_t best = -1;
  bool best_inside = false;
  *t = kNaN;
  // Each candidate's distance (NaN: none), for the neighbours below.
  std::array<double, HitCandidates::kMax> distance;
  auto consider = [&](int32_t prim, double ti, bool inside) {
    bool better = best < 0;
    if (!better && !std::isnan(ti)) {
      if (std::isnan(*t) || inside != best_inside) {
        better = std::isnan(*t) || inside;
      } else {
        better = ti < *t || (ti == *t && prim < best);
      }
    }
    if (better) {
      best = prim;
      best_inside = inside;
      *t = ti;
    }
  };
  around->clear();
  double closest = std::numeric_limits<double>::infinity();
  bool any_edge = false;
  for (int i = 0; i < c.count(); ++i) {
    PlaneHit h;
    distance[i] = kNaN;
    any_edge |= c[i].edge;
    if (!HitPlane(g.Corners(c[i].prim), x, d, &h)) {
      consider(c[i].prim, kNaN, false);
      continue;
    }
    distance[i] = h.t;
    consider(c[i].prim, h.t, h.inside >= 0);
    closest = std::min(closest, h.t);
  }
  if (!any_edge) return best;
  const double slack = (reach + closest) * 0x1p-16;
  for (int i = 0; i < c.count(); ++i) {
    if (!c[i].edge) continue;
    // Where the ray could pass within slack of another primitive: near an
    // edge or a corner of this one, with a margin (kNearHitMargin) for the
    // distance's change between the primitives on either side of an edge,
    // so that the set does not depend on which one Embree reported.
    const double ti = std::isnan(distance[i]) ? closest : distance[i];
    AppendPrimitivesNear(g.topology(), g.mesh(), c[i].prim, x + d * ti,
                         kNearHitMargin * slack, around);
  }
  if (around->empty()) return best;
  std::sort(around->begin(), around->end());
  around->erase(std::unique(around->begin(), around->end()), around->end());
  for (int32_t q : *around) {
    if (std::binary_search(excluded.begin(), excluded.end(), q)) continue;
    bool listed = false;
    for (int i = 0; i < c.count(); ++i) listed |= c[i].prim == q;
    PlaneHit h;
    if (listed || !HitPlane(g.Corners(q), x, d, &h)) continue;
    if (h.t >= t_min && std::abs(h.t - closest) <= slack &&
        h.inside >= -slack) {
      consider(q, h.t, h.inside >= 0);
    }
  }
  return best;
}

// SPEC §4 ignores hits closer than t_min, in double precision, while
// Embree's filter decides in single precision (FanFilter): a primitive
// passing through x or just beyond it (a coincident or touching surface)
// may get a single-precision distance past limits.t_min and a
// double-precision one below t_min. Such candidates of one ray are dropped
// and the ray traced again without them, until its candidates are all at
// t_min or beyond: otherwise the ray would keep a distance of about 0, or
// (a distance not positive) none, instead of the surface behind. Only
// candidates within 2^-16 of the coordinates' magnitude past limits.t_min
// (HitCandidates' window, far wider than single-precision rounding) can be
// below t_min, and they mark the ray near() (RayScene::NearBelow), so a
// ray that is not near() needs no look. Not inlined: the pass's loop ran
// about 1 % slower on horse with it inlined. `dropped`, `merged`: scratch.
ABSL_ATTRIBUTE_NOINLINE void DropHitsBelowTMin(
    const MeshGeometry& g, const RayScene& scene, const Vec3& x, const Vec3& d,
    double t_min, const RayScene::FanLimits& limits,
    absl::Span<const int32_t> excluded, HitCandidates* c,
    std::vector<int32_t>* dropped, std::vector<int32_t>* merged) {
  const float suspect_below = RayScene::NearBelow(
      limits, static_cast<float>(MaxAbs(x - scene.origin())));
  dropped->clear();
  for (;;) {
    const size_t before = dropped->size();
    for (int i = 0; i < c->count() && (*c)[i].t < suspect_below; ++i) {
      // A ray along the plane (NaN) is left as it is.
      if (PlaneDistance(g.Corners((*c)[i].prim), x, d) < t_min) {
        dropped->push_back((*c)[i].prim);
      }
    }
    if (dropped->size() == before) return;
    merged->assign(excluded.begin(), excluded.end());
    merged->insert(merged->end(), dropped->begin(), dropped->end());
    std::sort(merged->begin(), merged->end());
    scene.IntersectFan(x, absl::MakeConstSpan(&d, 1), limits, *merged,
                       absl::MakeSpan(c, 1));
  }
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
  ev->ray_test_ = options.ray_test;
  ev->ray_start_ = options.ray_start;
  ev->fan_traversal_ = options.fan_traversal;
  ev->rebuild_every_updates_ = options.rebuild_every_updates;
  ev->generation_ = options.generation;
  if (absl::Status s = ev->RebuildBvh(); !s.ok()) return s;
  return ev;
}

bool IsBvhBase(int64_t generation, int rebuild_every_updates) {
  return rebuild_every_updates > 0 && generation % rebuild_every_updates == 0;
}

absl::Status SdfEvaluator::RebuildBvh() {
  auto scene = RayScene::Create(mesh_, topo_, policy_, ray_test_);
  if (!scene.ok()) return scene.status();
  scene_ = std::move(*scene);
  ++builds_;
  return absl::OkStatus();
}

// What an incremental pass reuses and what it must retrace (SPEC 2.1 §3:
// the result is the full pass's, bit for bit; docs/numerics.md,
// "Incremental passes").
struct SdfEvaluator::ReusePlan {
  const SdfResult* result = nullptr;
  const HitTable* hits = nullptr;
  // Vertices whose cone (position, normal, frame) may have changed: every
  // corner of a face with a moved vertex.
  std::vector<uint8_t> dirty;
  std::vector<uint8_t> moved_primitive;
  std::unique_ptr<MovedBoxes> boxes;
  // A sphere around the boxes (tracer coordinates); radius 0 for none.
  Vec3 sphere_centre;
  double sphere_radius = 0;
  bool t_min_changed = false, t_max_changed = false;
  double t_max_both = 0;  // min of the old and new miss distances.
};

absl::StatusOr<std::unique_ptr<SdfEvaluator::ReusePlan>>
SdfEvaluator::PlanReuse(const PreviousPass& previous,
                        const std::vector<ConeRay>& cone,
                        const ResolvedParams& resolved, bool walks_cones,
                        float t_near, double t_min, double t_max) const {
  const HitTable& h = *previous.hits;
  const SdfResult& r = *previous.result;
  const int64_t nv = mesh_.num_vertices();
  const bool same_rays =
      h.resolved.params == resolved.params && h.cone.size() == cone.size() &&
      std::ssize(h.positions) == nv && std::ssize(h.near) == nv &&
      std::ssize(r.values) == nv &&
      std::ssize(h.primitives) == nv * std::ssize(cone) &&
      h.num_primitives == std::ssize(topo_.primitives) &&
      h.scene_origin == scene_->origin() &&
      h.extrude_half_height == scene_->extrude_half_height() &&
      h.t_near == t_near && h.walks_cones == walks_cones;
  if (!same_rays) return nullptr;
  auto plan = std::make_unique<ReusePlan>();
  plan->result = &r;
  plan->hits = &h;
  std::vector<int32_t> moved;
  for (int64_t v = 0; v < nv; ++v) {
    if (std::memcmp(&h.positions[v], &mesh_.positions[v], sizeof(Vec3)) != 0) {
      moved.push_back(static_cast<int32_t>(v));
    }
  }
  // Beyond half the vertices a full pass costs less than the checks.
  if (2 * std::ssize(moved) > nv) return nullptr;
  plan->dirty = CornersOfFacesAround(topo_, mesh_, moved);
  plan->moved_primitive.assign(topo_.primitives.size(), 0);
  for (int32_t v : moved) {
    for (int32_t q : topo_.PrimitivesOf(v)) {
      plan->moved_primitive[q] = 1;
    }
  }
  // Each moved primitive's corners before and after, in the tracer's
  // coordinates, enlarged by far more than single-precision rounding.
  const Vec3& o = scene_->origin();
  double reach = bbox_diagonal_;
  for (const Vec3& p : mesh_.positions) reach = std::max(reach, MaxAbs(p - o));
  // 4 times the most PickClosest lets a neighbour's plane hit lie outside it.
  const double slack = reach * 0x1p-14;
  const double z = mesh_.dimension == 2 ? scene_->extrude_half_height() : 0;
  const Vec3 extrusion(0, 0, z), enlarged(slack, slack, slack);
  std::vector<Box> boxes;
  Box all;
  for (size_t q = 0; q < plan->moved_primitive.size(); ++q) {
    if (!plan->moved_primitive[q]) continue;
    Box b;
    for (int32_t v : topo_.primitives[q].v) {
      if (v < 0) continue;
      for (const Vec3* p : {&h.positions[v], &mesh_.positions[v]}) {
        b.Extend(*p - o - extrusion, *p - o + extrusion);
      }
    }
    b.lo = b.lo - enlarged;
    b.hi = b.hi + enlarged;
    boxes.push_back(b);
    // The sphere around them all (in 2D in the rays' plane z = 0).
    all.Extend(b.lo + extrusion, b.hi - extrusion);
  }
  if (!boxes.empty()) {
    plan->sphere_centre = (all.lo + all.hi) * 0.5;
    const Vec3 half = (all.hi - all.lo) * 0.5;
    plan->sphere_radius = std::sqrt(Dot(half, half));
  }
  auto made = MovedBoxes::Create(std::move(boxes));
  if (!made.ok()) return made.status();
  plan->boxes = std::move(*made);
  // Hits are dropped below t_min in double precision (DropHitsBelowTMin).
  plan->t_min_changed = h.t_min != t_min;
  plan->t_max_changed = h.t_max != t_max;
  plan->t_max_both = std::min(h.t_max, t_max);
  return plan;
}

void SdfEvaluator::RaysToRetrace(
    const ReusePlan& plan, int64_t p, const Vec3& x, const Vec3& axis,
    double cone_half_angle, double reach, float t_far,
    absl::FunctionRef<void()> directions, absl::Span<const Vec3> dirs,
    absl::Span<int32_t> prims, absl::Span<double> t,
    std::vector<int32_t>* retrace) const {
  const int32_t* old_row = plan.hits->Row(p).data();
  const int num_rays = static_cast<int>(prims.size());
  // Can the cone reach the moved primitives' boxes at all?
  const Vec3 to = plan.sphere_centre - (x - scene_->origin());
  const double dist = std::sqrt(Dot(to, to));
  const double radius = plan.sphere_radius;
  bool cone_reaches = radius > 0;
  if (cone_reaches && dist > radius) {
    const double axis_angle =
        std::acos(std::clamp(Dot(axis, to) / dist, -1.0, 1.0));
    cone_reaches =
        axis_angle <= cone_half_angle + std::asin(radius / dist) + 1e-6;
  }
  // Far from every moved primitive: only a moved hit changes.
  const bool only_moved_hits = !cone_reaches && !plan.t_max_changed;
  if (!only_moved_hits) directions();
  for (int k = 0; k < num_rays; ++k) {
    const int32_t q = old_row[k];
    prims[k] = q;
    bool again = q >= 0 && plan.moved_primitive[q];
    if (only_moved_hits) {
      if (again) retrace->push_back(k);
      continue;
    }
    double t_end = t_far;
    if (!again && q >= 0) {
      t[k] = HitDistance(Corners(q), x, dirs[k]);
      t_end = t[k] + (reach + t[k]) * 0x1p-12;
      again = plan.t_max_changed && !(t_end < plan.t_max_both);
    } else if (!again) {
      again = plan.t_max_changed;
    }
    if (!again && cone_reaches) {
      again = plan.boxes->Crosses(x - scene_->origin(), dirs[k], t_end);
    }
    if (again) retrace->push_back(k);
  }
}

using pass_state::MakePassSample;
using pass_state::NewOutput;
using pass_state::PassOutput;
using pass_state::PassSetup;
using pass_state::SampleRows;
using pass_state::SampleScratch;
using pass_state::SetUpPass;

// The work of one pass on one sample (SPEC §3-5): its cone, its rays (or
// ball) and its value, written to the pass's output. Workers call Sample
// for disjoint samples concurrently.
class SdfEvaluator::SampleTracer {
 public:
  // `starts`: null, or the rays' starts past an empty ball over
  // `ball_tree` (then not null).
  SampleTracer(const SdfEvaluator& ev, const PassSetup& setup,
               const ReusePlan* plan, const BallTree* ball_tree,
               const RayStarts* starts, FanTraversal traversal, PassOutput* out)
      : ev_(ev),
        setup_(setup),
        params_(setup.resolved.params),
        plan_(plan),
        ball_tree_(ball_tree),
        starts_(starts),
        traversal_(traversal),
        out_(*out) {}

  // Sample i of the pass's visiting order `visit` (vertices in Morton
  // order), or face range.begin + i.
  void Sample(int64_t i, absl::Span<const int32_t> visit,
              SampleScratch& s) const {
    const int64_t p = setup_.faces ? setup_.range.begin + i : visit[i];
    SampleRows rows;
    if (!out_.table.empty()) {
      rows = {&out_.table[Slot(p) * setup_.num_rays],
              &out_.kept_table[Slot(p) * setup_.num_rays]};
      std::fill_n(rows.prims, setup_.num_rays, -1);
      std::fill_n(rows.kept, setup_.num_rays, 0);
    }
    SampleCone sample;
    if (const VertexStatus status = MakePassSample(ev_, setup_, p, &sample);
        status != VertexStatus::kOk) {
      out_.result.status[Slot(p)] = status;
      return;
    }
    s.world_frames += sample.cone.world_frame;
    if (setup_.sphere) {
      Ball(p, sample, rows, s);
    } else {
      Rays(p, sample, rows, s);
    }
  }

 private:
  // Sample p's entry in the pass's output (the range's first is 0).
  int64_t Slot(int64_t p) const { return p - setup_.range.begin; }

  // kSphere: the inscribed ball at the sample, one "ray" in the tables.
  void Ball(int64_t p, const SampleCone& sample, const SampleRows& rows,
            SampleScratch& s) const {
    SampleExclusions(ev_.mesh_, ev_.topo_, params_.samples, /*ball=*/true, p,
                     &s.excluded);
    const VertexBall b =
        InscribedBall(ev_, *ev_.scene_, *ball_tree_, sample.x,
                      sample.cone.axis(), s.excluded, setup_.ball);
    ++s.traced;
    if (rows.prims) {
      *rows.prims = b.prim;
      *rows.kept = static_cast<uint8_t>(b.contact.kind + 1);
    }
    SdfResult& result = out_.result;
    if (b.prim < 0) {
      result.status[Slot(p)] = VertexStatus::kNoHit;
      return;
    }
    result.values[Slot(p)] = 2 * b.contact.radius;
    result.hits[Slot(p)] = result.kept[Slot(p)] = 1;
    if (params_.opposite_points) {
      const PrimitiveCorners pc = ev_.Corners(b.prim);
      result.opposite[Slot(p)] = pc.a * b.contact.lambda[0] +
                           pc.b * b.contact.lambda[1] +
                           (pc.segment ? Vec3() : pc.c * b.contact.lambda[2]);
    }
  }

  // The cone's rays: all traced, or (reusing the plan's pass) those whose
  // hit may have changed, the others' hits taken from that pass.
  void Rays(int64_t p, const SampleCone& sample, const SampleRows& rows,
            SampleScratch& s) const {
    const bool reuse = plan_ && !plan_->dirty[p] &&
                       !(plan_->t_min_changed && plan_->hits->near[p]);
    const int num_rays = setup_.num_rays;
    const VertexCone& vc = sample.cone;
    const double reach = MaxAbs(sample.x - ev_.scene_->origin());
    // The directions, computed only when a ray needs them.
    bool have_dirs = false;
    auto directions = [&] {
      if (have_dirs) return;
      RayDirections(vc.frame, setup_.cone, absl::MakeSpan(s.dirs));
      have_dirs = true;
    };
    std::fill(s.t.begin(), s.t.end(), kNaN);
    s.retrace.clear();
    if (reuse) {
      ev_.RaysToRetrace(*plan_, p, sample.x, vc.frame.axis,
                        setup_.cone_half_angle, reach, setup_.limits.t_far,
                        directions, s.dirs, absl::MakeSpan(s.prims),
                        absl::MakeSpan(s.t), &s.retrace);
      if (s.retrace.empty()) {
        CopyReused(p, rows);
        return;
      }
    } else {
      for (int k = 0; k < num_rays; ++k) s.retrace.push_back(k);
    }
    directions();
    const bool near = Trace(p, sample.x, vc.frame.axis, reach, reuse, s);
    Estimate(p, sample.x, reuse, near, rows, s);
  }

  // Sample p's value, statuses and rows as the plan's pass had them.
  void CopyReused(int64_t p, const SampleRows& rows) const {
    const SdfResult& r = *plan_->result;
    SdfResult& result = out_.result;
    // Only full passes reuse (range passes trace every ray): Slot(p) == p.
    result.values[p] = r.values[p];
    result.status[p] = r.status[p];
    result.hits[p] = r.hits[p];
    result.kept[p] = r.kept[p];
    if (params_.opposite_points) result.opposite[p] = r.opposite[p];
    if (rows.prims) {
      std::copy_n(plan_->hits->Row(p).data(), setup_.num_rays, rows.prims);
      std::copy_n(plan_->hits->KeptRow(p).data(), setup_.num_rays, rows.kept);
      out_.near[p] = plan_->hits->near[p];
    }
  }

  // Traces the rays s.retrace (as traversal_ says), prefetching each candidate
  // primitive, then picks each ray's hit in double precision once it has
  // arrived, into s.prims and s.t. Returns whether a hit lay near t_min
  // (HitTable::near), in this pass or in the reused one.
  bool Trace(int64_t p, const Vec3& x, const Vec3& axis, double reach,
             bool reuse, SampleScratch& s) const {
    absl::Span<const Vec3> fan_dirs = s.dirs;
    if (reuse) {
      s.retrace_dirs.clear();
      for (int k : s.retrace) s.retrace_dirs.push_back(s.dirs[k]);
      fan_dirs = s.retrace_dirs;
    }
    SampleExclusions(ev_.mesh_, ev_.topo_, params_.samples, /*ball=*/false, p,
                     &s.excluded);
    const auto fan = absl::MakeSpan(s.candidates.data(), s.retrace.size());
    absl::Span<const float> starts;
    if (starts_ != nullptr &&
        (!reuse || s.retrace.size() >= kStartsMinRetraced)) {
      const double r = starts_->EmptyBall(
          ev_, *ball_tree_, x, axis, s.excluded,
          RayStarts::kCapEdgeLengths * ev_.mean_edge_length(), reach,
          setup_.limits);
      if (r > 0) {
        starts_->Fill(r, s.retrace, setup_.limits, &s.starts);
        starts = s.starts;
        ++s.past_ball;
      }
    }
    const FanTraversal used = ev_.scene_->IntersectFan(
        x, fan_dirs, setup_.limits, s.excluded, fan, starts, traversal_, &axis);
    s.streamed += used == FanTraversal::kStream;
    s.walked += used == FanTraversal::kCone;
    s.fell_back +=
        traversal_ == FanTraversal::kCone && used != FanTraversal::kCone;
    for (const HitCandidates& c : fan) {
      if (c.count() > 0) ev_.PrefetchPrimitive(c[0].prim);
    }
    for (const HitCandidates& c : fan) {
      if (c.count() > 0) ev_.PrefetchCorners(c[0].prim);
    }
    bool near = reuse && plan_->hits->near[p];
    for (size_t j = 0; j < s.retrace.size(); ++j) {
      if (fan[j].near()) {
        near = true;
        DropHitsBelowTMin(ev_, *ev_.scene_, x, fan_dirs[j], setup_.t_min,
                          setup_.limits, s.excluded, &fan[j], &s.dropped,
                          &s.merged);
      }
      const int k = s.retrace[j];
      s.prims[k] = PickClosest(ev_, fan[j], s.excluded, setup_.t_min, reach, x,
                               fan_dirs[j], &s.around, &s.t[k]);
    }
    s.traced += std::ssize(s.retrace);
    return near;
  }

  // The hits within t_max, the cone estimate over them (SPEC §5) and, when
  // asked, the opposite point; writes sample p's entries and rows.
  void Estimate(int64_t p, const Vec3& x, bool reuse, bool near,
                const SampleRows& rows, SampleScratch& s) const {
    const int num_rays = setup_.num_rays;
    for (int k = 0; k < num_rays; ++k) {
      // A reused hit's distance not measured yet, as when it was picked.
      if (reuse && s.prims[k] >= 0 && std::isnan(s.t[k])) {
        s.t[k] = HitDistance(ev_.Corners(s.prims[k]), x, s.dirs[k]);
      }
      if (!(s.t[k] <= setup_.t_max)) {
        s.t[k] = kNaN;
        s.prims[k] = -1;
      }
      if (rows.prims) rows.prims[k] = s.prims[k];
    }
    const ConeEstimate est = EstimateCone(s.t, setup_.cone, params_.kappa,
                                          absl::MakeSpan(s.kept), s.estimator);
    if (rows.kept) std::copy(s.kept.begin(), s.kept.end(), rows.kept);
    if (!out_.near.empty()) out_.near[Slot(p)] = near;
    SdfResult& result = out_.result;
    result.hits[Slot(p)] = est.hits;
    result.kept[Slot(p)] = est.kept;
    if (est.kept == 0) {
      result.status[Slot(p)] = VertexStatus::kNoHit;
      return;
    }
    result.values[Slot(p)] = est.value;
    if (params_.opposite_points) {
      Vec3 sum;
      double weights = 0;
      for (int k = 0; k < num_rays; ++k) {
        if (!s.kept[k]) continue;
        sum += (x + s.dirs[k] * s.t[k]) * setup_.cone[k].weight;
        weights += setup_.cone[k].weight;
      }
      result.opposite[Slot(p)] = sum / weights;
    }
  }

  const SdfEvaluator& ev_;
  const PassSetup& setup_;
  const SdfParams& params_;
  const ReusePlan* plan_;      // null: trace every ray.
  const BallTree* ball_tree_;  // kSphere, or with starts_.
  const RayStarts* starts_;
  FanTraversal traversal_;
  PassOutput& out_;
};

bool SdfEvaluator::ChooseWalk(const PassSetup& setup, tbb::task_arena& arena,
                              double* pilot) const {
  SdfParams key = setup.resolved.params;
  key.range = {};
  {
    std::lock_guard lock(walk_choice_mu_);
    if (walk_choice_.generation == generation_ && walk_choice_.params == key) {
      *pilot = walk_choice_.pilot;
      return walk_choice_.walks;
    }
  }
  bool walks = false;
  arena.execute(
      [&] { walks = WalksCones(*this, *scene_, setup, ray_test_, pilot); });
  std::lock_guard lock(walk_choice_mu_);
  walk_choice_ = {generation_, key, walks, *pilot};
  return walks;
}

absl::StatusOr<SdfResult> SdfEvaluator::Compute(
    const SdfParams& params, const ComputeControl& control, HitTable* hits,
    const PreviousPass* previous) const {
  auto setup = SetUpPass(*this, params);
  if (!setup.ok()) return setup.status();
  if (absl::Status s = ValidateControl(control); !s.ok()) return s;
  const Stopwatch watch;
  tbb::task_arena arena(ThreadCount(control.threads));
  double pilot = 0;
  bool walks_cones = false;
  // Rays always started past balls never walk (the walk starts at the
  // surface): no pilot.
  if (!fan_traversal_.has_value() &&
      ray_start_ != RayStartMode::kPastEmptyBall) {
    walks_cones = ChooseWalk(*setup, arena, &pilot);
  }
  std::unique_ptr<ReusePlan> plan;
  if (previous != nullptr && previous->hits != nullptr &&
      previous->result != nullptr && !setup->sphere && !setup->faces &&
      params.range.all()) {
    auto planned =
        PlanReuse(*previous, setup->cone, setup->resolved, walks_cones,
                  setup->limits.t_near, setup->t_min, setup->t_max);
    if (!planned.ok()) return planned.status();
    plan = std::move(*planned);
  }
  PassOutput out = NewOutput(*setup, hits != nullptr);
  // Rays start past empty balls in 3D cone passes; with kAuto only where
  // the pass traces enough rays (all of a full pass's, an estimate from an
  // incremental pass's moved samples) that the tree's build is a small
  // share of it.
  const int64_t primitives = std::ssize(topo_.primitives);
  bool use_starts = ray_start_ != RayStartMode::kSurface && !setup->sphere &&
                    mesh_.dimension == 3 &&
                    !(walks_cones && ray_start_ == RayStartMode::kAuto);
  if (use_starts && ray_start_ == RayStartMode::kAuto) {
    const int64_t rays =
        plan ? kIncrementalRaysPerMovedRay * setup->num_rays *
                   std::count(plan->dirty.begin(), plan->dirty.end(), 1)
             : setup->num_rays * setup->samples;
    use_starts =
        rays >= std::max(kStartsMinRays, kStartsPerPrimitive * primitives);
  }
  std::optional<RayStarts> starts;
  if (use_starts) {
    starts.emplace(setup->cone);
    if (starts->empty()) starts.reset();
  }
  // The inscribed ball searches its tree far (SAH); ray starts ask short
  // queries, for which a tree three times faster to build does as well.
  std::unique_ptr<BallTree> ball_tree;
  if (setup->sphere || starts) {
    auto made = BallTree::Create(
        mesh_, topo_,
        setup->sphere ? BallTree::Build::kSah : BallTree::Build::kMorton);
    if (!made.ok()) return made.status();
    ball_tree = *std::move(made);
  }
  const int64_t ns = setup->samples;
  // A vertex range's vertices in the pass's Morton order.
  std::vector<int32_t> range_order;
  if (!setup->faces && !params.range.all()) {
    range_order = VerticesInOrder(setup->range.begin, setup->range.end,
                                  [](int32_t) { return true; });
  }
  const absl::Span<const int32_t> visit =
      params.range.all() ? vertex_order() : range_order;
  ControlGate gate(control, ns);
  std::atomic<int64_t> rays_traced{0}, world_frame_vertices{0},
      samples_past_ball{0}, samples_streamed{0}, samples_walked{0},
      samples_fell_back{0};
  FanTraversal traversal = fan_traversal_.value_or(
      walks_cones && !starts
          ? FanTraversal::kCone
          : ChooseTraversal(starts.has_value(), ray_test_, primitives,
                            mesh_.dimension, setup->cone_half_angle));
  // A pass walks all of its samples or none, so that whether a sample walks
  // does not depend on which of its rays a pass traces.
  if (traversal == FanTraversal::kCone &&
      !ConeWalk::TakesEveryFan(primitives, mesh_.dimension, setup->num_rays,
                               setup->cone_half_angle)) {
    traversal = FanTraversal::kStream;
  }
  const SampleTracer tracer(*this, *setup, plan.get(), ball_tree.get(),
                            starts ? &*starts : nullptr, traversal, &out);
  auto process = [&](const tbb::blocked_range<int64_t>& range) {
    if (!gate.Poll()) return;
    SampleScratch s(setup->num_rays);
    for (int64_t i = range.begin(); i < range.end(); ++i) {
      tracer.Sample(i, visit, s);
    }
    rays_traced += s.traced;
    world_frame_vertices += s.world_frames;
    samples_past_ball += s.past_ball;
    samples_streamed += s.streamed;
    samples_walked += s.walked;
    samples_fell_back += s.fell_back;
    gate.Done(range.size());
  };
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, ns, kVertexBlock), process,
                      tbb::simple_partitioner());
  });
  if (gate.stopped()) return absl::CancelledError("SDF computation cancelled");
  SdfResult& result = out.result;
  result.trace_seconds = watch.Seconds();
  result.rays_traced = rays_traced;
  result.world_frame_vertices = world_frame_vertices;
  result.samples_past_ball = samples_past_ball;
  result.samples_streamed = samples_streamed;
  result.samples_cone_walked = samples_walked;
  result.samples_cone_fell_back = samples_fell_back;
  result.cone_walk_pilot = pilot;
  result.normalized = NormalizedSdf(result.values);
  if (params.range.all()) {
    result.missing = setup->faces ? CountMissingFaces(mesh_, result.values)
                                  : CountMissing(mesh_, result.values);
  }
  if (hits != nullptr) {
    hits->resolved = setup->resolved;
    hits->cone = std::move(setup->cone);
    hits->primitives = std::move(out.table);
    hits->kept = std::move(out.kept_table);
    hits->t_min = setup->t_min;
    hits->t_max = setup->t_max;
    hits->generation = generation_;
    hits->positions = mesh_.positions;
    hits->near = std::move(out.near);
    hits->scene_origin = scene_->origin();
    hits->extrude_half_height = scene_->extrude_half_height();
    hits->t_near = setup->limits.t_near;
    hits->num_primitives = std::ssize(topo_.primitives);
    hits->first_sample = setup->range.begin;
    hits->walks_cones = walks_cones;
  }
  return std::move(result);
}

int64_t EstimatePassBytes(const Mesh& mesh, const SdfParams& params) {
  const int64_t samples = params.range.all()
                              ? NumSamples(mesh, params.samples)
                              : params.range.end - params.range.begin;
  const int64_t rays = ResolveParams(params, mesh.dimension).rays;
  // Hit table: a primitive (4) and a kept flag (1) per ray, a near flag per
  // sample, the positions per vertex. Result: value, normalized value,
  // status, hits and kept counts per sample, and the opposite point.
  const int64_t per_sample = static_cast<int64_t>(
      rays * (sizeof(int32_t) + sizeof(uint8_t)) + sizeof(uint8_t) +
      2 * sizeof(double) + sizeof(VertexStatus) + 2 * sizeof(int32_t) +
      (params.opposite_points ? sizeof(Vec3) : 0));
  return samples * per_sample +
         mesh.num_vertices() * static_cast<int64_t>(sizeof(Vec3));
}

int64_t PassBytes(const SdfResult& result, const HitTable& hits) {
  return hits.Bytes() +
         static_cast<int64_t>(result.values.capacity() * sizeof(double) +
                              result.normalized.capacity() * sizeof(double) +
                              result.status.capacity() * sizeof(VertexStatus) +
                              result.hits.capacity() * sizeof(int32_t) +
                              result.kept.capacity() * sizeof(int32_t) +
                              result.opposite.capacity() * sizeof(Vec3));
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
