// SdfEvaluator: thread-count independence, position updates (refit and
// rebuild), cancellation, and NORMAL_RAY on the thin CAD plate.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <malloc.h>

#include <cstring>

#include "lib/core/shapes.h"
#include "lib/core/table_allocator.h"
#include "lib/embree/sdf.h"
#include "lib/io/mesh_io.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using ::testing::HasSubstr;
using testing::SharedMesh;
using testing::WithEveryFaceTwice;

bool BitIdentical(const SdfResult& a, const SdfResult& b) {
  return a.values.size() == b.values.size() &&
         std::memcmp(a.values.data(), b.values.data(),
                     a.values.size() * sizeof(double)) == 0 &&
         a.hits == b.hits && a.kept == b.kept && a.status == b.status;
}

TEST(EvaluatorTest, OneAndTwoThreadsAreBitIdentical) {
  for (const char* name : {"decimated-knight.off", "teapot.obj"}) {
    auto mesh = ReadMesh(SharedMesh(name));
    ASSERT_TRUE(mesh.ok());
    auto a = ComputeSdf(*mesh, {}, {.threads = 1});
    auto b = ComputeSdf(*mesh, {}, {.threads = 2});
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_TRUE(BitIdentical(*a, *b)) << name;
  }
  // Hub fans (traced by HubFans, not Embree) too.
  for (const Mesh& m : {MakeHollowSquare(4, 1, 0.01), MakeFanCone(1000),
                        MakeFanCylinder(1000)}) {
    EXPECT_TRUE(BitIdentical(*ComputeSdf(m, {}, {.threads = 1}),
                             *ComputeSdf(m, {}, {.threads = 2})));
  }
}

TEST(EvaluatorTest, UpdatePositionsMatchesAFreshComputation) {
  for (BvhUpdatePolicy policy :
       {BvhUpdatePolicy::kRefit, BvhUpdatePolicy::kRebuild}) {
    const Mesh torus = MakeTorus(2, 0.5, 64, 24);
    auto ev = SdfEvaluator::Create(torus, {.bvh_policy = policy});
    ASSERT_TRUE(ev.ok());
    Mesh moved = torus;
    for (Vec3& p : moved.positions) p = Vec3(p.x * 1.1, p.y * 0.9, p.z * 1.3);
    ASSERT_TRUE((*ev)->UpdatePositions(moved.positions).ok());
    EXPECT_EQ((*ev)->generation(), 1);
    auto updated = (*ev)->Compute({});
    auto fresh = ComputeSdf(moved, {});
    ASSERT_TRUE(updated.ok() && fresh.ok());
    EXPECT_TRUE(BitIdentical(*updated, *fresh));
    // A mesh with hub fans, whose trees are rebuilt on every update.
    const Mesh cylinder = MakeFanCylinder(600);
    auto fans = SdfEvaluator::Create(cylinder, {.bvh_policy = policy});
    ASSERT_TRUE(fans.ok());
    Mesh squashed = cylinder;
    for (Vec3& p : squashed.positions) p = Vec3(p.x * 0.7, p.y, p.z * 2 + p.x);
    ASSERT_TRUE((*fans)->UpdatePositions(squashed.positions).ok());
    auto fans_updated = (*fans)->Compute({});
    auto fans_fresh = ComputeSdf(squashed, {});
    ASSERT_TRUE(fans_updated.ok() && fans_fresh.ok());
    EXPECT_TRUE(BitIdentical(*fans_updated, *fans_fresh));
    if (policy == BvhUpdatePolicy::kRefit) {
      EXPECT_EQ((*ev)->refits(), 1);
      EXPECT_EQ((*ev)->builds(), 1);
    } else {
      EXPECT_EQ((*ev)->builds(), 2);
      EXPECT_EQ((*ev)->refits(), 0);
    }
  }
}

