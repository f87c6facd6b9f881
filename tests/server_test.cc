// The gRPC service end to end on loopback: results equal to the library's
// bit for bit, every status code path, uploads, caching, sessions.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <mutex>
#include <thread>

#include "absl/strings/str_cat.h"
#include "lib/core/penalty.h"
#include "lib/core/sensitivity.h"
#include "lib/core/shapes.h"
#include "lib/core/weld.h"
#include "lib/embree/gradcheck.h"
#include "lib/embree/sdf.h"
#include "lib/io/mesh_io.h"
#include "proto/wire/convert.h"
#include "proto/wire/upload_convert.h"
#include "server/writer_first_mutex.h"
#include "tests/server_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Knight;
using ::testing::HasSubstr;
using testing::MetricValue;
using testing::RawUpload;
using testing::SameBits;

// The mesh's positions scaled by 1.01: a valid update.
std::vector<Vec3> Grown(const Mesh& mesh) {
  std::vector<Vec3> p = mesh.positions;
  for (Vec3& v : p) v *= 1.01;
  return p;
}

void ExpectSameRows(const std::vector<GradCheckRow>& a,
                    const std::vector<GradCheckRow>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].row, b[i].row);
    EXPECT_EQ(a[i].vertex, b[i].vertex);
    EXPECT_EQ(a[i].coordinate, b[i].coordinate);
    EXPECT_TRUE(SameBits({a[i].analytic, a[i].fd, a[i].relative_error,
                          a[i].step, a[i].measure_part},
                         {b[i].analytic, b[i].fd, b[i].relative_error,
                          b[i].step, b[i].measure_part}))
        << "entry " << i;
    EXPECT_EQ(a[i].clean, b[i].clean);
  }
}

class ServerTest : public testing::ServerFixture {};

TEST_F(ServerTest, ComputeSdfMatchesLibraryBitForBit) {
  const Mesh mesh = Knight();
  auto info = client_->Upload(mesh, "knight");
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->num_vertices, 502);
  EXPECT_EQ(info->generation, 0);
  for (SdfMethod method : {SdfMethod::kCone, SdfMethod::kNormalRay}) {
    SdfParams params;
    params.method = method;
    auto remote =
        client_->ComputeSdf("knight", params, {.chunk_vertices = 100});
    ASSERT_TRUE(remote.ok()) << remote.status();
    auto local = ComputeSdf(mesh, params);
    const SdfResult& r = remote->result;
    EXPECT_TRUE(SameBits(r.values, local->values));
    EXPECT_TRUE(SameBits(r.normalized, local->normalized));
    EXPECT_EQ(r.status, local->status);
    EXPECT_EQ(r.hits, local->hits);
    EXPECT_EQ(r.kept, local->kept);
    EXPECT_EQ(r.rays_traced, local->rays_traced);
    EXPECT_EQ(r.resolved.rays, local->resolved.rays);
    EXPECT_EQ(r.CountStatus(VertexStatus::kOk), 502);
    EXPECT_FALSE(remote->facts.reused_hits);
    EXPECT_EQ(remote->integral, IntegrateNodal(mesh, local->values).value);
  }
}

// report_progress: SdfProgress messages before the first chunk, counting up
// to every vertex; none without it, and none when the pass is reused.
TEST_F(ServerTest, ProgressIsStreamedOnlyWhenAskedAndOnlyWhileTracing) {
  ASSERT_TRUE(client_->Upload(Knight(), "p").ok());
  struct Seen {
    std::vector<v1::SdfProgress> progress;
    bool progress_after_chunk = false;
    std::vector<double> values;
  };
  auto call = [&](bool report, int rays) {
    v1::ComputeSdfRequest req;
    req.set_session_id("p");
    req.mutable_params()->set_rays(rays);
    req.set_report_progress(report);
    auto ctx = client_->Context("p");
    auto reader = client_->stub().ComputeSdf(ctx.get(), req);
    Seen seen;
    bool chunk = false;
    v1::ComputeSdfResponse msg;
    while (reader->Read(&msg)) {
      if (msg.has_progress()) {
        seen.progress.push_back(msg.progress());
        seen.progress_after_chunk |= chunk;
      } else if (msg.has_chunk()) {
        chunk = true;
        seen.values.insert(seen.values.end(), msg.chunk().values().begin(),
                           msg.chunk().values().end());
      }
    }
    EXPECT_TRUE(reader->Finish().ok());
    return seen;
  };
  const Seen quiet = call(false, 40);
  EXPECT_TRUE(quiet.progress.empty());
  const Seen drawn = call(true, 41);  // other parameters: traced again.
  ASSERT_FALSE(drawn.progress.empty());
  EXPECT_FALSE(drawn.progress_after_chunk);
  for (size_t i = 1; i < drawn.progress.size(); ++i) {
    EXPECT_GE(drawn.progress[i].vertices_done(),
              drawn.progress[i - 1].vertices_done());
  }
  EXPECT_EQ(drawn.progress.back().vertices_done(), 502);
  EXPECT_EQ(drawn.progress.back().vertices_total(), 502);
  EXPECT_EQ(drawn.progress.back().rays_total(), 502 * 41);
  EXPECT_TRUE(call(true, 41).progress.empty());  // the cached pass.
  EXPECT_TRUE(SameBits(call(true, 40).values, quiet.values));
}

TEST_F(ServerTest, KsConstraintMatchesLibraryAndReportsMissingValues) {
  const Mesh mesh = Knight();
  ASSERT_TRUE(client_->Upload(mesh, "ks").ok());
  auto ev = SdfEvaluator::Create(mesh);
  HitTable hits;
  auto values = (*ev)->Compute({}, {}, &hits);
  const PenaltyParams ks{.t_min = 0.3, .form = PenaltyForm::kKs, .rho = 30};
  auto local = ComputePenalty(**ev, *values, ks, &hits);
  auto remote = client_->ComputePenalty("ks", SdfParams{}, ks, true);
  ASSERT_TRUE(remote.ok()) << remote.status();
  EXPECT_EQ(remote->penalty.value, local->value);
  EXPECT_EQ(remote->penalty.gradient, local->gradient);
  EXPECT_EQ(remote->penalty.missing.vertices, 0);
  EXPECT_EQ(remote->world_frame_vertices, 0);
  auto sdf = client_->ComputeSdf("ks", SdfParams{});
  ASSERT_TRUE(sdf.ok());
  EXPECT_EQ(sdf->result.missing.area_fraction, 0.0);
  EXPECT_EQ(SummarizeValues(sdf->result.values).median,
            SummarizeValues(values->values).median);
}

