// How a pass traces each sample's rays (FanTraversal): packets of 16, one
// coherent stream per sample and the cone walk give the same values on the
// test meshes (packets and streams the same hit tables too; the walk's
// differ only at ties, ExpectSameResultsUpToTies), at both cone angles, with
// and without ray starts, for vertex ranges, face samples, 2D curves, quads and
// hub fans; and a pass left to choose walks cones (from the surface) on small
// scenes (larger ones for narrow cones) where a pilot finds the walk's work
// small, and streams the other small scenes whose rays start at the surface
// in narrow cones.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "lib/core/mesh.h"
#include "lib/core/shapes.h"
#include "lib/embree/cone_walk.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/embree/traversal_choice.h"
#include "lib/io/mesh_io.h"
#include "tests/pass_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::ExpectSameBits;
using testing::Pass;
using testing::PassFrom;
using testing::Traced;

// The three traversals with `start`: the same bits, and each reported.
void ExpectTraversalsAgree(const Mesh& mesh, const SdfParams& params,
                           RayStartMode start, const std::string& what) {
  const Pass packets =
      PassFrom(mesh, params,
               {.ray_start = start, .fan_traversal = FanTraversal::kPackets});
  const Pass stream =
      PassFrom(mesh, params,
               {.ray_start = start, .fan_traversal = FanTraversal::kStream});
  const Pass cone = PassFrom(
      mesh, params, {.ray_start = start, .fan_traversal = FanTraversal::kCone});
  ExpectSameBits(packets, stream, what + " streamed");
  testing::ExpectSameResultsUpToTies(mesh, packets, cone, what + " walked");
  EXPECT_EQ(packets.result.samples_streamed, 0) << what;
  EXPECT_EQ(packets.result.samples_cone_walked, 0) << what;
  // Every sample but those whose rays Embree's streams mishandle: spot's 7
  // on its plane of symmetry (StreamMayLoseHits), traced in packets.
  const int64_t mishandled = what.starts_with("spot") ? 7 : 0;
  EXPECT_EQ(stream.result.samples_streamed, Traced(stream.result) - mishandled)
      << what;
  // The walk takes every sample of a 3D pass (on a CPU with AVX2 and FMA)
  // and gives none up; a 2D pass streams.
  EXPECT_EQ(cone.result.samples_cone_fell_back, 0) << what;
  const bool walks = mesh.dimension == 3 && ConeWalk::Supported();
  EXPECT_EQ(cone.result.samples_cone_walked, walks ? Traced(cone.result) : 0)
      << what;
}

TEST(RayTraversalTest, AllTraversalsGiveTheSameValuesOnTheTestMeshes) {
  // igea and bunny are left out for time (the walk, forced, takes every
  // fan of horse and bunny: over a thousand triangles a fan); kAuto never
  // streams a scene that large, nor walks its cones. Under the sanitizers
  // (scripts/sanitize.sh) horse is left out too: its forced walks are most
  // of this test's time (112 s there with it), and the release run checks
  // its bits. (CI's sanitizer stage leaves the whole test out: .ci/run.)
  std::vector<const char*> names = {
      "rocker-arm.obj", "fandisk.obj",          "spot_triangulated.obj",
      "teapot.obj",     "decimated-knight.off", "1002_tray_bottom.STL"};
  if (std::getenv("MESHGAUGE_SANITIZED") == nullptr) {
    names.insert(names.begin(), "horse.ply");
  }
  testing::ForEachTestMeshAndAngle(
      names,
      [](const Mesh& mesh, const SdfParams& params, const std::string& what) {
        ExpectTraversalsAgree(mesh, params, RayStartMode::kSurface, what);
        ExpectTraversalsAgree(mesh, params, RayStartMode::kPastEmptyBall,
                              what + " past balls");
      });
}

