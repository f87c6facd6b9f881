// Rays started past an empty tangent ball (lib/embree/ray_start.h, issue
// 52): the ball holds no primitive of any ray, and a pass gives the same
// bits as one whose rays start at the surface, on every test mesh. The
// passes here ask for the starts (kPastEmptyBall): most are too small for
// kAuto to take them.
#include "lib/embree/ray_start.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <string>
#include <tuple>

#include "lib/core/normals.h"
#include "lib/core/shapes.h"
#include "lib/core/topology.h"
#include "lib/core/vertex_cone.h"
#include "lib/embree/ball_tree.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "tests/pass_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::ExpectSameBits;
using testing::IncrementalPass;
using testing::Moved;
using testing::Pass;
using testing::PassFrom;
using testing::SameBits;
using testing::Traced;

// Every pass here traces in packets, so that the starts alone differ: a
// pass left to choose would walk the cones of small scenes from the
// surface, whose hit tables may differ at ties (RayTraversalTest).
constexpr FanTraversal kPackets = FanTraversal::kPackets;

// The pass past empty balls, checked bit for bit against the pass whose
// rays start at the surface (`what` names the case in a failure).
Pass PassPastBallsAsFromTheSurface(const Mesh& mesh, const SdfParams& params,
                                   const std::string& what) {
  Pass ball = PassFrom(
      mesh, params,
      {.ray_start = RayStartMode::kPastEmptyBall, .fan_traversal = kPackets});
  ExpectSameBits(ball,
                 PassFrom(mesh, params,
                          {.ray_start = RayStartMode::kSurface,
                           .fan_traversal = kPackets}),
                 what);
  return ball;
}

// Two unit icospheres, the second moved by `offset`, each with vertices of
// its own.
Mesh TwoSpheres(const Vec3& offset) {
  const Mesh sphere = MakeIcosphere(1, 8);
  Mesh mesh = sphere;
  const int32_t n = sphere.num_vertices();
  for (const Vec3& q : sphere.positions) mesh.positions.push_back(q + offset);
  for (Face f : sphere.faces) {
    for (int k = 0; k < f.size; ++k) f.v[k] += n;
    mesh.faces.push_back(f);
  }
  return mesh;
}

TEST(RayStartTest, EveryTestMeshGivesTheBitsOfRaysStartedAtTheSurface) {
  testing::ForEachTestMeshAndAngle(
      {"igea-triangles.ply", "horse.ply", "stanford-bunny.obj",
       "rocker-arm.obj", "fandisk.obj", "spot_triangulated.obj", "teapot.obj",
       "decimated-knight.off", "1002_tray_bottom.STL"},
      [](const Mesh& mesh, const SdfParams& params, const std::string& what) {
        const Pass ball = PassFrom(mesh, params,
                                   {.ray_start = RayStartMode::kPastEmptyBall,
                                    .fan_traversal = kPackets});
        const Pass surface = PassFrom(
            mesh, params,
            {.ray_start = RayStartMode::kSurface, .fan_traversal = kPackets});
        ExpectSameBits(ball, surface, what);
        EXPECT_EQ(surface.result.samples_past_ball, 0) << what;
        // Most samples start past a ball (thin or crowded places fall back).
        EXPECT_GT(ball.result.samples_past_ball, Traced(ball.result) / 2)
            << what;
      });
}

TEST(RayStartTest, FaceSamplesAndWideConesGiveTheSameBits) {
  const Mesh mesh = *ReadMesh(testing::SharedMesh("rocker-arm.obj"));
  SdfParams params;
  params.rays = 32;
  params.samples = SampleSet::kFaces;
  const Pass ball = PassPastBallsAsFromTheSurface(mesh, params, "faces");
  EXPECT_GT(ball.result.samples_past_ball, Traced(ball.result) / 2);
  params.samples = SampleSet::kVertices;
  params.cone_angle_degrees = 150;
  const Pass wide = PassPastBallsAsFromTheSurface(mesh, params, "150");
  EXPECT_GT(wide.result.samples_past_ball, 0);
}