// header.weld merges an unwelded export's seams on the server and answers
// the map of the uploaded vertices; a tolerance out of range is refused.
TEST_F(ServerTest, AWeldedUploadAnswersTheMapOfItsVertices) {
  const Mesh cube = testing::SixGridCube();
  std::vector<v1::CreateSessionRequest> msgs =
      testing::UploadMessages(cube, "welded");
  msgs[0].mutable_header()->set_weld(true);
  auto r = testing::RawUploadResponse(*client_, msgs);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->session().num_vertices(), 98);
  ASSERT_EQ(r->welded_vertex_size(), 150);
  Mesh welded = cube;
  auto local = WeldVertices(welded, 0);
  ASSERT_TRUE(local.ok());
  for (int v = 0; v < 150; ++v) {
    EXPECT_EQ(r->welded_vertex(v), local->welded_vertex[v]) << v;
  }
  EXPECT_THAT(r->session().warnings(0), HasSubstr("52 vertices welded"));
  EXPECT_TRUE(r->session().closed());
  msgs = testing::UploadMessages(cube, "too_loose");
  msgs[0].mutable_header()->set_weld(true);
  msgs[0].mutable_header()->set_weld_tolerance(0.5);
  EXPECT_EQ(testing::RawUploadResponse(*client_, msgs).status().code(),
            absl::StatusCode::kInvalidArgument);
  // Without weld nothing merges and the map stays empty.
  auto plain = testing::RawUploadResponse(
      *client_, testing::UploadMessages(cube, "plain"));
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_EQ(plain->session().num_vertices(), 150);
  EXPECT_EQ(plain->welded_vertex_size(), 0);
}

// An outside tester's six concurrent uploads of igea all ended CANCELLED
// after about 34 s with the default flags (cancellation polled per face, the
// idle timer running while the server built each mesh): with the defaults
// they all succeed.
TEST_F(ServerTest, SixConcurrentUploadsOfIgeaSucceedWithDefaults) {
  auto igea = ReadMesh(testing::SharedMesh("igea-triangles.ply"));
  ASSERT_TRUE(igea.ok());
  std::vector<absl::Status> results(6);
  std::vector<std::thread> uploads;
  for (int i = 0; i < 6; ++i) {
    uploads.emplace_back([&, i] {
      client::RemoteClient c(target_);
      results[i] = c.Upload(*igea, "igea" + std::to_string(i)).status();
    });
  }
  for (std::thread& t : uploads) t.join();
  for (int i = 0; i < 6; ++i) EXPECT_TRUE(results[i].ok()) << results[i];
}

// Face samples through ComputePenalty: the library's value and gradient.
TEST_F(ServerTest, FaceSampledPenaltyMatchesTheLibrary) {
  const Mesh mesh = Knight();
  ASSERT_TRUE(client_->Upload(mesh, "faces").ok());
  SdfParams faces;
  faces.samples = SampleSet::kFaces;
  auto ev = SdfEvaluator::Create(mesh);
  HitTable hits;
  auto values = (*ev)->Compute(faces, {}, &hits);
  ASSERT_TRUE(values.ok());
  const PenaltyParams p{.t_min = 0.3};
  auto local = ComputePenalty(**ev, *values, p, &hits);
  ASSERT_TRUE(local.ok()) << local.status();
  auto remote = client_->ComputePenalty("faces", faces, p, true);
  ASSERT_TRUE(remote.ok()) << remote.status();
  EXPECT_EQ(remote->penalty.value, local->value);
  EXPECT_EQ(remote->penalty.gradient, local->gradient);
}

TEST_F(ServerTest, PenaltyOverMostlyMissingValuesIsFailedPrecondition) {
  // The shared horse is inward oriented: most cones look outside.
  const Mesh horse = *ReadMesh(testing::SharedMesh("horse.ply"));
  ASSERT_TRUE(client_->Upload(horse, "horse").ok());
  SdfParams few;
  few.rays = 8;
  auto pen = client_->ComputePenalty("horse", few, {.t_min = 0.01}, false);
  EXPECT_EQ(pen.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(pen.status().message()), HasSubstr("reorient"));
  auto sdf = client_->ComputeSdf("horse", few);
  ASSERT_TRUE(sdf.ok());
  EXPECT_GT(sdf->result.missing.area_fraction, 0.5);
  // The upload's diagnostics said why.
  auto info = client_->Get("horse");
  ASSERT_TRUE(info.ok());
  ASSERT_EQ(info->warnings.size(), 1u);
  EXPECT_THAT(info->warnings[0], HasSubstr("negative signed volume"));
  EXPECT_GT(sdf->result.missing.vertices, 0);
  // The caller may allow it explicitly.
  auto allowed = client_->ComputePenalty(
      "horse", few, {.t_min = 0.01, .max_missing_fraction = 1}, false);
  EXPECT_TRUE(allowed.ok()) << allowed.status();
  EXPECT_GT(allowed->penalty.missing.area_fraction, 0.5);
}