TEST(RayTraversalTest,
     RangesFaceSamplesCurvesQuadsAndHubFansGiveTheSameValues) {
  const Mesh teapot = *ReadMesh(testing::SharedMesh("teapot.obj"));
  SdfParams range;
  range.range = {1000, 1600};
  ExpectTraversalsAgree(teapot, range, RayStartMode::kSurface, "range");
  // Past empty balls too: CI's sanitizer stage leaves out the test above,
  // which alone streamed and walked rays with starts.
  ExpectTraversalsAgree(teapot, range, RayStartMode::kPastEmptyBall,
                        "range past balls");
  SdfParams faces;
  faces.samples = SampleSet::kFaces;
  ExpectTraversalsAgree(*ReadMesh(testing::SharedMesh("1002_tray_bottom.STL")),
                        faces, RayStartMode::kSurface, "faces");
  ExpectTraversalsAgree(MakeCircle(1, 2000), SdfParams{},
                        RayStartMode::kSurface, "2D");
  ExpectTraversalsAgree(MakeBox(2, 1, 0.5, 0.1, /*quads=*/true), SdfParams{},
                        RayStartMode::kSurface, "quads");
  // Hubs in 300 and 600 primitives: traced by HubFans' user geometry, whose
  // hits reach the filter through Embree's stream too.
  ExpectTraversalsAgree(MakeFanCone(300), SdfParams{}, RayStartMode::kSurface,
                        "fan cone");
  ExpectTraversalsAgree(MakeFanCylinder(300), SdfParams{},
                        RayStartMode::kSurface, "fan cylinder");
}

// An incremental pass's retraced rays, from every sample whose cone sees
// the moved patch (fans of a few rays), in packets, streamed and walked.
TEST(RayTraversalTest, AnIncrementalPassGivesTheSameValues) {
  const Mesh mesh = *ReadMesh(testing::SharedMesh("teapot.obj"));
  const std::vector<int32_t> patch =
      testing::Patch(mesh, 1000, 0.05 * BoundingBoxDiagonal(mesh));
  auto incremental = [&](const EvaluatorOptions& options) {
    auto ev = SdfEvaluator::Create(mesh, options);
    EXPECT_TRUE(ev.ok()) << ev.status();
    return ev.ok() ? testing::IncrementalPass(**ev, mesh, patch, SdfParams{})
                   : Pass{};
  };
  const Pass packets = incremental({.ray_start = RayStartMode::kSurface,
                                    .fan_traversal = FanTraversal::kPackets});
  const Pass stream = incremental({.ray_start = RayStartMode::kSurface,
                                   .fan_traversal = FanTraversal::kStream});
  const Pass cone = incremental({.ray_start = RayStartMode::kSurface,
                                 .fan_traversal = FanTraversal::kCone});
  ExpectSameBits(packets, stream, "incremental, streamed");
  testing::ExpectSameResultsUpToTies(mesh, packets, cone,
                                     "incremental, walked");
  // And exactly the walk's full pass at the new positions, hit table and
  // all (ConeWalkTest.ARaysCandidatesDoNotDependOnTheRaysWalkedWithIt).
  ExpectSameBits(PassFrom(testing::Moved(mesh, patch), SdfParams{},
                          {.ray_start = RayStartMode::kSurface,
                           .fan_traversal = FanTraversal::kCone}),
                 cone, "incremental walk against a full one");
  EXPECT_EQ(packets.result.samples_streamed, 0);
  EXPECT_GT(stream.result.samples_streamed, std::ssize(patch));
  if (ConeWalk::Supported()) {
    EXPECT_GT(cone.result.samples_cone_walked, std::ssize(patch));
    // Left to choose, a pass this small walks its retraced rays' cones.
    EXPECT_EQ(incremental({}).result.samples_cone_walked,
              cone.result.samples_cone_walked);
  }
}