// SPEC §3 (2.1): values do not depend on the computation's history. A
// patch moved on a real mesh (rocker-arm: the updated session differed from
// a fresh upload on 4 vertices before the BVH's coordinates and tie rule
// were made functions of the current positions) and on a mesh far from the
// origin, where a refit kept the creation's centroid as the BVH's origin.
std::vector<Vec3> MovePatch(const Mesh& mesh, int64_t centre, double radius,
                            const Vec3& by) {
  std::vector<Vec3> p = mesh.positions;
  for (int32_t v : testing::Patch(mesh, centre, radius)) p[v] += by;
  return p;
}

TEST(EvaluatorTest, AnUpdatedEvaluatorMatchesOneCreatedAtThosePositions) {
  auto rocker = ReadMesh(SharedMesh("rocker-arm.obj"));
  ASSERT_TRUE(rocker.ok());
  Mesh far = MakeTorus(2, 0.5, 64, 24);
  for (Vec3& p : far.positions) p += Vec3(1e4, -3e3, 7e3);
  const Mesh twins = WithEveryFaceTwice(MakeTorus(1.0, 0.4, 40, 20));
  SdfParams params;
  for (const Mesh* mesh : std::vector<const Mesh*>{&*rocker, &far, &twins}) {
    const double d = BoundingBoxDiagonal(*mesh);
    std::vector<std::vector<Vec3>> steps = {
        MovePatch(*mesh, 7, 0.1 * d, Vec3(1e-3, 2e-3, -1e-3) * d)};
    steps.push_back(MovePatch(*mesh, mesh->num_vertices() / 2, 0.2 * d,
                              Vec3(-2e-3, 1e-3, 3e-3) * d));
    for (BvhUpdatePolicy policy :
         {BvhUpdatePolicy::kRefit, BvhUpdatePolicy::kRebuild}) {
      auto ev = SdfEvaluator::Create(*mesh, {.bvh_policy = policy});
      ASSERT_TRUE(ev.ok());
      for (size_t i = 0; i < steps.size(); ++i) {
        ASSERT_TRUE((*ev)->UpdatePositions(steps[i]).ok());
        Mesh moved = *mesh;
        moved.positions = steps[i];
        auto fresh = SdfEvaluator::Create(moved, {.bvh_policy = policy});
        ASSERT_TRUE(fresh.ok());
        auto a = (*ev)->Compute(params);
        auto b = (*fresh)->Compute(params);
        ASSERT_TRUE(a.ok() && b.ok());
        int differ = 0;
        for (int64_t v = 0; v < mesh->num_vertices(); ++v) {
          differ += std::memcmp(&a->values[v], &b->values[v], 8) != 0;
        }
        EXPECT_EQ(differ, 0)
            << "step " << i << " policy " << static_cast<int>(policy)
            << " mesh of " << mesh->num_vertices() << " vertices";
        EXPECT_TRUE(BitIdentical(*a, *b));
      }
    }
  }
}

// An extreme move (one vertex 1e5 bounding-box diagonals away, as an
// attacker sent; from 1e4 on the refitted values differed from fresh ones):
// the updated evaluator equals one created at those positions, or both
// refuse them alike (an edge over 2^16 typical edges, CheckTraceable).
TEST(EvaluatorTest, AnExtremeMoveGivesTheFreshValuesOrTheFreshRefusal) {
  auto knight = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(knight.ok());
  const double d = BoundingBoxDiagonal(*knight);
  for (double away : {1e2, 1e3, 1e4, 1e5, 1e7}) {
    Mesh moved = *knight;
    moved.positions[0] += Vec3(away * d, 0.5 * away * d, 0);
    for (BvhUpdatePolicy policy :
         {BvhUpdatePolicy::kRefit, BvhUpdatePolicy::kRebuild}) {
      SCOPED_TRACE(::testing::Message() << "away " << away << " policy "
                                        << static_cast<int>(policy));
      auto ev = SdfEvaluator::Create(*knight, {.bvh_policy = policy});
      ASSERT_TRUE(ev.ok());
      const absl::Status update = (*ev)->UpdatePositions(moved.positions);
      auto fresh = SdfEvaluator::Create(moved, {.bvh_policy = policy});
      ASSERT_EQ(update.ok(), fresh.ok()) << update << " vs " << fresh.status();
      EXPECT_EQ(update.ok(), away < 1e4) << update;
      if (!update.ok()) {
        EXPECT_EQ(update.code(), fresh.status().code());
        EXPECT_THAT(std::string(update.message()), HasSubstr("median"));
        continue;
      }
      auto a = (*ev)->Compute({});
      auto b = (*fresh)->Compute({});
      ASSERT_TRUE(a.ok() && b.ok());
      int differ = 0;
      for (int64_t v = 0; v < knight->num_vertices(); ++v) {
        differ += std::memcmp(&a->values[v], &b->values[v], 8) != 0;
      }
      EXPECT_EQ(differ, 0);
      EXPECT_TRUE(BitIdentical(*a, *b));
    }
  }
}