// A curve's pass (traced against its extrusion) starts its rays at the
// curve whatever the mode, in a pass that kAuto would take for 3D: the
// certificate is for 3D primitives.
TEST(RayStartTest, ACurvesPassStartsAtTheCurve) {
  const Mesh circle = MakeCircle(1, 10000);
  SdfParams params;
  const Pass surface = PassFrom(
      circle, params,
      {.ray_start = RayStartMode::kSurface, .fan_traversal = kPackets});
  ASSERT_GE(surface.result.rays_traced,
            std::max<int64_t>(int64_t{1} << 18, 8 * circle.num_faces()));
  for (RayStartMode mode :
       {RayStartMode::kPastEmptyBall, RayStartMode::kAuto}) {
    const Pass pass = PassFrom(circle, params, {.ray_start = mode});
    ExpectSameBits(pass, surface, "2D");
    EXPECT_EQ(pass.result.samples_past_ball, 0);
  }
}

// A second copy of the sphere on the first, with vertices of its own: each
// sample has primitives through it that it does not exclude, so no ball is
// empty and every sample falls back.
TEST(RayStartTest, ACoincidentSurfaceLeavesNoBall) {
  const Mesh mesh = TwoSpheres(Vec3());
  SdfParams params;
  params.rays = 32;
  const Pass ball = PassPastBallsAsFromTheSurface(mesh, params, "twice");
  EXPECT_EQ(ball.result.samples_past_ball, 0);
}

// The teapot's OBJ repeats the vertices of its seams: at each of those
// samples another vertex's primitives touch the sample, so no ball is
// certified there (as in ACoincidentSurfaceLeavesNoBall), and every other
// sample finds one.
TEST(RayStartTest, TheTeapotFallsBackExactlyAtItsRepeatedVertices) {
  const Mesh mesh = *ReadMesh(testing::SharedMesh("teapot.obj"));
  std::map<std::tuple<double, double, double>, int> at;
  for (const Vec3& x : mesh.positions) ++at[{x.x, x.y, x.z}];
  int64_t repeated = 0;
  for (const Vec3& x : mesh.positions) repeated += at[{x.x, x.y, x.z}] > 1;
  ASSERT_GT(repeated, 0);
  SdfParams params;
  params.rays = 24;
  const Pass ball = PassPastBallsAsFromTheSurface(mesh, params, "teapot");
  EXPECT_EQ(Traced(ball.result) - ball.result.samples_past_ball, repeated);
}

// The ball EmptyBall returns holds no admissible point of any primitive but
// the excluded ones (checked against every primitive), and nothing but them
// comes within ApexRadius of the sample.
TEST(RayStartTest, TheBallHoldsNoPrimitiveBesidesTheOneRing) {
  std::vector<std::pair<std::string, Mesh>> meshes;
  meshes.emplace_back("knight", testing::Knight());
  meshes.emplace_back("box", MakeBox(2, 2, 1, 0.25));
  meshes.emplace_back("jittered torus",
                      testing::Jitter(MakeTorus(1, 0.3, 48, 24), 0.01));
  for (const auto& [name, mesh] : meshes) {
    const MeshTopology topo = MeshTopology::Build(mesh);
    auto tree = BallTree::Create(mesh, topo);
    ASSERT_TRUE(tree.ok());
    auto ev = SdfEvaluator::Create(mesh);
    ASSERT_TRUE(ev.ok());
    SdfParams params;
    params.rays = 32;
    const ResolvedParams resolved = ResolveParams(params, 3);
    const std::vector<ConeRay> cone = *MakeCone(
        3, resolved.aperture_radians, resolved.rays, resolved.min_weight_angle);
    const RayStarts starts(cone);
    ASSERT_FALSE(starts.empty());
    RayScene::FanLimits limits;
    limits.t_min = static_cast<float>(1e-6 * MeanEdgeLength(mesh));
    limits.t_near = limits.t_min / 2;
    limits.near_below = limits.t_min;
    const Vec3 origin = SceneOrigin(mesh);
    const double cap = BoundingBoxDiagonal(mesh) / 2;
    std::vector<int32_t> excluded;
    int64_t balls = 0;
    for (int64_t p = 0; p < mesh.num_vertices(); ++p) {
      const VertexCone vc = MakeVertexCone(
          mesh, topo, p,
          UnnormalizedNormal(mesh, topo, p, NormalWeighting::kArea));
      if (!vc.valid) continue;
      OneRingPrimitives(topo, p, &excluded);
      const Vec3& x = mesh.positions[p];
      const double reach = MaxAbs(x - origin);
      // A large cap: the ball shrinks to the nearest admissible point.
      const double r = starts.EmptyBall(**ev, **tree, x, vc.frame.axis,
                                        excluded, cap, reach, limits);
      if (r == 0) continue;
      ++balls;
      const double apex = RayStarts::ApexRadius(reach, limits);
      for (int32_t prim = 0; prim < std::ssize(topo.primitives); ++prim) {
        if (std::binary_search(excluded.begin(), excluded.end(), prim)) {
          continue;
        }
        PrimitiveCorners pc = (*ev)->Corners(prim);
        EXPECT_GE(
            MinimumTangentBall(pc, x, vc.frame.axis, starts.cos_beta()).radius,
            r)
            << name << " vertex " << p << " primitive " << prim;
        pc.a = pc.a - x;
        pc.b = pc.b - x;
        pc.c = pc.c - x;
        EXPECT_FALSE(ClosestPointWithin(pc, Vec3(), apex))
            << name << " vertex " << p << " primitive " << prim;
      }
    }
    EXPECT_GT(balls, mesh.num_vertices() / 2) << name;
  }
}