// kAuto's rule (traversal_choice.h): on 3D scenes of fewer than 2^13
// primitives (2^15 for cones of more than one ray narrower than
// kNarrowWalkMaxConeDegrees) with the watertight test, the cone walk from
// the surface for
// normal rays and where a pilot counts at most 8 of its tests a ray, else
// streams where the rays start at the surface and the cones open less than
// kStreamMaxConeDegrees; packets elsewhere.
TEST(RayTraversalTest,
     APassWalksConesWhereItsPilotFindsLittleWorkElseStreamsNarrowOnes) {
  if (!ConeWalk::Supported()) GTEST_SKIP() << "this CPU has no AVX2 and FMA";
  struct Used {
    bool walked = false, streamed = false, past_balls = false;
    double pilot = 0;
  };
  auto traced = [](const Mesh& mesh, const SdfParams& params,
                   RayStartMode start = RayStartMode::kAuto,
                   RayTest test = RayTest::kWatertight) {
    auto ev =
        SdfEvaluator::Create(mesh, {.ray_test = test, .ray_start = start});
    auto r = (*ev)->Compute(params, {.threads = 2});
    EXPECT_TRUE(r.ok()) << r.status();
    if (!r.ok()) return Used{};
    const int64_t all = Traced(*r);
    // All of the pass's samples, or none; the walk's fall-backs stream.
    const int64_t walk = r->samples_cone_walked + r->samples_cone_fell_back;
    if (walk != 0) {
      EXPECT_EQ(walk, all);
      EXPECT_EQ(r->samples_streamed, r->samples_cone_fell_back);
    } else if (r->samples_streamed != 0) {
      EXPECT_EQ(r->samples_streamed, all);
    }
    return Used{r->samples_cone_walked > 0, r->samples_streamed == all,
                r->samples_past_ball > 0, r->cone_walk_pilot};
  };
  const Mesh knight = testing::Knight();  // 1,000 primitives
  const Mesh teapot = *ReadMesh(testing::SharedMesh("teapot.obj"));    // 6,320
  const Mesh fandisk = *ReadMesh(testing::SharedMesh("fandisk.obj"));  // 12,946
  SdfParams all;
  SdfParams wide;
  wide.cone_angle_degrees = 60;
  SdfParams few;
  few.range = {0, 500};
  const Used knight_all = traced(knight, all);
  EXPECT_TRUE(knight_all.walked);
  EXPECT_GT(knight_all.pilot, 0);
  EXPECT_LE(knight_all.pilot, 8);
  // The teapot's whole pass would start past balls; it walks from the
  // surface instead at 30 degrees, where a ray makes about 6 of the walk's
  // tests; at 60 about 18: past balls.
  const Used teapot_all = traced(teapot, all);
  EXPECT_TRUE(teapot_all.walked);
  EXPECT_FALSE(teapot_all.past_balls);
  EXPECT_LE(teapot_all.pilot, 8);
  const Used teapot_wide = traced(teapot, wide);
  EXPECT_FALSE(teapot_wide.walked);
  EXPECT_TRUE(teapot_wide.past_balls);
  EXPECT_GT(teapot_wide.pilot, 8);
  // From the surface the 60-degree cones go in packets: streams only
  // for cones narrower than kStreamMaxConeDegrees.
  const Used teapot_wide_surface = traced(teapot, wide, RayStartMode::kSurface);
  EXPECT_FALSE(teapot_wide_surface.walked || teapot_wide_surface.streamed);
  // A range's pilot is the whole pass's: the same samples decide.
  const Used teapot_few = traced(teapot, few);
  EXPECT_TRUE(teapot_few.walked);
  EXPECT_EQ(teapot_few.pilot, teapot_all.pilot);
  // The knight's cones meet few triangles at 60 degrees too.
  const Used knight_wide = traced(knight, wide);
  EXPECT_TRUE(knight_wide.walked);
  EXPECT_LE(knight_wide.pilot, 8);
  // Too many primitives: neither, and no pilot.
  const Used fandisk_few = traced(fandisk, few);
  EXPECT_FALSE(fandisk_few.walked || fandisk_few.streamed);
  EXPECT_EQ(fandisk_few.pilot, 0);
  // But not for a cone narrower than kNarrowWalkMaxConeDegrees (up to
  // kNarrowWalkMaxPrimitives): fandisk's 10-degree cones meet few
  // triangles. Normal rays keep the smaller scenes' bound.
  SdfParams narrow = few;
  narrow.cone_angle_degrees = 10;
  const Used fandisk_narrow = traced(fandisk, narrow);
  EXPECT_TRUE(fandisk_narrow.walked);
  EXPECT_GT(fandisk_narrow.pilot, 0);
  EXPECT_LE(fandisk_narrow.pilot, 8);
  narrow.method = SdfMethod::kNormalRay;
  EXPECT_FALSE(traced(fandisk, narrow).walked);
  // Normal rays (one ray a fan) walk without a pilot; more rays than the
  // walk takes stream in a narrow cone, go in packets in a wide one (from
  // kStreamMaxConeDegrees itself: the bound is exclusive).
  SdfParams normal_ray = wide;
  normal_ray.method = SdfMethod::kNormalRay;
  const Used teapot_normal = traced(teapot, normal_ray);
  EXPECT_TRUE(teapot_normal.walked);
  EXPECT_EQ(teapot_normal.pilot, 0);
  SdfParams many = all;
  many.rays = ConeWalk::kMaxRays + 1;
  EXPECT_TRUE(traced(knight, many).streamed);
  many.cone_angle_degrees = kStreamMaxConeDegrees;
  const Used knight_many_wide = traced(knight, many);
  EXPECT_FALSE(knight_many_wide.walked || knight_many_wide.streamed);
  // Embree's fast test, and 2D: packets.
  const Used fast = traced(knight, all, RayStartMode::kAuto, RayTest::kFast);
  EXPECT_FALSE(fast.walked || fast.streamed);
  const Used curve = traced(MakeCircle(1, 400), all);
  EXPECT_FALSE(curve.walked || curve.streamed);
}