TEST_F(ServerTest, JacobianVjpAndPenaltyMatchLibrary) {
  const Mesh mesh = Knight();
  ASSERT_TRUE(client_->Upload(mesh, "k").ok());
  auto ev = SdfEvaluator::Create(mesh);
  HitTable hits;
  auto values = (*ev)->Compute({}, {}, &hits);
  auto jac = ComputeJacobian(**ev, hits);
  auto remote =
      client_->ComputeSdf("k", SdfParams{}, {.include_jacobian = true});
  ASSERT_TRUE(remote.ok()) << remote.status();
  ASSERT_TRUE(remote->jacobian.has_value());
  EXPECT_EQ(remote->jacobian->row_offsets, jac->row_offsets);
  EXPECT_EQ(remote->jacobian->columns, jac->columns);
  EXPECT_EQ(remote->jacobian->values, jac->values);

  std::vector<double> g(502);
  for (int i = 0; i < 502; ++i) g[i] = std::sin(0.1 * i);
  auto vjp = client_->ComputeVjp("k", SdfParams{}, g);
  ASSERT_TRUE(vjp.ok()) << vjp.status();
  EXPECT_TRUE(vjp->facts.reused_hits)
      << "same generation and params as ComputeSdf";
  EXPECT_EQ(vjp->gradient, *ComputeVjp(**ev, hits, g));

  auto pen = client_->ComputePenalty("k", SdfParams{}, {.t_min = 0.1}, true);
  ASSERT_TRUE(pen.ok()) << pen.status();
  auto local = ComputePenalty(**ev, *values, {.t_min = 0.1}, &hits);
  EXPECT_EQ(pen->penalty.value, local->value);
  EXPECT_EQ(pen->penalty.gradient, local->gradient);
  EXPECT_TRUE(pen->facts.reused_hits);

  // Other parameters trace anew.
  SdfParams other;
  other.rays = 50;
  auto traced = client_->ComputeVjp("k", other, g);
  ASSERT_TRUE(traced.ok());
  EXPECT_FALSE(traced->facts.reused_hits);
  EXPECT_THAT(
      metrics_.Text(),
      HasSubstr("meshgauge_hit_cache_requests_total{result=\"reused\"} 2"));
}

TEST_F(ServerTest, UpdatePositionsRefitsAndChecksGeneration) {
  const Mesh torus = MakeTorus(2, 0.5, 48, 16);
  ASSERT_TRUE(client_->Upload(torus, "t").ok());
  Mesh moved = torus;
  for (Vec3& p : moved.positions) p = Vec3(p.x * 1.2, p.y, p.z * 0.8);
  auto up = client_->UpdatePositions("t", 0, 3, moved.positions);
  ASSERT_TRUE(up.ok()) << up.status();
  EXPECT_EQ(up->generation, 1);
  EXPECT_TRUE(up->refit);
  auto stale = client_->UpdatePositions("t", 0, 3, moved.positions);
  EXPECT_EQ(stale.status().code(), absl::StatusCode::kAborted);
  EXPECT_THAT(std::string(stale.status().message()), HasSubstr("generation 1"));
  auto remote =
      client_->ComputeSdf("t", SdfParams{}, {.expected_generation = 1});
  ASSERT_TRUE(remote.ok()) << remote.status();
  EXPECT_TRUE(SameBits(remote->result.values, ComputeSdf(moved, {})->values));
  EXPECT_EQ(client_->ComputeSdf("t", SdfParams{}, {.expected_generation = 0})
                .status()
                .code(),
            absl::StatusCode::kAborted);
  // Subset update.
  auto sub = client_->UpdatePositions("t", 1, 3, {Vec3(3, 0, 0)}, {0});
  ASSERT_TRUE(sub.ok()) << sub.status();
  EXPECT_EQ(sub->generation, 2);
  auto info = client_->Get("t");
  EXPECT_EQ(info->bvh_refits, 2);
  EXPECT_THAT(metrics_.Text(), HasSubstr("meshgauge_bvh_refits_total 2"));
}

// SPEC §3 (2.1): a session's values do not depend on its history. After
// each kind of update (a 1 % patch, one vertex, 1 % scattered, a 10 % patch
// moved across the part, every vertex, and back) rocker-arm's values, hits
// and statuses equal a fresh upload's of the same positions (4 of 10,044
// vertices differed when the BVH kept the first positions' centroid as its
// origin); the passes after small updates traced few rays (they reused the
// previous generation's), and Prometheus counts the rays traced.
TEST_F(ServerTest, AnUpdatedSessionMatchesAFreshUploadOfItsPositions) {
  const Mesh rocker = *ReadMesh(testing::SharedMesh("rocker-arm.obj"));
  const int64_t nv = rocker.num_vertices(), full = nv * 100;
  ASSERT_TRUE(client_->Upload(rocker, "updated").ok());
  ASSERT_TRUE(client_->ComputeSdf("updated", SdfParams{}).ok());
  int64_t rays = full;
  const double d = BoundingBoxDiagonal(rocker);
  std::vector<int32_t> scattered;
  for (int32_t v = 0; v < nv; v += 97) scattered.push_back(v);
  std::vector<int32_t> all(nv);
  for (int32_t v = 0; v < nv; ++v) all[v] = v;
  struct Step {
    const char* name;
    std::vector<int32_t> indices;
    Vec3 shift;         // in units of the diagonal.
    int64_t most_rays;  // the incremental pass traces at most these.
  };
  const std::vector<Step> steps = {
      {"1 % patch", testing::Patch(rocker, 100, 0.15 * d),
       Vec3(2e-3, -1e-3, 1.5e-3), full / 2},
      {"one vertex", {5000}, Vec3(0, 3e-3, 0), full / 10},
      {"1 % scattered", scattered, Vec3(-1e-3, 1e-3, 2e-3), full * 9 / 10},
      {"10 % patch across the part", testing::Patch(rocker, 7000, 0.3 * d),
       Vec3(0.05, 0.02, -0.03), full},
      {"every vertex", all, Vec3(1e-3, 1e-3, 1e-3), full},
  };
  Mesh moved = rocker;
  int64_t generation = 0;
  auto check = [&](const char* name, const std::vector<int32_t>& indices,
                   int64_t most_rays) {
    std::vector<Vec3> to;
    for (int32_t v : indices) to.push_back(moved.positions[v]);
    auto up = client_->UpdatePositions("updated", generation, 3, to, indices);
    ASSERT_TRUE(up.ok()) << name << ": " << up.status();
    generation = up->generation;
    const std::string fresh = absl::StrCat("fresh", generation);
    ASSERT_TRUE(client_->Upload(moved, fresh).ok()) << name;
    auto a = client_->ComputeSdf("updated", SdfParams{});
    auto b = client_->ComputeSdf(fresh, SdfParams{});
    ASSERT_TRUE(a.ok() && b.ok()) << name;
    EXPECT_TRUE(SameBits(a->result.values, b->result.values)) << name;
    EXPECT_EQ(a->result.hits, b->result.hits) << name;
    EXPECT_EQ(a->result.kept, b->result.kept) << name;
    EXPECT_EQ(a->result.status, b->result.status) << name;
    EXPECT_EQ(b->result.rays_traced, full) << name;
    EXPECT_GT(a->result.rays_traced, 0) << name;
    EXPECT_LE(a->result.rays_traced, most_rays) << name;
    EXPECT_FALSE(a->facts.reused_hits) << name;
    rays += a->result.rays_traced + b->result.rays_traced;
    EXPECT_EQ(MetricValue(metrics_.Text(), "meshgauge_rays_traced_total"), rays)
        << name;
    ASSERT_TRUE(client_->Delete(fresh).ok());
  };
  for (const Step& step : steps) {
    for (int32_t v : step.indices) moved.positions[v] += step.shift * d;
    check(step.name, step.indices, step.most_rays);
  }
  moved = rocker;
  check("back to the first positions", all, full);
}