// A small triangle, not connected to the mesh, wholly behind the tangent
// plane of a vertex and closer to it than the traced ray may stray from
// the rays' cone (reach 2^-21 (1 + 1 / (sin 0.02 - 2^-20)), ray_start.h,
// computed here from the rounding, not by ApexRadius): that vertex gets no
// ball. (Its axis-aligned box still reaches above the tangent plane: the
// walk's near radius alone is tested by the next test.)
TEST(RayStartTest, ATriangleBehindTheSampleWithinTheRoundingLeavesNoBall) {
  Mesh mesh = MakeBox(1, 1, 1, 0.25);
  const MeshTopology before = MeshTopology::Build(mesh);
  const int32_t p = 7;
  const Vec3 x = mesh.positions[p];
  const VertexCone vc = MakeVertexCone(
      mesh, before, p,
      UnnormalizedNormal(mesh, before, p, NormalWeighting::kArea));
  ASSERT_TRUE(vc.valid);
  const Vec3& axis = vc.frame.axis;
  Vec3 across = Cross(axis, Vec3(1, 0, 0));
  if (Norm(across) < 0.5) across = Cross(axis, Vec3(0, 1, 0));
  across = across / Norm(across);
  const Vec3 side = Cross(axis, across);
  RayScene::FanLimits limits;
  limits.t_min = static_cast<float>(1e-6 * MeanEdgeLength(mesh));
  limits.t_near = limits.t_min / 2;
  limits.near_below = limits.t_min;
  const double reach = MaxAbs(x - SceneOrigin(mesh));
  const double stray = reach * 0x1p-21 * (1 + 1 / (std::sin(0.02) - 0x1p-20));
  const double gap = stray / 2;  // the nearest corner, gap * sqrt(2) away.
  const int32_t first = mesh.num_vertices();
  mesh.positions.push_back(x + across * gap - axis * gap);
  mesh.positions.push_back(x + across * (gap + 0.1) - axis * 0.05);
  mesh.positions.push_back(x + across * (gap + 0.1) - axis * 0.05 + side * 0.1);
  mesh.faces.push_back(Face::Triangle(first, first + 1, first + 2));
  const MeshTopology topo = MeshTopology::Build(mesh);
  auto tree = BallTree::Create(mesh, topo, BallTree::Build::kMorton);
  auto ev = SdfEvaluator::Create(mesh);
  ASSERT_TRUE(tree.ok() && ev.ok());
  SdfParams params;
  params.rays = 32;
  const ResolvedParams resolved = ResolveParams(params, 3);
  const RayStarts starts(*MakeCone(3, resolved.aperture_radians, resolved.rays,
                                   resolved.min_weight_angle));
  std::vector<int32_t> excluded;
  OneRingPrimitives(topo, p, &excluded);
  EXPECT_EQ(
      starts.EmptyBall(**ev, **tree, x, axis, excluded, 0.2, reach, limits), 0);
  // Without the triangle the same vertex gets one.
  Mesh plain = MakeBox(1, 1, 1, 0.25);
  auto plain_tree = BallTree::Create(plain, before, BallTree::Build::kMorton);
  auto plain_ev = SdfEvaluator::Create(plain);
  ASSERT_TRUE(plain_tree.ok() && plain_ev.ok());
  OneRingPrimitives(before, p, &excluded);
  EXPECT_GT(starts.EmptyBall(**plain_ev, **plain_tree, x, axis, excluded, 0.2,
                             reach, limits),
            0);
}