// The pilot counts the walk's work, which depends on its tree: the tree is
// built from the current positions after every update, so a pass's pilot
// (and its choice) is the same for an evaluator moved there as for one
// made there. A teapot stretched threefold along x, then moved back.
TEST(RayTraversalTest, APassesPilotDependsOnThePositionsAlone) {
  if (!ConeWalk::Supported()) GTEST_SKIP() << "this CPU has no AVX2 and FMA";
  const Mesh teapot = *ReadMesh(testing::SharedMesh("teapot.obj"));
  Mesh stretched = teapot;
  for (Vec3& p : stretched.positions) p.x *= 3;
  SdfParams params;
  auto moved = SdfEvaluator::Create(stretched);
  ASSERT_TRUE(moved.ok()) << moved.status();
  auto before = (*moved)->Compute(params);
  ASSERT_TRUE(before.ok()) << before.status();
  ASSERT_TRUE((*moved)->UpdatePositions(teapot.positions).ok());
  auto after = (*moved)->Compute(params);
  ASSERT_TRUE(after.ok()) << after.status();
  auto made = SdfEvaluator::Create(teapot);
  ASSERT_TRUE(made.ok()) << made.status();
  auto fresh = (*made)->Compute(params);
  ASSERT_TRUE(fresh.ok()) << fresh.status();
  EXPECT_NE(before->cone_walk_pilot, fresh->cone_walk_pilot);
  EXPECT_EQ(after->cone_walk_pilot, fresh->cone_walk_pilot);
  EXPECT_EQ(after->samples_cone_walked, fresh->samples_cone_walked);
  // At the same positions, another cone: the evaluator's kept choice is
  // for the parameters it was made for.
  SdfParams wide;
  wide.cone_angle_degrees = 60;
  auto wider = (*made)->Compute(wide);
  ASSERT_TRUE(wider.ok()) << wider.status();
  EXPECT_GT(fresh->samples_cone_walked, 0);
  EXPECT_EQ(wider->samples_cone_walked, 0);
  EXPECT_GT(wider->cone_walk_pilot, 8);
}

}  // namespace
}  // namespace meshgauge