// GradCheck checks the session's current generation (after an update) and
// reports what the library reports at those positions, bit for bit; it
// streams progress when asked, counts its rays and leaves the session (its
// generation, cached pass and memory) as it was.
TEST_F(ServerTest, GradCheckChecksTheCurrentPositionsAndLeavesTheSession) {
  const Mesh knight = Knight();
  ASSERT_TRUE(client_->Upload(knight, "g").ok());
  Mesh moved = knight;
  std::vector<int32_t> indices = testing::Patch(knight, 7, 0.1);
  std::vector<Vec3> to;
  for (int32_t v : indices) {
    moved.positions[v] += Vec3(0.004, -0.002, 0.003);
    to.push_back(moved.positions[v]);
  }
  ASSERT_TRUE(client_->UpdatePositions("g", 0, 3, to, indices).ok());
  SdfParams params;
  params.rays = 30;
  auto before = client_->ComputeSdf("g", params);
  ASSERT_TRUE(before.ok()) << before.status();
  const int64_t memory = client_->Get("g")->memory_bytes;
  GradCheckOptions options;
  options.samples = 4;
  options.penalty = PenaltyParams{.t_min = 0.3};
  const double rays_before =
      MetricValue(metrics_.Text(), "meshgauge_rays_traced_total");
  int64_t calls = 0, done = 0, total = 0;
  double accounted = 0;  // the memory gauge while the check runs.
  auto remote =
      client_->GradCheck("g", params, options, [&](int64_t d, int64_t t) {
        ++calls;
        EXPECT_GE(d, done);
        done = d;
        total = t;
        accounted = std::max(
            accounted,
            MetricValue(metrics_.Text(), "meshgauge_session_cache_bytes"));
      });
  ASSERT_TRUE(remote.ok()) << remote.status();
  auto local = RunGradCheck(moved, params, options);
  ASSERT_TRUE(local.ok()) << local.status();
  EXPECT_EQ(remote->facts.generation, 1);
  ExpectSameRows(remote->report.rows, local->rows);
  ExpectSameRows(remote->report.penalty_rows, local->penalty_rows);
  EXPECT_FALSE(local->rows.empty());
  EXPECT_FALSE(local->penalty_rows.empty());
  EXPECT_EQ(remote->report.Verdict(), GradCheckVerdict::kPass);
  EXPECT_EQ(remote->report.vjp_checks, local->vjp_checks);
  EXPECT_EQ(remote->report.rays_traced, local->rays_traced);
  EXPECT_EQ(remote->report.retried, local->retried);
  EXPECT_EQ(remote->report.max_abs_derivative, local->max_abs_derivative);
  EXPECT_EQ(
      MetricValue(metrics_.Text(), "meshgauge_rays_traced_total") - rays_before,
      local->rays_traced);
  EXPECT_GE(calls, 1);
  EXPECT_EQ(done, total);
  EXPECT_EQ(total, (1 + 2 * 3 * 4) * knight.num_vertices());
  auto after = client_->ComputeSdf("g", params);
  ASSERT_TRUE(after.ok());
  EXPECT_EQ(after->facts.generation, 1);
  EXPECT_TRUE(after->facts.reused_hits);
  EXPECT_TRUE(SameBits(after->result.values, before->result.values));
  EXPECT_EQ(client_->Get("g")->memory_bytes, memory);
  // The private copy and its passes were accounted while the check ran,
  // and returned after it.
  EXPECT_GE(accounted, memory + server::Session::EstimateBaseBytes(moved) +
                           GradCheckWorkBytes(moved, params));
  EXPECT_EQ(MetricValue(metrics_.Text(), "meshgauge_session_cache_bytes"),
            memory);
}

// A check's scratch memory counts against its tenant's budget while it
// runs: an upload that fits beside the session alone is refused during the
// check and accepted after it.
TEST_F(ServerTest, GradCheckScratchCountsAgainstTheTenantsBudget) {
  const Mesh knight = Knight();
  SdfParams params;
  params.rays = 30;
  const int64_t base = server::Session::EstimateBaseBytes(knight);
  const int64_t scratch = base + GradCheckWorkBytes(knight, params);
  server::ServerOptions o;
  o.memory_budget_bytes_per_tenant = base + scratch + base / 2;
  RestartServer(o);
  ASSERT_TRUE(client_->Upload(knight, "g").ok());
  client::RemoteClient other(target_);
  absl::Status during;
  bool tried = false;
  auto checked =
      client_->GradCheck("g", params, {.samples = 2}, [&](int64_t, int64_t) {
        if (tried) return;
        tried = true;
        during = other.Upload(knight, "h").status();
      });
  ASSERT_TRUE(checked.ok()) << checked.status();
  ASSERT_TRUE(tried);
  EXPECT_EQ(during.code(), absl::StatusCode::kResourceExhausted) << during;
  EXPECT_TRUE(other.Upload(knight, "h").ok());
}