// BallTree::Visit with a near radius visits every primitive within it of
// the point, whatever the ball and the cone (checked against all).
TEST(RayStartTest, TheTreeVisitsEveryPrimitiveWithinTheNearRadius) {
  const Mesh mesh = testing::Knight();
  const MeshTopology topo = MeshTopology::Build(mesh);
  const double near = 0.05 * BoundingBoxDiagonal(mesh);
  for (BallTree::Build build :
       {BallTree::Build::kSah, BallTree::Build::kMorton}) {
    auto tree = BallTree::Create(mesh, topo, build);
    ASSERT_TRUE(tree.ok());
    for (int64_t p = 0; p < mesh.num_vertices(); p += 7) {
      const Vec3& x = mesh.positions[p];
      const ContactCone cone = MakeContactCone(Vec3(0, 0, 1), 0.95);
      std::vector<uint8_t> seen(topo.primitives.size(), 0);
      (*tree)->Visit(
          x, cone, 1e-9,
          [&](int32_t prim) {
            seen[prim] = 1;
            return 1e-9;
          },
          near);
      for (int32_t prim = 0; prim < std::ssize(topo.primitives); ++prim) {
        PrimitiveCorners pc = CornersOf(mesh, topo.primitives[prim]);
        pc.a = pc.a - x;
        pc.b = pc.b - x;
        pc.c = pc.c - x;
        if (ClosestPointWithin(pc, Vec3(), near)) {
          EXPECT_TRUE(seen[prim]) << "vertex " << p << " primitive " << prim;
        }
      }
    }
  }
}

// Two parts far apart: the scene's origin lies between them, so a part's
// coordinates are about 2^11 of its balls (ray_start.h's smallest), where
// the margins against rounding are thinnest.
TEST(RayStartTest, PartsFarFromTheSceneOriginGiveTheSameBits) {
  const Mesh mesh = TwoSpheres(Vec3(400, 0, 0));
  SdfParams params;
  params.rays = 32;
  const Pass ball = PassPastBallsAsFromTheSurface(mesh, params, "far");
  EXPECT_GT(ball.result.samples_past_ball, Traced(ball.result) / 2);
}

// kAuto (the default) starts rays past balls in a pass of a million rays,
// not in one of 160,000 (building the tree would cost more than it saves).
TEST(RayStartTest, TheDefaultStartsPastBallsInLargePassesOnly) {
  const Mesh mesh = *ReadMesh(testing::SharedMesh("rocker-arm.obj"));
  auto ev = SdfEvaluator::Create(mesh);
  ASSERT_TRUE(ev.ok());
  SdfParams params;
  params.rays = 100;
  auto large = (*ev)->Compute(params);
  ASSERT_TRUE(large.ok());
  EXPECT_GT(large->samples_past_ball, mesh.num_vertices() / 2);
  params.rays = 16;
  auto small = (*ev)->Compute(params);
  ASSERT_TRUE(small.ok());
  EXPECT_EQ(small->samples_past_ball, 0);
}

// The samples an incremental pass traces in full after `moved` moved.
int64_t MovedSamples(const Mesh& mesh, const std::vector<int32_t>& moved) {
  const std::vector<uint8_t> dirty =
      CornersOfFacesAround(MeshTopology::Build(mesh), mesh, moved);
  return std::count(dirty.begin(), dirty.end(), 1);
}