// The same positions through two BVHs: one built at them, one built at other
// positions (same centroid) and refitted, so that the traversal meets tied
// primitives in other orders. The pick does not depend on that order.
TEST(EvaluatorTest, TiedPrimitivesArePickedTheSameWayByEveryBvh) {
  const Mesh twins = WithEveryFaceTwice(MakeTorus(1.0, 0.4, 40, 20));
  Mesh squashed = twins;
  for (Vec3& p : squashed.positions) p = Vec3(p.x * 1.3, p.y * 0.6, p.z * 2);
  auto built = SdfEvaluator::Create(twins);
  auto refit = SdfEvaluator::Create(squashed);
  ASSERT_TRUE(built.ok() && refit.ok());
  ASSERT_TRUE((*refit)->UpdatePositions(twins.positions).ok());
  HitTable ha, hb;
  auto a = (*built)->Compute({}, {}, &ha);
  auto b = (*refit)->Compute({}, {}, &hb);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_TRUE(BitIdentical(*a, *b));
  EXPECT_EQ(ha.primitives, hb.primitives);
}

// rebuild_every_updates = 3: generations 3 and 6 are built from scratch at
// their positions, the others refitted; each update counts once. An
// evaluator created at generation 4 from generation 3's positions (as a
// replica restores a session) then gives the same values at generation 5
// as the one that made every update.
TEST(EvaluatorTest, TheRebuildCadenceIsAnOptionCountedFromGenerationZero) {
  const Mesh torus = MakeTorus(2, 0.5, 48, 16);
  auto ev = SdfEvaluator::Create(torus, {.rebuild_every_updates = 3});
  ASSERT_TRUE(ev.ok());
  std::vector<std::vector<Vec3>> positions = {torus.positions};
  for (int g = 1; g <= 6; ++g) {
    std::vector<Vec3> p = positions.back();
    for (Vec3& x : p) x = Vec3(x.x * 1.05, x.y, x.z * (1 + 0.02 * g));
    positions.push_back(p);
    ASSERT_TRUE((*ev)->UpdatePositions(p).ok());
    EXPECT_EQ((*ev)->builds(), 1 + g / 3) << g;
    EXPECT_EQ((*ev)->refits(), g - g / 3) << g;
    EXPECT_EQ(IsBvhBase(g, 3), g % 3 == 0);
    if (g == 5) {
      Mesh base = torus;
      base.positions = positions[3];
      auto restored = SdfEvaluator::Create(
          base, {.rebuild_every_updates = 3, .generation = 4});
      ASSERT_TRUE(restored.ok());
      ASSERT_TRUE((*restored)->UpdatePositions(p).ok());
      EXPECT_EQ((*restored)->generation(), 5);
      EXPECT_EQ((*restored)->refits(), 1);
      auto a = (*ev)->Compute({}), b = (*restored)->Compute({});
      ASSERT_TRUE(a.ok() && b.ok());
      EXPECT_TRUE(BitIdentical(*a, *b));
    }
  }
  EXPECT_FALSE(IsBvhBase(3, 0));
  EXPECT_EQ(SdfEvaluator::Create(torus, {.rebuild_every_updates = -1})
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(EvaluatorTest, SubsetUpdateMovesOnlyThoseVertices) {
  const Mesh sphere = MakeIcosphere(1, 6);
  auto ev = SdfEvaluator::Create(sphere);
  ASSERT_TRUE(ev.ok());
  const std::vector<int32_t> idx = {3, 10};
  const std::vector<Vec3> pos = {sphere.positions[3] * 1.01,
                                 sphere.positions[10] * 0.99};
  ASSERT_TRUE((*ev)->UpdatePositions(idx, pos).ok());
  Mesh expected = sphere;
  expected.positions[3] = pos[0];
  expected.positions[10] = pos[1];
  EXPECT_EQ((*ev)->mesh().positions, expected.positions);
  EXPECT_TRUE(BitIdentical(*(*ev)->Compute({}), *ComputeSdf(expected, {})));
}

TEST(EvaluatorTest, RejectsWrongPositionCount) {
  auto ev = SdfEvaluator::Create(MakeIcosphere(1, 2));
  ASSERT_TRUE(ev.ok());
  const std::vector<Vec3> few(3);
  EXPECT_THAT(std::string((*ev)->UpdatePositions(few).message()),
              HasSubstr("expected 42 positions, got 3"));
  EXPECT_EQ((*ev)->generation(), 0);
}

TEST(EvaluatorTest, RejectsNonFinitePositionsAndKeepsOldOnes) {
  const Mesh sphere = MakeIcosphere(1, 2);
  auto ev = SdfEvaluator::Create(sphere);
  ASSERT_TRUE(ev.ok());
  std::vector<Vec3> bad = sphere.positions;
  bad[7].x = std::numeric_limits<double>::quiet_NaN();
  const absl::Status s = (*ev)->UpdatePositions(bad);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.message()), HasSubstr("non-finite"));
  EXPECT_EQ((*ev)->mesh().positions, sphere.positions);
  EXPECT_EQ((*ev)->generation(), 0);
}

