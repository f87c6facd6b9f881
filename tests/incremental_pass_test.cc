// Incremental ray passes (SdfEvaluator::Compute with a PreviousPass): after
// position updates of every kind, only some rays are traced and the result
// and hit table equal a fresh full pass at the same positions, bit for bit.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "lib/core/shapes.h"
#include "lib/embree/cone_walk.h"
#include "lib/embree/gradcheck.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Patch;
using testing::SameBits;

struct Pass {
  SdfResult result;
  HitTable hits;
};

Pass Full(const Mesh& mesh, const std::vector<Vec3>& positions,
          const SdfParams& params) {
  Mesh moved = mesh;
  moved.positions = positions;
  auto ev = SdfEvaluator::Create(moved);
  EXPECT_TRUE(ev.ok()) << ev.status();
  Pass pass;
  pass.result = *(*ev)->Compute(params, {}, &pass.hits);
  return pass;
}

// Applies each step's positions to one evaluator, computing each pass from
// the one before, and compares it with a fresh full pass. Returns the rays
// traced per step.
std::vector<int64_t> ExpectIncrementalEqualsFull(
    const Mesh& mesh, const std::vector<std::vector<Vec3>>& steps,
    const SdfParams& params) {
  auto ev = SdfEvaluator::Create(mesh);
  EXPECT_TRUE(ev.ok());
  Pass last;
  last.result = *(*ev)->Compute(params, {}, &last.hits);
  std::vector<int64_t> traced;
  for (size_t i = 0; i < steps.size(); ++i) {
    EXPECT_TRUE((*ev)->UpdatePositions(steps[i]).ok());
    Pass next;
    const PreviousPass previous{&last.result, &last.hits};
    auto r = (*ev)->Compute(params, {}, &next.hits, &previous);
    EXPECT_TRUE(r.ok()) << r.status();
    next.result = std::move(*r);
    const Pass full = Full(mesh, steps[i], params);
    EXPECT_TRUE(SameBits(next.result.values, full.result.values))
        << "step " << i;
    EXPECT_EQ(next.result.status, full.result.status) << "step " << i;
    EXPECT_EQ(next.result.hits, full.result.hits) << "step " << i;
    EXPECT_EQ(next.result.kept, full.result.kept) << "step " << i;
    EXPECT_EQ(next.hits.primitives, full.hits.primitives) << "step " << i;
    EXPECT_EQ(next.hits.kept, full.hits.kept) << "step " << i;
    traced.push_back(next.result.rays_traced);
    last = std::move(next);
  }
  return traced;
}

std::vector<Vec3> Moved(const std::vector<Vec3>& from,
                        const std::vector<int32_t>& which, const Vec3& by) {
  std::vector<Vec3> p = from;
  for (int32_t v : which) p[v] += by;
  return p;
}

TEST(IncrementalPassTest, EveryKindOfUpdateMatchesAFullPass) {
  auto rocker = ReadMesh(testing::SharedMesh("rocker-arm.obj"));
  ASSERT_TRUE(rocker.ok());
  const Mesh& m = *rocker;
  const double d = BoundingBoxDiagonal(m);
  const int64_t nv = m.num_vertices();
  const std::vector<int32_t> patch1 = Patch(m, 100, 0.05 * d);
  const std::vector<int32_t> patch10 = Patch(m, 5000, 0.2 * d);
  std::vector<int32_t> scattered;
  std::mt19937 rng(3);
  for (int i = 0; i < nv / 100; ++i) scattered.push_back(rng() % nv);
  std::sort(scattered.begin(), scattered.end());
  scattered.erase(std::unique(scattered.begin(), scattered.end()),
                  scattered.end());
  std::vector<int32_t> all(nv);
  std::iota(all.begin(), all.end(), 0);

  std::vector<std::vector<Vec3>> steps;
  std::vector<Vec3> p = m.positions;
  // One vertex along its surface (the faces around it flip which rays hit
  // them) and along the normal (its neighbours' normals change).
  p = Moved(p, {1234}, Vec3(3e-3, -2e-3, 1e-3) * d);
  steps.push_back(p);
  // Patches of about 1 % and 10 %, small moves and a move far across the
  // part (its faces cross other vertices' rays).
  p = Moved(p, patch1, Vec3(1e-3, 2e-3, -1e-3) * d);
  steps.push_back(p);
  p = Moved(p, patch10, Vec3(-2e-3, 1e-3, 3e-3) * d);
  steps.push_back(p);
  p = Moved(p, patch1, Vec3(0.05, -0.04, 0.03) * d);
  steps.push_back(p);
  // Scattered vertices; the vertex of largest x pushed out (the bounding
  // box, so the default miss distance, changes).
  p = Moved(p, scattered, Vec3(1e-4, 1e-4, -2e-4) * d);
  steps.push_back(p);
  const int32_t right = static_cast<int32_t>(
      std::max_element(p.begin(), p.end(),
                       [](const Vec3& a, const Vec3& b) { return a.x < b.x; }) -
      p.begin());
  p = Moved(p, {right}, Vec3(0.02, 0, 0) * d);
  steps.push_back(p);
  // Then everything.
  p = Moved(p, all, Vec3(1e-5, 0, 0) * d);
  steps.push_back(p);
  // Back to the start: every earlier move undone.
  steps.push_back(m.positions);
  SdfParams params;
  const std::vector<int64_t> traced =
      ExpectIncrementalEqualsFull(m, steps, params);
  const int64_t full = nv * 100;
  ASSERT_EQ(traced.size(), steps.size());
  EXPECT_LT(traced[0], full / 10);  // one vertex.
  EXPECT_LT(traced[1], full / 10);  // 1 % patch.
  EXPECT_LT(traced[2], full / 2);   // 10 % patch.
  EXPECT_LT(traced[5], full / 2);   // the bounding box grew.
  EXPECT_EQ(traced[6], full);       // all moved: a full pass.
  // A self-hit threshold of 3 mean edge lengths (every update moves it, and
  // many rays meet primitives near it) and a fixed miss distance.
  SdfParams near;
  near.self_hit_epsilon = 3;
  near.max_distance = 0.2 * d;
  const std::vector<int64_t> near_traced =
      ExpectIncrementalEqualsFull(m, steps, near);
  EXPECT_LT(near_traced[1], full / 2);
  for (size_t i = 0; i < traced.size(); ++i) {
    std::printf("step %zu: %lld of %lld rays traced\n", i,
                static_cast<long long>(traced[i]),
                static_cast<long long>(full));
  }
}

