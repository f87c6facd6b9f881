// How a pass hands each sample's rays to Embree (FanTraversal): one
// coherent stream per sample and packets of 16 give the same bits on the
// test meshes, at both cone angles, with and without ray starts, for vertex
// ranges, face samples, 2D curves, quads and hub fans; and a pass left to
// choose streams exactly the small scenes whose rays start at the surface.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "lib/core/mesh.h"
#include "lib/core/shapes.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "tests/pass_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::ExpectSameBits;
using testing::Pass;
using testing::PassFrom;
using testing::Traced;

// Both traversals with `start`: the same bits, and each reported.
void ExpectTraversalsAgree(const Mesh& mesh, const SdfParams& params,
                           RayStartMode start, const std::string& what) {
  const Pass packets =
      PassFrom(mesh, params,
               {.ray_start = start, .fan_traversal = FanTraversal::kPackets});
  const Pass stream =
      PassFrom(mesh, params,
               {.ray_start = start, .fan_traversal = FanTraversal::kStream});
  ExpectSameBits(packets, stream, what);
  EXPECT_EQ(packets.result.samples_streamed, 0) << what;
  // Every sample but those whose rays Embree's streams mishandle: spot's 7
  // on its plane of symmetry (StreamMayLoseHits), traced in packets.
  const int64_t mishandled = what.starts_with("spot") ? 7 : 0;
  EXPECT_EQ(stream.result.samples_streamed, Traced(stream.result) - mishandled)
      << what;
}

TEST(RayTraversalTest, StreamsAndPacketsGiveTheSameBitsOnTheTestMeshes) {
  // igea is left out for time; kAuto never streams a scene that large.
  testing::ForEachTestMeshAndAngle(
      {"horse.ply", "stanford-bunny.obj", "rocker-arm.obj", "fandisk.obj",
       "spot_triangulated.obj", "teapot.obj", "decimated-knight.off",
       "1002_tray_bottom.STL"},
      [](const Mesh& mesh, const SdfParams& params, const std::string& what) {
        ExpectTraversalsAgree(mesh, params, RayStartMode::kSurface, what);
        ExpectTraversalsAgree(mesh, params, RayStartMode::kPastEmptyBall,
                              what + " past balls");
      });
}

TEST(RayTraversalTest, RangesFaceSamplesCurvesQuadsAndHubFansGiveTheSameBits) {
  const Mesh teapot = *ReadMesh(testing::SharedMesh("teapot.obj"));
  SdfParams range;
  range.range = {1000, 1600};
  ExpectTraversalsAgree(teapot, range, RayStartMode::kSurface, "range");
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
// the moved patch (fans of a few rays), streamed and in packets.
TEST(RayTraversalTest, AnIncrementalPassGivesTheSameBits) {
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
  ExpectSameBits(packets, stream, "incremental");
  EXPECT_EQ(packets.result.samples_streamed, 0);
  EXPECT_GT(stream.result.samples_streamed, std::ssize(patch));
  // Left to choose, a pass this small starts at the surface and streams.
  EXPECT_EQ(incremental({}).result.samples_streamed,
            stream.result.samples_streamed);
}

// kAuto's rule (sdf_evaluator.cc, kStreamMaxPrimitives = 2^13): streams
// where the pass starts its rays at the surface on fewer primitives, in 3D
// with the watertight test.
TEST(RayTraversalTest, APassStreamsSmallScenesWhoseRaysStartAtTheSurface) {
  auto streamed = [](const Mesh& mesh, const SdfParams& params,
                     RayStartMode start = RayStartMode::kAuto,
                     RayTest test = RayTest::kWatertight) {
    auto ev =
        SdfEvaluator::Create(mesh, {.ray_test = test, .ray_start = start});
    auto r = (*ev)->Compute(params, {.threads = 2});
    EXPECT_TRUE(r.ok()) << r.status();
    if (!r.ok()) return false;
    // All of the pass's samples, or none.
    if (r->samples_streamed == 0) return false;
    EXPECT_EQ(r->samples_streamed, Traced(*r));
    return true;
  };
  const Mesh knight = testing::Knight();  // 1,000 primitives
  const Mesh teapot = *ReadMesh(testing::SharedMesh("teapot.obj"));    // 6,320
  const Mesh fandisk = *ReadMesh(testing::SharedMesh("fandisk.obj"));  // 12,946
  SdfParams all;
  SdfParams half;
  half.range = {0, teapot.num_vertices() / 2};
  SdfParams few;
  few.range = {0, 500};
  // Too few rays for starts: at the surface.
  EXPECT_TRUE(streamed(knight, all));
  EXPECT_TRUE(streamed(teapot, half));
  EXPECT_FALSE(streamed(fandisk, few));  // too many primitives
  // The teapot's whole pass starts past balls; without them it streams.
  EXPECT_FALSE(streamed(teapot, all));
  EXPECT_TRUE(streamed(teapot, all, RayStartMode::kSurface));
  // Embree's fast test, and 2D: packets.
  EXPECT_FALSE(streamed(knight, all, RayStartMode::kAuto, RayTest::kFast));
  EXPECT_FALSE(streamed(MakeCircle(1, 400), all));
}

}  // namespace
}  // namespace meshgauge