TEST(EvaluatorTest, RejectsAMeshBeyondTheRayTracersRangeAndKeepsOldOnes) {
  // Embree asserts (aborting the process) on coordinates beyond ~1.8e18.
  Mesh huge = MakeIcosphere(1, 2);
  for (Vec3& p : huge.positions) p *= 1e18;
  ASSERT_TRUE(ValidateMesh(huge).ok());
  auto refused = SdfEvaluator::Create(huge);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(refused.status().message()), HasSubstr("rescale"));
  const Mesh sphere = MakeIcosphere(1, 2);
  auto ev = SdfEvaluator::Create(sphere);
  ASSERT_TRUE(ev.ok());
  const absl::Status s = (*ev)->UpdatePositions(huge.positions);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ((*ev)->mesh().positions, sphere.positions);
  EXPECT_EQ((*ev)->generation(), 0);
  // Radius 1e13: Embree's triangle test overflows float, no ray hits.
  for (Vec3& p : huge.positions) p *= 1e-5;
  EXPECT_EQ(SdfEvaluator::Create(huge).status().code(),
            absl::StatusCode::kInvalidArgument);
  // An unused vertex far away is not a face's (UnusedVerticesDoNotMoveThe
  // TracersOrigin).
  Mesh stray = MakeIcosphere(1, 2);
  stray.positions.push_back({1e30, 0, 0});
  ASSERT_TRUE(ValidateMesh(stray).ok());
  EXPECT_TRUE(SdfEvaluator::Create(stray).ok());
  // An update moving the whole (small) mesh far from where it was built.
  std::vector<Vec3> moved = sphere.positions;
  for (Vec3& p : moved) p += Vec3{1e19, 0, 0};
  EXPECT_EQ((*ev)->UpdatePositions(moved).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ((*ev)->mesh().positions, sphere.positions);
  // Radius 2e12 computes every value.
  Mesh large = MakeIcosphere(1, 2);
  for (Vec3& p : large.positions) p *= 2e12;
  auto ok = SdfEvaluator::Create(large);
  ASSERT_TRUE(ok.ok()) << ok.status();
  auto values = (*ok)->Compute({});
  ASSERT_TRUE(values.ok());
  EXPECT_EQ(values->CountStatus(VertexStatus::kOk), large.num_vertices());
}