// Options, generation, session and normals are checked before anything is
// computed (no ray is traced).
TEST_F(ServerTest, GradCheckRejectsBadOptionsBeforeTracing) {
  ASSERT_TRUE(client_->Upload(Knight(), "g").ok());
  auto code = [&](GradCheckOptions o, SdfParams p = {}) {
    return client_->GradCheck("g", p, o).status().code();
  };
  EXPECT_EQ(code({.samples = 1001}), absl::StatusCode::kInvalidArgument);
  GradCheckOptions many;
  many.vertices.assign(1001, 0);
  EXPECT_EQ(code(many), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code({.vertices = {502}}), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code({.relative_step = 0.5}), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code({.penalty = PenaltyParams{.t_min = -1}}),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code({}, SdfParams{.normal_weighting = NormalWeighting::kAngle,
                              .range = {}}),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(client_->GradCheck("nope", {}, {}).status().code(),
            absl::StatusCode::kNotFound);
  v1::GradCheckRequest stale;
  stale.set_session_id("g");
  stale.set_expected_generation(3);
  auto ctx = client_->Context("g");
  auto reader = client_->stub().GradCheck(ctx.get(), stale);
  v1::GradCheckResponse msg;
  while (reader->Read(&msg)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::ABORTED);
  EXPECT_EQ(MetricValue(metrics_.Text(), "meshgauge_rays_traced_total"), 0);
}

// The private copy and its passes are claimed against the memory budget
// before they are made: a check that cannot fit is RESOURCE_EXHAUSTED, and
// the sessions (and their accounted memory) are as before.
TEST_F(ServerTest, GradCheckOverTheMemoryBudgetIsRefusedBeforeComputing) {
  server::ServerOptions o;
  const Mesh knight = Knight();
  o.memory_budget_bytes = 2 << 20;  // 8 knights; a check needs 4.3 MB.
  RestartServer(o);
  ASSERT_TRUE(client_->Upload(knight, "a").ok());
  ASSERT_TRUE(client_->Upload(knight, "b").ok());
  const int64_t memory = client_->Get("a")->memory_bytes;
  auto refused = client_->GradCheck("a", {}, {.samples = 1});
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(refused.status().message(), HasSubstr("scratch memory"));
  EXPECT_TRUE(client_->Get("b").ok());
  EXPECT_EQ(client_->Get("a")->memory_bytes, memory);
  EXPECT_EQ(MetricValue(metrics_.Text(), "meshgauge_rays_traced_total"), 0);
}

TEST_F(ServerTest, RebuildsAfterConfiguredNumberOfUpdates) {
  server::ServerOptions o;
  o.rebuild_every_updates = 2;
  RestartServer(o);
  const Mesh sphere = MakeIcosphere(1, 4);
  ASSERT_TRUE(client_->Upload(sphere, "s").ok());
  std::vector<Vec3> p = sphere.positions;
  for (int gen = 0; gen < 4; ++gen) {
    for (Vec3& v : p) v *= 1.01;
    auto up = client_->UpdatePositions("s", gen, 3, p);
    ASSERT_TRUE(up.ok());
    EXPECT_EQ(up->refit, gen % 2 == 0) << gen;
  }
  auto info = client_->Get("s");
  EXPECT_EQ(info->bvh_refits, 2);
  EXPECT_EQ(info->bvh_builds, 3);  // first build + 2 rebuilds.
}

TEST_F(ServerTest, StatusCodePaths) {
  const Mesh mesh = Knight();
  auto code = [](const auto& r) { return r.status().code(); };
  EXPECT_EQ(code(client_->Get("nope")), absl::StatusCode::kNotFound);
  EXPECT_EQ(client_->Delete("nope").code(), absl::StatusCode::kNotFound);
  ASSERT_TRUE(client_->Upload(mesh, "a").ok());
  EXPECT_EQ(code(client_->Upload(mesh, "a")), absl::StatusCode::kAlreadyExists);
  auto bad_id = client_->Upload(mesh, "no spaces/please");
  EXPECT_EQ(code(bad_id), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(bad_id.status().message()),
              HasSubstr("[A-Za-z0-9._-]"));
  Mesh degenerate = mesh;
  degenerate.positions[degenerate.faces[3].v[1]] =
      degenerate.positions[degenerate.faces[3].v[0]];
  auto invalid = client_->Upload(degenerate, "d");
  EXPECT_EQ(code(invalid), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(invalid.status().message()), HasSubstr("zero area"));

  SdfParams wide;
  wide.cone_angle_degrees = 190;
  auto bad_angle = client_->ComputeSdf("a", wide);
  EXPECT_EQ(code(bad_angle), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(bad_angle.status().message()),
              HasSubstr("cone angle"));
  SdfParams many;
  many.rays = 2000;
  auto too_many = client_->ComputeSdf("a", many);
  EXPECT_EQ(code(too_many), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(too_many.status().message()),
              HasSubstr("limit of 1024"));
  EXPECT_EQ(
      code(client_->ComputeSdf("a", SdfParams{}, {.chunk_vertices = 100000})),
      absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code(client_->ComputeVjp("a", SdfParams{}, {1.0, 2.0})),
            absl::StatusCode::kInvalidArgument);
  SdfParams angle;
  angle.normal_weighting = NormalWeighting::kAngle;
  EXPECT_EQ(
      code(client_->ComputeVjp("a", angle, std::vector<double>(502, 1.0))),
      absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(
      code(client_->ComputePenalty("a", SdfParams{}, {.t_min = -1}, false)),
      absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code(client_->UpdatePositions("a", 0, 3, {Vec3(0, 0, 0)})),
            absl::StatusCode::kInvalidArgument);
  std::vector<Vec3> nan_positions = mesh.positions;
  nan_positions[4].y = std::nan("");
  auto nan_update = client_->UpdatePositions("a", 0, 3, nan_positions);
  EXPECT_EQ(code(nan_update), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(nan_update.status().message()),
              HasSubstr("not finite"));
  EXPECT_EQ(code(client_->UpdatePositions("a", 0, 3, {Vec3(0, 0, 0)}, {9999})),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code(client_->Calibrate("a", {.t_min = 0})),
            absl::StatusCode::kInvalidArgument);
  auto cal = client_->Calibrate("a", {.t_min = 0.05});
  ASSERT_TRUE(cal.ok()) << cal.status();
  EXPECT_EQ(cal->compared, 502);
  v1::ListSessionsRequest list;
  list.set_page_size(5000);
  v1::ListSessionsResponse resp;
  auto ctx = client_->Context("");
  EXPECT_EQ(client_->stub().ListSessions(ctx.get(), list, &resp).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(client_->Delete("a").ok());
  EXPECT_EQ(code(client_->Get("a")), absl::StatusCode::kNotFound);
}

TEST_F(ServerTest, LimitsGiveResourceExhausted) {
  server::ServerOptions o;
  o.max_sessions = 2;
  o.max_vertices = 600;
  RestartServer(o);
  const Mesh mesh = Knight();
  ASSERT_TRUE(client_->Upload(mesh, "1").ok());
  ASSERT_TRUE(client_->Upload(mesh, "2").ok());
  auto third = client_->Upload(mesh, "3");
  EXPECT_EQ(third.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(third.status().message()),
              HasSubstr("maximum of 2 sessions"));
  auto big = client_->Upload(MakeIcosphere(1, 8), "big");
  EXPECT_EQ(big.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(big.status().message()), HasSubstr("limit of 600"));
}

TEST_F(ServerTest, MessageSizeLimitIsEnforced) {
  server::ServerOptions o;
  o.max_message_bytes = 4096;
  RestartServer(o);
  client::ClientOptions co;
  co.upload_chunk_vertices = 1000;  // one chunk far above 4 KiB.
  client::RemoteClient c(target_, co);
  auto r = c.Upload(MakeIcosphere(1, 10), "x");
  EXPECT_EQ(r.status().code(), absl::StatusCode::kResourceExhausted)
      << r.status();
}

std::vector<v1::CreateSessionRequest> TriangleUpload(uint32_t crc) {
  Mesh tri;
  tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  tri.faces = {Face::Triangle(0, 1, 2)};
  std::vector<v1::CreateSessionRequest> m(3);
  auto* h = m[0].mutable_header();
  h->set_session_id("raw");
  h->set_dimension(3);
  h->set_num_vertices(3);
  h->set_num_faces(1);
  auto* c = m[1].mutable_chunk();
  for (const Vec3& p : tri.positions) {
    c->add_positions(p.x);
    c->add_positions(p.y);
    c->add_positions(p.z);
  }
  c->add_face_sizes(3);
  for (int i = 0; i < 3; ++i) c->add_face_indices(i);
  m[2].mutable_footer()->set_num_vertices(3);
  m[2].mutable_footer()->set_num_faces(1);
  wire::UploadCrc sent;
  sent.Add(*c);
  m[2].mutable_footer()->set_crc32(crc ? crc : sent.Value());
  return m;
}

TEST_F(ServerTest, UploadChecksCountsChecksumAndTruncation) {
  EXPECT_TRUE(RawUpload(*client_, TriangleUpload(0)).ok());
  ASSERT_TRUE(client_->Delete("raw").ok());
  auto bad_crc = RawUpload(*client_, TriangleUpload(12345));
  EXPECT_EQ(bad_crc.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(bad_crc.status().message()),
              HasSubstr("checksum mismatch"));
  auto msgs = TriangleUpload(0);
  msgs.pop_back();
  auto truncated = RawUpload(*client_, msgs);
  EXPECT_EQ(truncated.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(truncated.status().message()),
              HasSubstr("truncated stream"));
  msgs = TriangleUpload(0);
  msgs[1].mutable_chunk()->mutable_positions()->RemoveLast();
  auto short_positions = RawUpload(*client_, msgs);
  EXPECT_THAT(std::string(short_positions.status().message()),
              HasSubstr("stray coordinates"));
  msgs = TriangleUpload(0);
  msgs.erase(msgs.begin());
  EXPECT_THAT(std::string(RawUpload(*client_, msgs).status().message()),
              HasSubstr("first message must be a header"));
  msgs = TriangleUpload(0);
  msgs[2].mutable_footer()->set_num_faces(2);
  EXPECT_THAT(std::string(RawUpload(*client_, msgs).status().message()),
              HasSubstr("footer counts"));
  msgs = TriangleUpload(0);
  msgs[1].mutable_chunk()->set_face_sizes(0, 5);
  EXPECT_THAT(std::string(RawUpload(*client_, msgs).status().message()),
              HasSubstr("has size 5"));
  EXPECT_EQ(client_->List()->size(), 0u);
}

TEST_F(ServerTest, TwoDimensionalHollowSessionWithOutwardRegion) {
  const Mesh hollow = MakeHollowSquare(4, 1, 0.1);
  auto info = client_->Upload(hollow);
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->dimension, 2);
  // Named by the client (a UUID, so the upload carried its routing key),
  // not by the server ("s-<16 hex>").
  EXPECT_THAT(info->session_id,
              ::testing::MatchesRegex("[0-9a-f]{8}-[0-9a-f]{4}-4[0-9a-f]{3}-"
                                      "[89ab][0-9a-f]{3}-[0-9a-f]{12}"));
  auto r = client_->ComputeSdf(info->session_id, SdfParams{});
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(SameBits(r->result.values, ComputeSdf(hollow, {})->values));
  auto vjp =
      client_->ComputeVjp(info->session_id, SdfParams{},
                          std::vector<double>(hollow.num_vertices(), 1.0));
  ASSERT_TRUE(vjp.ok());
  ASSERT_EQ(std::ssize(vjp->gradient), hollow.num_vertices());
}

TEST_F(ServerTest, ListPaginates) {
  const Mesh tri = MakeIcosphere(1, 1);
  for (int i = 0; i < 7; ++i)
    ASSERT_TRUE(client_->Upload(tri, "m" + std::to_string(i)).ok());
  v1::ListSessionsRequest req;
  req.set_page_size(3);
  std::vector<std::string> ids;
  int pages = 0;
  do {
    v1::ListSessionsResponse resp;
    auto ctx = client_->Context("");
    ASSERT_TRUE(client_->stub().ListSessions(ctx.get(), req, &resp).ok());
    for (const auto& s : resp.sessions()) ids.push_back(s.session_id());
    req.set_page_token(resp.next_page_token());
    ++pages;
  } while (!req.page_token().empty());
  EXPECT_EQ(pages, 3);
  EXPECT_EQ(ids, (std::vector<std::string>{"m0", "m1", "m2", "m3", "m4", "m5",
                                           "m6"}));
}

TEST_F(ServerTest, IdleSessionsExpireAfterTtl) {
  ASSERT_TRUE(client_->Upload(Knight(), "old").ok());
  clock_.Advance(options_.session_ttl_seconds - 1);
  ASSERT_TRUE(client_->Upload(Knight(), "new").ok());
  clock_.Advance(2);  // "old" is now idle past the TTL, "new" is not.
  EXPECT_EQ(client_->Get("old").status().code(), absl::StatusCode::kNotFound);
  EXPECT_TRUE(client_->Get("new").ok());
  EXPECT_THAT(metrics_.Text(),
              HasSubstr("meshgauge_session_evictions_total{reason=\"ttl\"} 1"));
}

TEST_F(ServerTest, GetSessionDoesNotResetTheIdleClock) {
  ASSERT_TRUE(client_->Upload(MakeIcosphere(1, 2), "idle").ok());
  clock_.Advance(5);
  auto first = client_->Get("idle");
  clock_.Advance(5);
  auto second = client_->Get("idle");
  ASSERT_TRUE(first.ok() && second.ok());
  EXPECT_DOUBLE_EQ(first->idle_seconds, 5);
  EXPECT_DOUBLE_EQ(second->idle_seconds, 10);
  ASSERT_TRUE(client_->ComputeSdf("idle", SdfParams{}).ok());
  EXPECT_DOUBLE_EQ(client_->Get("idle")->idle_seconds, 0);
}

TEST_F(ServerTest, MemoryBudgetEvictsLeastRecentlyUsed) {
  server::ServerOptions o;
  const Mesh sphere = MakeIcosphere(1, 10);
  o.memory_budget_bytes = server::Session::EstimateBaseBytes(sphere) * 5 / 2;
  RestartServer(o);
  ASSERT_TRUE(client_->Upload(sphere, "a").ok());
  clock_.Advance(1);
  ASSERT_TRUE(client_->Upload(sphere, "b").ok());
  clock_.Advance(1);
  // A call that uses "a" (GetSession only looks) makes it more recent.
  ASSERT_TRUE(client_->UpdatePositions("a", 0, 3, sphere.positions).ok());
  clock_.Advance(1);
  ASSERT_TRUE(client_->Upload(sphere, "c").ok());
  EXPECT_TRUE(client_->Get("a").ok());
  EXPECT_EQ(client_->Get("b").status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(
      metrics_.Text(),
      HasSubstr("meshgauge_session_evictions_total{reason=\"memory\"} 1"));
}

TEST_F(ServerTest, ConcurrentClientsGetLibraryResults) {
  const Mesh knight = Knight();
  const Mesh torus = MakeTorus(2, 0.5, 40, 14);
  ASSERT_TRUE(client_->Upload(knight, "k").ok());
  ASSERT_TRUE(client_->Upload(torus, "t").ok());
  ASSERT_TRUE(client_->Upload(torus, "moving").ok());
  const auto k_values = ComputeSdf(knight, {})->values;
  const auto t_values = ComputeSdf(torus, {})->values;
  std::atomic<int> mismatches{0}, errors{0};
  std::vector<std::thread> threads;
  for (int c = 0; c < 4; ++c) {
    threads.emplace_back([&, c] {
      client::RemoteClient cl(target_);
      for (int i = 0; i < 4; ++i) {
        SdfParams p;
        p.rays = (i % 2) ? 64 : 0;  // alternate parameters: cache misses.
        const bool k = (c + i) % 2 == 0;
        auto r = cl.ComputeSdf(k ? "k" : "t", p);
        if (!r.ok()) {
          ++errors;
          continue;
        }
        if (p.rays == 0 && !SameBits(r->result.values, k ? k_values : t_values))
          ++mismatches;
      }
    });
  }
  threads.emplace_back([&] {  // an optimiser moving its own session.
    client::RemoteClient cl(target_);
    std::vector<Vec3> p = torus.positions;
    for (int gen = 0; gen < 6; ++gen) {
      for (Vec3& v : p) v *= 1.001;
      if (!cl.UpdatePositions("moving", gen, 3, p).ok()) ++errors;
      if (!cl.ComputeVjp("moving", SdfParams{},
                         std::vector<double>(p.size(), 1))
               .ok())
        ++errors;
    }
  });
  for (auto& t : threads) t.join();
  EXPECT_EQ(errors, 0);
  EXPECT_EQ(mismatches, 0);
}

// A waiting writer goes before readers that come after it: by order, not
// by time (glibc's rwlock let new readers in while a writer waited).
TEST(WriterFirstMutexTest, AWaitingWriterGoesBeforeLaterReaders) {
  server::WriterFirstMutex mu;
  std::vector<std::string> order;
  std::mutex order_mu;
  auto note = [&](const char* what) {
    std::lock_guard<std::mutex> lock(order_mu);
    order.push_back(what);
  };
  mu.lock_shared();  // a computation running.
  std::thread writer([&] {
    mu.lock();
    note("writer");
    mu.unlock();
  });
  while (mu.writers_waiting() == 0) std::this_thread::yield();
  std::thread reader([&] {
    mu.lock_shared();
    note("later reader");
    mu.unlock_shared();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  {
    std::lock_guard<std::mutex> lock(order_mu);
    EXPECT_TRUE(order.empty());  // neither passed the running reader.
  }
  mu.unlock_shared();
  writer.join();
  reader.join();
  EXPECT_EQ(order, (std::vector<std::string>{"writer", "later reader"}));
  // A writer whose deadline passes holds nothing and lets readers in.
  mu.lock_shared();
  EXPECT_FALSE(mu.try_lock_until(std::chrono::system_clock::now() +
                                 std::chrono::milliseconds(20)));
  std::thread another([&] {
    mu.lock_shared();
    mu.unlock_shared();
  });
  another.join();
  mu.unlock_shared();
}

// An update is applied only if it is still wanted when its turn comes: one
// whose deadline passes while computations run changes nothing (an outside
// tester saw an update applied after its client got DEADLINE_EXCEEDED).
TEST_F(ServerTest, AnUpdatePastItsDeadlineIsNeverApplied) {
  const Mesh mesh = Knight();
  ASSERT_TRUE(client_->Upload(mesh, "held").ok());
  auto session = server_->store().Get("", "held");
  ASSERT_TRUE(session.ok()) << session.status();
  const std::vector<Vec3> moved = Grown(mesh);
  {
    auto reader = (*session)->Read();  // a computation in progress.
    ASSERT_TRUE(reader.ok());
    auto late = (*session)->UpdatePositions(
        0, {}, moved,
        {.deadline = std::chrono::system_clock::now() +
                     std::chrono::milliseconds(100)});
    EXPECT_EQ(late.status().code(), absl::StatusCode::kDeadlineExceeded);
  }
  auto gone = (*session)->UpdatePositions(0, {}, moved,
                                          {.cancelled = [] { return true; }});
  EXPECT_EQ(gone.status().code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(client_->Get("held")->generation, 0);
  // Through the wire: a deadline shorter than a running computation.
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() +
                   std::chrono::milliseconds(200));
  v1::UpdatePositionsRequest req;
  req.set_session_id("held");
  for (const Vec3& p : moved) {
    req.add_positions(p.x);
    req.add_positions(p.y);
    req.add_positions(p.z);
  }
  v1::UpdatePositionsResponse resp;
  {
    auto reader = (*session)->Read();
    EXPECT_EQ(client_->stub().UpdatePositions(&ctx, req, &resp).error_code(),
              grpc::StatusCode::DEADLINE_EXCEEDED);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  EXPECT_EQ(client_->Get("held")->generation, 0);
  ASSERT_TRUE(client_->UpdatePositions("held", 0, 3, moved).ok());
}

// 32 clients computing (each pass holds the session's lock shared) do not
// starve an update: it waits for the passes already running, not for the
// readers to stop (an outside tester's 8 of 8 updates hit their 120 s
// deadline). Checked by order: the update returns while the readers still
// have most of their calls to make.
TEST_F(ServerTest, ThirtyTwoReadersDoNotStarveAnUpdate) {
  const Mesh mesh = Knight();
  ASSERT_TRUE(client_->Upload(mesh, "busy").ok());
  constexpr int kReaders = 32, kCalls = 30;
  std::atomic<int> done{0}, started{0};
  std::vector<std::thread> readers;
  for (int i = 0; i < kReaders; ++i) {
    readers.emplace_back([&, i] {
      client::RemoteClient c(target_);
      for (int k = 0; k < kCalls; ++k) {
        SdfParams p;
        p.rays = 16 + (i + k) % 7;  // a new pass each time (one cached).
        ++started;
        EXPECT_TRUE(c.ComputeSdf("busy", p).ok());
        ++done;
      }
    });
  }
  while (started < 2 * kReaders) std::this_thread::yield();
  auto update = client_->UpdatePositions("busy", 0, 3, Grown(mesh));
  const int done_at_update = done;
  for (std::thread& t : readers) t.join();
  ASSERT_TRUE(update.ok()) << update.status();
  EXPECT_LT(done_at_update, kReaders * kCalls / 2);
}

// A client that stops reading a ComputeSdf stream holds back no update:
// the session's lock is let go before the values are streamed.
TEST_F(ServerTest, AStalledStreamDoesNotBlockAnUpdate) {
  const Mesh sphere = MakeIcosphere(1, 120);  // 144,002 vertices.
  ASSERT_TRUE(client_->Upload(sphere, "stall").ok());
  grpc::ClientContext stalled;
  v1::ComputeSdfRequest req;
  req.set_session_id("stall");
  req.mutable_params()->set_rays(1);
  req.set_chunk_vertices(1);  // ~144k messages: more than any window.
  auto stream = client_->stub().ComputeSdf(&stalled, req);
  v1::ComputeSdfResponse first;
  ASSERT_TRUE(stream->Read(&first));  // then never read again.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  client::ClientOptions o;
  o.deadline_seconds = 20;
  client::RemoteClient c(target_, o);
  auto update = c.UpdatePositions("stall", 0, 3, Grown(sphere));
  EXPECT_TRUE(update.ok()) << update.status();
  stalled.TryCancel();
}

TEST_F(ServerTest, ConcurrentUpdatesOnOneSessionAreSerialised) {
  ASSERT_TRUE(client_->Upload(MakeIcosphere(1, 6), "s").ok());
  const std::vector<Vec3> base = MakeIcosphere(1, 6).positions;
  std::atomic<int> ok{0}, aborted{0};
  std::vector<std::thread> threads;
  for (int c = 0; c < 4; ++c) {
    threads.emplace_back([&, c] {
      client::RemoteClient cl(target_);
      std::vector<Vec3> p = base;
      for (Vec3& v : p) v *= 1 + 0.01 * (c + 1);
      auto r = cl.UpdatePositions("s", 0, 3, p);
      if (r.ok())
        ++ok;
      else if (r.status().code() == absl::StatusCode::kAborted)
        ++aborted;
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(ok, 1);  // exactly one writer wins generation 0 -> 1.
  EXPECT_EQ(aborted, 3);
  EXPECT_EQ(client_->Get("s")->generation, 1);
}

}  // namespace
}  // namespace meshgauge