TEST(IncrementalPassTest, GeneratedShapesIn2dAnd3dMatchAFullPass) {
  const Mesh torus = MakeTorus(2, 0.5, 64, 24);
  const Mesh twins = testing::WithEveryFaceTwice(MakeTorus(1, 0.4, 40, 20));
  const Mesh circle = MakeHollowSquare(4, 1, 0.01);
  for (const Mesh* mesh : {&torus, &twins, &circle}) {
    const double d = BoundingBoxDiagonal(*mesh);
    std::vector<std::vector<Vec3>> steps;
    std::vector<Vec3> p = mesh->positions;
    p = Moved(p, {3}, Vec3(0.02, -0.01, mesh->dimension == 3 ? 0.01 : 0) * d);
    steps.push_back(p);
    p = Moved(p, Patch(*mesh, mesh->num_vertices() / 2, 0.1 * d),
              Vec3(-0.01, 0.02, 0) * d);
    steps.push_back(p);
    SdfParams params;
    params.rays = 24;
    const std::vector<int64_t> traced =
        ExpectIncrementalEqualsFull(*mesh, steps, params);
    EXPECT_LT(traced[0], mesh->num_vertices() * 24 / 2);  // reused.
  }
}

// A previous pass with other parameters, or without its hit table's
// reuse data, gives a full pass (and the same result).
TEST(IncrementalPassTest, APreviousPassThatDoesNotFitGivesAFullPass) {
  const Mesh torus = MakeTorus(2, 0.5, 48, 16);
  auto ev = SdfEvaluator::Create(torus);
  ASSERT_TRUE(ev.ok());
  Pass narrow;
  SdfParams p30, p60;
  p60.cone_angle_degrees = 60;
  narrow.result = *(*ev)->Compute(p30, {}, &narrow.hits);
  const PreviousPass previous{&narrow.result, &narrow.hits};
  auto wide = (*ev)->Compute(p60, {}, nullptr, &previous);
  ASSERT_TRUE(wide.ok());
  EXPECT_EQ(wide->rays_traced, torus.num_vertices() * 100);
  EXPECT_TRUE(SameBits(wide->values, (*ev)->Compute(p60)->values));
  // Same parameters, nothing moved: nothing traced.
  auto same = (*ev)->Compute(p30, {}, nullptr, &previous);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->rays_traced, 0);
  EXPECT_TRUE(SameBits(same->values, narrow.result.values));
}