// Outsider report: a unit tetrahedron with an unused vertex at (1e9, 1e9,
// 1e9) lost every value, as the tracer's origin (the vertices' centroid)
// moved to 2.5e8, where single precision cannot resolve the tetrahedron.
TEST(EvaluatorTest, UnusedVerticesDoNotMoveTheTracersOrigin) {
  Mesh tet;
  tet.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  tet.faces = {Face::Triangle(0, 2, 1), Face::Triangle(0, 1, 3),
               Face::Triangle(0, 3, 2), Face::Triangle(1, 2, 3)};
  Mesh stray = tet;
  stray.positions.push_back({1e9, 1e9, 1e9});
  ASSERT_TRUE(ValidateMesh(stray).ok());
  auto ev = SdfEvaluator::Create(tet);
  auto stray_ev = SdfEvaluator::Create(stray);
  ASSERT_TRUE(ev.ok() && stray_ev.ok());
  EXPECT_EQ((*stray_ev)->scene().origin(), (*ev)->scene().origin());
  auto values = (*ev)->Compute({});
  auto stray_values = (*stray_ev)->Compute({});
  ASSERT_TRUE(values.ok() && stray_values.ok());
  EXPECT_EQ(values->CountStatus(VertexStatus::kOk), 4);
  EXPECT_EQ(stray_values->status[4], VertexStatus::kNoFaces);
  for (int v = 0; v < 4; ++v) {
    EXPECT_EQ(stray_values->values[v], values->values[v]) << v;
  }
}

TEST(EvaluatorTest, RejectsUpdateCollapsingAFace) {
  const Mesh sphere = MakeIcosphere(1, 2);
  auto ev = SdfEvaluator::Create(sphere);
  ASSERT_TRUE(ev.ok());
  const Face& f = sphere.faces[0];
  const std::vector<int32_t> idx = {f.v[1]};
  const std::vector<Vec3> pos = {sphere.positions[f.v[0]]};
  EXPECT_THAT(std::string((*ev)->UpdatePositions(idx, pos).message()),
              HasSubstr("zero area"));
}

TEST(EvaluatorTest, RejectsRepeatedOrOutOfRangeSubsetIndices) {
  auto ev = SdfEvaluator::Create(MakeIcosphere(1, 2));
  ASSERT_TRUE(ev.ok());
  const std::vector<Vec3> pos(2, Vec3(0, 0, 2));
  EXPECT_THAT(
      std::string(
          (*ev)->UpdatePositions(std::vector<int32_t>{1, 1}, pos).message()),
      HasSubstr("repeated"));
  EXPECT_THAT(
      std::string(
          (*ev)->UpdatePositions(std::vector<int32_t>{1, 99}, pos).message()),
      HasSubstr("out of range"));
}

TEST(EvaluatorTest, CancellationStopsTheComputation) {
  auto ev = SdfEvaluator::Create(MakeIcosphere(1, 20));
  ASSERT_TRUE(ev.ok());
  ComputeControl control;
  int polls = 0;
  control.cancelled = [&polls] { return ++polls > 3; };
  EXPECT_EQ((*ev)->Compute({}, control).status().code(),
            absl::StatusCode::kCancelled);
}

TEST(EvaluatorTest, ProgressReachesTotal) {
  auto ev = SdfEvaluator::Create(MakeIcosphere(1, 10));
  ASSERT_TRUE(ev.ok());
  int64_t last = 0, total = 0;
  ComputeControl control;
  control.progress = [&](int64_t done, int64_t all) {
    EXPECT_GE(done, last);
    last = done;
    total = all;
  };
  ASSERT_TRUE((*ev)->Compute({}, control).ok());
  EXPECT_EQ(last, total);
  EXPECT_EQ(total, (*ev)->mesh().num_vertices());
}