// Rocker-arm's incremental pass (`rays` rays, starts asked for) after the
// vertices within `radius` diagonals of vertex 5000 moved, checked bit for
// bit against a fresh pass from the surface at the moved positions.
struct PatchPass {
  Pass pass;
  int64_t patch_vertices = 0;
  int64_t moved_samples = 0;  // MovedSamples of the patch.
};
PatchPass RockerArmPatchPass(double radius, int rays) {
  const Mesh mesh = *ReadMesh(testing::SharedMesh("rocker-arm.obj"));
  SdfParams params;
  params.rays = rays;
  auto ev = SdfEvaluator::Create(
      mesh,
      {.ray_start = RayStartMode::kPastEmptyBall, .fan_traversal = kPackets});
  if (!ev.ok()) {
    ADD_FAILURE() << ev.status();
    return {};
  }
  const std::vector<int32_t> patch =
      testing::Patch(mesh, 5000, radius * BoundingBoxDiagonal(mesh));
  PatchPass out{IncrementalPass(**ev, mesh, patch, params), std::ssize(patch),
                MovedSamples(mesh, patch)};
  ExpectSameBits(out.pass,
                 PassFrom(Moved(mesh, patch), params,
                          {.ray_start = RayStartMode::kSurface,
                           .fan_traversal = kPackets}),
                 absl::StrCat("patch of radius ", radius));
  return out;
}

// A small moved patch: the unmoved samples whose cones see it retrace
// rays, and those retracing many start them past balls too (more samples
// start past balls than the pass traces in full), with the same bits.
TEST(RayStartTest, AnIncrementalPassStartsUnmovedSamplesRetracedRaysPastBalls) {
  const PatchPass small = RockerArmPatchPass(0.05, 64);
  ASSERT_GT(small.patch_vertices, 20);
  EXPECT_GT(small.pass.result.samples_past_ball, small.moved_samples + 20);
}

// kAuto in an incremental pass counts twice its moved samples' rays (its
// unmoved samples retrace about as many): rocker-arm's threshold is 2^18
// rays; a patch whose moved samples trace 100 rays each, between a half
// and all of it, starts rays past balls, a small one does not.
TEST(RayStartTest, TheDefaultCountsAnIncrementalPassByItsMovedSamples) {
  const Mesh mesh = *ReadMesh(testing::SharedMesh("rocker-arm.obj"));
  ASSERT_LT(8 * mesh.num_faces(), int64_t{1} << 18);
  SdfParams params;
  params.rays = 100;
  const double diagonal = BoundingBoxDiagonal(mesh);
  const std::vector<int32_t> small =
      testing::Patch(mesh, 5000, 0.05 * diagonal);
  std::vector<int32_t> medium;
  for (double radius = 0.05; radius < 1; radius *= 1.1) {
    medium = testing::Patch(mesh, 5000, radius * diagonal);
    if (100 * MovedSamples(mesh, medium) > (int64_t{1} << 17)) break;
  }
  const int64_t medium_rays = 100 * MovedSamples(mesh, medium);
  ASSERT_GT(medium_rays, int64_t{1} << 17);
  ASSERT_LT(medium_rays, int64_t{1} << 18);
  ASSERT_LT(100 * MovedSamples(mesh, small), int64_t{1} << 17);
  auto ev = SdfEvaluator::Create(mesh);
  ASSERT_TRUE(ev.ok());
  EXPECT_EQ(IncrementalPass(**ev, mesh, small, params).result.samples_past_ball,
            0);
  auto again = SdfEvaluator::Create(mesh);
  ASSERT_TRUE(again.ok());
  EXPECT_GT(
      IncrementalPass(**again, mesh, medium, params).result.samples_past_ball,
      MovedSamples(mesh, medium) / 2);
}

// An incremental pass whose moved patch is large starts its moved samples'
// rays past balls, with the same bits. With 12 rays a sample no unmoved
// sample retraces the 16 that make it look for a ball, so the count is the
// moved samples' alone.
TEST(RayStartTest, AnIncrementalPassStartsMovedSamplesPastBalls) {
  const PatchPass large = RockerArmPatchPass(0.3, 12);
  EXPECT_GT(large.pass.result.samples_past_ball, large.moved_samples / 2);
  EXPECT_LE(large.pass.result.samples_past_ball, large.moved_samples);
}

}  // namespace
}  // namespace meshgauge