// Whether a pass walks cones depends on the positions (a pilot counts the
// walk's work on a few fans), and the walk and Embree may record different
// primitives at a tie: a pass reuses only a pass whose rule chose alike. A
// dense sphere and four small squares whose vertices are the pilot's
// samples (every n/16th vertex): facing away, their rays meet nothing and
// the pass walks cones; turned towards the sphere (two corners swapped),
// their cones meet hundreds of its triangles and the pass streams. The
// sphere's own rays never see the squares, so a pass that chose alike would
// reuse them.
TEST(IncrementalPassTest, APassWhoseRuleChoseAnotherTracerIsNotReused) {
  if (!ConeWalk::Supported()) GTEST_SKIP() << "this CPU has no AVX2 and FMA";
  const Mesh sphere = MakeIcosphere(1.0, 16);  // 5,120 triangles
  Mesh mesh;
  const int64_t n = sphere.num_vertices() + 16;
  mesh.positions.resize(n);
  std::vector<int32_t> index(sphere.num_vertices()), corners;
  for (int64_t v = 0, next = 0; v < n; ++v) {
    if (v == std::ssize(corners) * n / 16 && corners.size() < 16) {
      corners.push_back(static_cast<int32_t>(v));
    } else {
      index[next++] = static_cast<int32_t>(v);
    }
  }
  for (int64_t v = 0; v < sphere.num_vertices(); ++v) {
    mesh.positions[index[v]] = sphere.positions[v];
  }
  for (const Face& f : sphere.faces) {
    mesh.faces.push_back(
        Face::Triangle(index[f.v[0]], index[f.v[1]], index[f.v[2]]));
  }
  // Square k at distance 2 along +-x or +-y, normal (and rays) along the
  // axis: away from the sphere at first.
  const Vec3 axes[4] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  for (int k = 0; k < 4; ++k) {
    const Vec3 a = axes[k];
    const Vec3 u = Vec3(a.y, -a.x, 0) * 0.25, w = Vec3(0, 0, 0.25);
    const Vec3 c = a * 2.0;
    const int32_t* q = &corners[4 * k];
    mesh.positions[q[0]] = c - u - w;
    mesh.positions[q[1]] = c + u - w;
    mesh.positions[q[2]] = c + u + w;
    mesh.positions[q[3]] = c - u + w;
    mesh.faces.push_back(Face::Triangle(q[0], q[1], q[2]));
    mesh.faces.push_back(Face::Triangle(q[0], q[2], q[3]));
  }
  SdfParams params;
  params.cone_angle_degrees = 60;
  auto ev = SdfEvaluator::Create(mesh);
  ASSERT_TRUE(ev.ok()) << ev.status();
  Pass away;
  away.result = *(*ev)->Compute(params, {}, &away.hits);
  EXPECT_LE(away.result.cone_walk_pilot, 8);
  EXPECT_EQ(away.result.samples_cone_walked, n);
  // Each square's rays turned towards the sphere.
  std::vector<Vec3> turned = mesh.positions;
  for (int k = 0; k < 4; ++k) {
    std::swap(turned[corners[4 * k + 1]], turned[corners[4 * k + 3]]);
  }
  ASSERT_TRUE((*ev)->UpdatePositions(turned).ok());
  const PreviousPass previous{&away.result, &away.hits};
  Pass towards;
  auto r = (*ev)->Compute(params, {}, &towards.hits, &previous);
  ASSERT_TRUE(r.ok()) << r.status();
  towards.result = *std::move(r);
  EXPECT_GT(towards.result.cone_walk_pilot, 8);
  EXPECT_EQ(towards.result.samples_cone_walked, 0);
  EXPECT_EQ(towards.result.rays_traced, n * 100);  // nothing reused
  const Pass full = Full(mesh, turned, params);
  EXPECT_TRUE(SameBits(towards.result.values, full.result.values));
  EXPECT_EQ(towards.hits.primitives, full.hits.primitives);
  EXPECT_EQ(towards.hits.kept, full.hits.kept);
  // A pass that chose alike is reused: the squares moved a little further
  // out, the sphere's rays are not traced again.
  for (int32_t v : corners) turned[v] *= 1.01;
  ASSERT_TRUE((*ev)->UpdatePositions(turned).ok());
  const PreviousPass before{&towards.result, &towards.hits};
  auto again = (*ev)->Compute(params, {}, nullptr, &before);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->samples_cone_walked, 0);
  EXPECT_LT(again->rays_traced, n * 100 / 10);
  EXPECT_TRUE(
      SameBits(again->values, Full(mesh, turned, params).result.values));
}

// The thread count is how a pass runs, not a parameter (ComputeControl): a
// pass on one thread serves as the previous pass of one on two, as the
// server's pass cache serves requests whatever their threads.
TEST(IncrementalPassTest, APassOfAnotherThreadCountIsReused) {
  const Mesh torus = MakeTorus(2, 0.5, 32, 12);
  auto ev = SdfEvaluator::Create(torus);
  ASSERT_TRUE(ev.ok());
  Pass one;
  one.result = *(*ev)->Compute({}, {.threads = 1}, &one.hits);
  const PreviousPass previous{&one.result, &one.hits};
  auto two = (*ev)->Compute({}, {.threads = 2}, nullptr, &previous);
  ASSERT_TRUE(two.ok());
  EXPECT_EQ(two->rays_traced, 0);
  EXPECT_TRUE(SameBits(two->values, one.result.values));
}

// gradcheck's probes move one vertex each: they reuse the base pass, so all
// its passes together trace fewer rays than two full passes.
TEST(IncrementalPassTest, GradcheckProbesReuseTheBasePass) {
  auto rocker = ReadMesh(testing::SharedMesh("rocker-arm.obj"));
  ASSERT_TRUE(rocker.ok());
  GradCheckOptions options;
  options.vertices = {10, 5000};
  auto rep = RunGradCheck(*rocker, {}, options);
  ASSERT_TRUE(rep.ok()) << rep.status();
  EXPECT_EQ(rep->full_pass_rays, rocker->num_vertices() * 100);
  EXPECT_LT(rep->rays_traced, 2 * rep->full_pass_rays);  // 13 passes.
  EXPECT_TRUE(rep->Passed());
}

}  // namespace
}  // namespace meshgauge