TEST(EvaluatorTest, HitTableMatchesValuesAndRecordsGeneration) {
  auto ev = SdfEvaluator::Create(MakeIcosphere(1, 3));
  ASSERT_TRUE(ev.ok());
  HitTable hits;
  auto with = (*ev)->Compute({}, {}, &hits);
  auto without = (*ev)->Compute({});
  ASSERT_TRUE(with.ok() && without.ok());
  EXPECT_EQ(with->values, without->values);
  const int64_t nv = (*ev)->mesh().num_vertices();
  EXPECT_EQ(hits.primitives.size(), static_cast<size_t>(nv * 100));
  EXPECT_EQ(hits.kept.size(), static_cast<size_t>(nv * 100));
  EXPECT_EQ(hits.generation, 0);
  for (int64_t p = 0; p < nv; ++p) {
    int kept = 0;
    for (uint8_t k : hits.KeptRow(p)) kept += k;
    EXPECT_EQ(kept, with->kept[p]);
  }
  std::vector<Vec3> p = (*ev)->mesh().positions;
  for (Vec3& v : p) v *= 1.01;
  ASSERT_TRUE((*ev)->UpdatePositions(p).ok());
  HitTable moved;
  ASSERT_TRUE((*ev)->Compute({}, {}, &moved).ok());
  EXPECT_EQ(moved.generation, 1);
}

// The hit table is allocated without initialization and each sample's row
// written by the worker that takes it: a sample that traces no ray (here a
// vertex without faces) still gets a row of misses. glibc's perturbation
// fills fresh allocations with 0xa5 so that an unwritten row shows (under
// AddressSanitizer, whose mallopt does nothing, its own fill of a fresh
// allocation's first 4 KiB with 0xbe covers row 0). The table stays below
// TableAllocator::kHugeBytes, whose mapped pages would read as zeros.
TEST(EvaluatorTest, AVertexWithoutFacesGetsAnEmptyHitRow) {
  Mesh mesh = MakeIcosphere(1, 2);
  mesh.positions.insert(mesh.positions.begin(), Vec3(0.1, 0.2, 0.3));
  for (Face& f : mesh.faces) {
    for (int k = 0; k < f.size; ++k) ++f.v[k];
  }
  auto ev = SdfEvaluator::Create(mesh);
  ASSERT_TRUE(ev.ok()) << ev.status();
  HitTable hits;
  mallopt(M_PERTURB, 0x5a);
  auto sdf = (*ev)->Compute({}, {}, &hits);
  mallopt(M_PERTURB, 0);
  ASSERT_LT(hits.primitives.size() * sizeof(int32_t),
            TableAllocator<int32_t>::kHugeBytes);
  ASSERT_TRUE(sdf.ok()) << sdf.status();
  EXPECT_EQ(sdf->status[0], VertexStatus::kNoFaces);
  EXPECT_THAT(hits.Row(0), ::testing::Each(-1));
  EXPECT_THAT(hits.KeptRow(0), ::testing::Each(0));
  EXPECT_EQ(hits.near[0], 0);
  // Every other vertex's rays hit the sphere.
  EXPECT_THAT(hits.Row(1), ::testing::Each(::testing::Ge(0)));
}

// SPEC §4 ignores hits closer than eps_self * h in double precision.
// Outsider report: on an unwelded mesh a vertex got 3.7e-15 from a
// neighbouring copy's face, whose single-precision distance had cleared the
// threshold. Here a small triangle lies under the top centre of a unit box
// at 1e-9 .. 6.4e-8 below t_min in double precision; single precision puts
// some of them past t_min. The normal ray ignores every one of them and
// meets the bottom at 1.
TEST(EvaluatorTest, HitsBelowTheSelfHitThresholdInDoubleAreIgnored) {
  const Mesh box = MakeBox(1, 1, 1, 0.5);
  int32_t top = -1;
  for (int32_t v = 0; v < box.num_vertices(); ++v) {
    if (box.positions[v] == Vec3(0.5, 0.5, 1)) top = v;
  }
  ASSERT_GE(top, 0);
  SdfParams params;
  params.method = SdfMethod::kNormalRay;
  params.self_hit_epsilon = 1e-3;
  int past_in_single = 0;
  for (int k = 1; k <= 64; ++k) {
    Mesh mesh = box;
    const int32_t n = static_cast<int32_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(),
                          {{0.45, 0.45, 0}, {0.6, 0.47, 0}, {0.48, 0.6, 0}});
    mesh.faces.push_back(Face::Triangle(n, n + 1, n + 2));
    const double t_min = params.self_hit_epsilon * MeanEdgeLength(mesh);
    for (int i = n; i < n + 3; ++i)
      mesh.positions[i].z = 1 - (t_min - k * 1e-9);
    auto ev = SdfEvaluator::Create(mesh);
    ASSERT_TRUE(ev.ok());
    const RayScene::Hit raw = (*ev)->scene().Intersect(
        mesh.positions[top], Vec3(0, 0, -1), static_cast<float>(t_min), 10);
    past_in_single += raw.prim == std::ssize((*ev)->topology().primitives) - 1;
    auto r = (*ev)->Compute(params);
    ASSERT_TRUE(r.ok());
    ASSERT_EQ(r->status[top], VertexStatus::kOk) << k;
    EXPECT_EQ(r->values[top], 1) << k;
  }
  // Else the test would not test the double-precision rule.
  EXPECT_GT(past_in_single, 0);
}

// The tray is a 3.175 mm plate: NORMAL_RAY gives exactly the plate thickness
// at every vertex whose faces all lie in the two large faces.
TEST(EvaluatorTest, TrayNormalRayIsPlateThickness) {
  auto mesh = ReadMesh(SharedMesh("1002_tray_bottom.STL"));
  ASSERT_TRUE(mesh.ok());
  SdfParams params;
  params.method = SdfMethod::kNormalRay;
  auto r = ComputeSdf(*mesh, params);
  ASSERT_TRUE(r.ok());
  const MeshTopology topo = MeshTopology::Build(*mesh);
  int flat = 0;
  for (int64_t v = 0; v < mesh->num_vertices(); ++v) {
    bool all_flat = true;
    for (int32_t f : topo.vertex_faces.Of(v)) {
      const Face& face = mesh->faces[f];
      const Vec3 n =
          Cross(mesh->positions[face.v[1]] - mesh->positions[face.v[0]],
                mesh->positions[face.v[2]] - mesh->positions[face.v[0]]);
      all_flat &= std::abs(n.y) > (1 - 1e-9) * Norm(n);
    }
    if (!all_flat) continue;
    ++flat;
    ASSERT_EQ(r->status[v], VertexStatus::kOk) << v;
    EXPECT_NEAR(r->values[v], 3.175, 1e-5) << v;
  }
  EXPECT_GT(flat, 0);
  std::printf("tray: %d vertices inside the large faces, all at 3.175\n", flat);
}

// The server claims EstimatePassBytes before a pass and then accounts
// PassBytes of what the pass holds: they agree for every kind of pass
// (vertices and faces, 3D quads split in two, 2D, opposite points, the
// inscribed ball's one "ray").
TEST(EvaluatorTest, EstimatePassBytesIsWhatAPassHolds) {
  SdfParams faces, opposite, sphere, rays;
  faces.samples = SampleSet::kFaces;
  opposite.opposite_points = true;
  sphere.method = SdfMethod::kSphere;
  rays.rays = 37;
  const Mesh meshes[] = {MakeBox(1, 2, 3, 0.5, /*quads=*/true),
                         MakeCircle(1, 40)};
  for (const Mesh& mesh : meshes) {
    auto ev = SdfEvaluator::Create(mesh);
    ASSERT_TRUE(ev.ok()) << ev.status();
    for (const SdfParams& params :
         {SdfParams{}, faces, opposite, sphere, rays}) {
      HitTable hits;
      auto pass = (*ev)->Compute(params, {}, &hits);
      ASSERT_TRUE(pass.ok()) << pass.status();
      EXPECT_EQ(EstimatePassBytes(mesh, params), PassBytes(*pass, hits))
          << "dimension " << mesh.dimension << ", method "
          << static_cast<int>(params.method) << ", samples "
          << static_cast<int>(params.samples) << ", rays " << params.rays;
    }
  }
}

}  // namespace
}  // namespace meshgauge
