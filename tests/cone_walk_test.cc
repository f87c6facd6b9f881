// The cone walk (lib/embree/cone_walk.h): the candidates Embree's filter
// finds, rays through shared edges and corners never slipping through,
// the fans it gives up on and its count of tests (a pass's pilot).
#include "lib/embree/cone_walk.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "absl/strings/str_cat.h"
#include "lib/core/sdf_types.h"
#include "lib/core/shapes.h"
#include "lib/core/topology.h"
#include "lib/embree/ray_scene.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "tests/ray_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

// Every test here needs the walk: x86-64 with AVX2 and FMA.
#define SKIP_WITHOUT_THE_WALK()                     \
  if (!ConeWalk::Supported()) {                     \
    GTEST_SKIP() << "this CPU has no AVX2 and FMA"; \
  }

// Every fan of `mesh` (its vertices' cones of `aperture_degrees`), traced
// in packets and by the cone walk, into `check(p, walked, packets, cone)`.
template <typename Check>
void ForEachFan(const Mesh& mesh, double aperture_degrees, Check check) {
  SdfParams params;
  params.cone_angle_degrees = aperture_degrees;
  const testing::VertexFans fans(mesh, params);
  std::vector<HitCandidates> packets(fans.rays()), walked(fans.rays());
  std::vector<Vec3> dirs;
  std::vector<int32_t> ring;
  Vec3 axis;
  for (int64_t p = 0; p < mesh.num_vertices(); ++p) {
    if (!fans.Fan(p, &dirs, &axis, &ring)) continue;
    fans.scene().IntersectFan(mesh.positions[p], dirs, fans.limits(), ring,
                              absl::MakeSpan(packets), {},
                              FanTraversal::kPackets);
    const FanTraversal used = fans.scene().IntersectFan(
        mesh.positions[p], dirs, fans.limits(), ring, absl::MakeSpan(walked),
        {}, FanTraversal::kCone, &axis);
    check(p, used == FanTraversal::kCone, packets, walked);
  }
}

std::string Listed(const HitCandidates& c) {
  std::string s;
  for (int i = 0; i < c.count(); ++i) {
    absl::StrAppend(&s, " ", c[i].prim, "@", c[i].t, c[i].edge ? "e" : "");
  }
  return s;
}

// The walk's single-precision distances and barycentric coordinates round
// differently from Embree's: near an edge, the two may report different
// primitives or flag the same one differently (HitCandidates' edge flag,
// at 2^-10 of a barycentric coordinate); PickClosest then looks at the
// neighbours. Elsewhere a ray's candidates are the same.
TEST(ConeWalkTest, FindsTheCandidatesEmbreeFindsOnEveryFanOfSpot) {
  SKIP_WITHOUT_THE_WALK();
  const Mesh mesh = *ReadMesh(testing::SharedMesh("spot_triangulated.obj"));
  for (double aperture : {30.0, 60.0}) {
    SCOPED_TRACE(::testing::Message() << aperture << " degrees");
    int64_t walked_fans = 0, rays = 0, differing = 0;
    ForEachFan(
        mesh, aperture,
        [&](int64_t p, bool walked, absl::Span<const HitCandidates> packets,
            absl::Span<const HitCandidates> cone) {
          if (!walked) return;
          ++walked_fans;
          for (size_t k = 0; k < packets.size(); ++k) {
            SCOPED_TRACE(::testing::Message()
                         << "vertex " << p << " ray " << k);
            const HitCandidates& a = packets[k];
            const HitCandidates& b = cone[k];
            ++rays;
            ASSERT_EQ(a.count() > 0, b.count() > 0);
            EXPECT_EQ(a.near(), b.near());
            bool same = a.count() == b.count();
            for (int i = 0; same && i < a.count(); ++i) {
              same = a[i].prim == b[i].prim && a[i].edge == b[i].edge;
            }
            if (same || a.count() == 0) continue;
            ++differing;
            EXPECT_TRUE(a[0].prim == b[0].prim || (a[0].edge && b[0].edge))
                << Listed(a) << " walked" << Listed(b);
            EXPECT_NEAR(a[0].t, b[0].t, 1e-6 * a[0].t);
          }
        });
    EXPECT_EQ(walked_fans, mesh.num_vertices());
    EXPECT_LT(differing, rays / 1000);
  }
}

// An incremental pass retraces some of a sample's rays: each must find
// exactly what it finds in the whole fan, every bit (the walk tests it in
// the frame of the sample's axis; in the frame of the fan's mean direction
// the distances rounded differently).
TEST(ConeWalkTest, ARaysCandidatesDoNotDependOnTheRaysWalkedWithIt) {
  SKIP_WITHOUT_THE_WALK();
  const Mesh mesh = *ReadMesh(testing::SharedMesh("teapot.obj"));
  const testing::VertexFans fans(mesh);
  std::vector<Vec3> all, some;
  std::vector<int32_t> ring;
  Vec3 axis;
  int64_t compared = 0;
  for (int64_t p = 0; p < mesh.num_vertices(); p += 7) {
    if (!fans.Fan(p, &all, &axis, &ring)) continue;
    some.clear();
    for (size_t k = 1; k < all.size(); k += 3) some.push_back(all[k]);
    std::vector<HitCandidates> whole(all.size()), part(some.size());
    auto walked = [&](absl::Span<const Vec3> dirs,
                      absl::Span<HitCandidates> out) {
      return fans.scene().IntersectFan(mesh.positions[p], dirs, fans.limits(),
                                       ring, out, {}, FanTraversal::kCone,
                                       &axis) == FanTraversal::kCone;
    };
    if (!walked(all, absl::MakeSpan(whole)) ||
        !walked(some, absl::MakeSpan(part))) {
      continue;
    }
    for (size_t j = 0; j < some.size(); ++j) {
      const HitCandidates& a = whole[3 * j + 1];
      const HitCandidates& b = part[j];
      ASSERT_EQ(a.count(), b.count()) << p << " " << j;
      EXPECT_EQ(a.near(), b.near()) << p << " " << j;
      for (int i = 0; i < a.count(); ++i) {
        EXPECT_EQ(a[i].prim, b[i].prim) << p << " " << j;
        EXPECT_EQ(std::bit_cast<uint32_t>(a[i].t),
                  std::bit_cast<uint32_t>(b[i].t))
            << p << " " << j;
        EXPECT_EQ(a[i].edge, b[i].edge) << p << " " << j;
      }
      ++compared;
    }
  }
  EXPECT_GT(compared, 10000);
}

// A fan from the centre of a cube of 8 x 8 cells a face towards every
// corner and edge midpoint of the triangles of its top face: every ray
// meets the face, at its exact distance.
TEST(ConeWalkTest, RaysThroughSharedEdgesAndCornersDoNotSlipThrough) {
  SKIP_WITHOUT_THE_WALK();
  const Mesh box = MakeBox(1, 1, 1, 0.125);
  const MeshTopology topo = MeshTopology::Build(box);
  auto scene = RayScene::Create(box, topo, BvhUpdatePolicy::kRebuild);
  ASSERT_TRUE(scene.ok()) << scene.status();
  const Vec3 centre(0.5, 0.5, 0.5);
  std::vector<Vec3> targets;
  for (const Primitive& prim : topo.primitives) {
    const Vec3& a = box.positions[prim.v[0]];
    if (a.z != 1 || box.positions[prim.v[1]].z != 1) continue;
    for (int i = 0; i < 3; ++i) {
      const Vec3& p = box.positions[prim.v[i]];
      const Vec3& q = box.positions[prim.v[(i + 1) % 3]];
      targets.push_back(p);
      targets.push_back((p + q) * 0.5);
    }
  }
  std::sort(targets.begin(), targets.end(), [](const Vec3& a, const Vec3& b) {
    return std::tie(a.x, a.y) < std::tie(b.x, b.y);
  });
  targets.erase(std::unique(targets.begin(), targets.end()), targets.end());
  ASSERT_EQ(std::ssize(targets), 81 + 2 * 72 + 64);  // corners, edges
  std::vector<Vec3> dirs;
  for (const Vec3& t : targets) dirs.push_back((t - centre) / Norm(t - centre));
  std::vector<HitCandidates> out(dirs.size());
  const RayScene::FanLimits limits = {1e-6f, 1e-6f, 2e-6f, 10};
  ASSERT_EQ(
      (*scene)->IntersectFan(centre, dirs, limits, {}, absl::MakeSpan(out), {},
                             FanTraversal::kCone),
      FanTraversal::kCone);
  for (size_t k = 0; k < dirs.size(); ++k) {
    ASSERT_GT(out[k].count(), 0) << "ray " << k << " slipped through";
    EXPECT_NEAR(out[k][0].t, 0.5 / dirs[k].z, 1e-6) << k;
  }
}

// A unit icosphere of geodesic frequency `frequency` in a RayScene, and
// limits that reach past it from its centre.
struct SphereScene {
  explicit SphereScene(int frequency)
      : mesh(MakeIcosphere(1, frequency)), topo(MeshTopology::Build(mesh)) {
    auto made = RayScene::Create(mesh, topo, BvhUpdatePolicy::kRebuild);
    EXPECT_TRUE(made.ok()) << made.status();
    if (made.ok()) scene = std::move(*made);
  }
  Mesh mesh;
  MeshTopology topo;
  std::unique_ptr<RayScene> scene;
  RayScene::FanLimits limits = {1e-6f, 1e-6f, 2e-6f, 10};
};

// `rays` directions about +z within `half_angle` radians of it, spread by
// the golden angle.
std::vector<Vec3> SpiralFan(int rays, double half_angle) {
  std::vector<Vec3> dirs;
  for (int k = 0; k < rays; ++k) {
    const double theta = half_angle * (k + 0.5) / rays;
    const double phi = 2.399963 * k;
    dirs.emplace_back(std::sin(theta) * std::cos(phi),
                      std::sin(theta) * std::sin(phi), std::cos(theta));
  }
  return dirs;
}

// Gives up on over kMaxRays rays (IntersectFan streams the fan instead,
// with the same candidates), but not on a fan that meets thousands of
// triangles (from the centre of a fine sphere, whose every triangle in the
// cone lies at the same distance): whether a sample walks must not depend
// on which of its rays a pass traces.
TEST(ConeWalkTest, GivesUpOnOver512RaysButNotOnManyTriangles) {
  SKIP_WITHOUT_THE_WALK();
  const SphereScene sphere(48);  // 46,080 triangles
  ASSERT_NE(sphere.scene, nullptr);
  auto traced = [&](const std::vector<Vec3>& dirs) {
    std::vector<HitCandidates> packets(dirs.size()), cone(dirs.size());
    sphere.scene->IntersectFan(Vec3(), dirs, sphere.limits, {},
                               absl::MakeSpan(packets), {},
                               FanTraversal::kPackets);
    const FanTraversal used = sphere.scene->IntersectFan(
        Vec3(), dirs, sphere.limits, {}, absl::MakeSpan(cone), {},
        FanTraversal::kCone);
    for (size_t k = 0; k < dirs.size(); ++k) {
      EXPECT_EQ(cone[k].count(), packets[k].count()) << k;
      if (cone[k].count() > 0 && packets[k].count() > 0) {
        EXPECT_EQ(cone[k][0].prim, packets[k][0].prim) << k;
      }
    }
    return used;
  };
  // A narrow cone of 100 rays meets a few hundred triangles.
  EXPECT_EQ(traced(SpiralFan(100, 0.1)), FanTraversal::kCone);
  EXPECT_EQ(traced(SpiralFan(ConeWalk::kMaxRays, 0.1)), FanTraversal::kCone);
  EXPECT_EQ(traced(SpiralFan(ConeWalk::kMaxRays + 1, 0.1)),
            FanTraversal::kStream);
  // 30 degrees about the axis: about 3,000 triangles.
  EXPECT_EQ(traced(SpiralFan(100, 0.5)), FanTraversal::kCone);
}

// The walk's count of its (triangle, group of 8 rays) tests, a pass's pilot
// (RayScene::ConeWalkTests): none for rays that meet nothing, more for a
// wider cone, which meets more triangles, and -1 where it gives up.
TEST(ConeWalkTest, CountsMoreTestsForAWiderConeAndNoneWhereNothingIsMet) {
  SKIP_WITHOUT_THE_WALK();
  const SphereScene sphere(24);  // 11,520 triangles
  ASSERT_NE(sphere.scene, nullptr);
  std::vector<HitCandidates> scratch(ConeWalk::kMaxRays + 1);
  auto tests = [&](const Vec3& origin, int rays, double half_angle) {
    return sphere.scene->ConeWalkTests(origin, SpiralFan(rays, half_angle),
                                       sphere.limits, {}, Vec3(0, 0, 1),
                                       absl::MakeSpan(scratch));
  };
  const int64_t narrow = tests(Vec3(), 100, 0.1);
  const int64_t wide = tests(Vec3(), 100, 0.5);
  EXPECT_GE(narrow, 13);  // each of the 13 groups meets a triangle
  EXPECT_GT(wide, 2 * narrow);
  EXPECT_EQ(tests(Vec3(0, 0, 2), 100, 0.5), 0);  // outside, looking away
  EXPECT_EQ(tests(Vec3(), ConeWalk::kMaxRays + 1, 0.1), -1);
}

// Gives up on a ray more than 80 degrees from the fan's axis.
TEST(ConeWalkTest, GivesUpOnRaysOver80DegreesFromTheAxis) {
  SKIP_WITHOUT_THE_WALK();
  const Mesh sphere = MakeIcosphere(1, 2);  // 80 triangles
  const MeshTopology topo = MeshTopology::Build(sphere);
  auto scene = RayScene::Create(sphere, topo, BvhUpdatePolicy::kRebuild);
  ASSERT_TRUE(scene.ok()) << scene.status();
  const RayScene::FanLimits limits = {1e-6f, 1e-6f, 2e-6f, 10};
  // Rays on two circles about z: every ray's angle to their mean is the
  // circle's.
  auto walked = [&](double degrees) {
    std::vector<Vec3> dirs;
    const double theta = degrees * std::numbers::pi / 180;
    for (int k = 0; k < 16; ++k) {
      const double phi = 2 * std::numbers::pi * k / 16;
      dirs.emplace_back(std::sin(theta) * std::cos(phi),
                        std::sin(theta) * std::sin(phi), std::cos(theta));
    }
    std::vector<HitCandidates> out(dirs.size());
    return (*scene)->IntersectFan(Vec3(), dirs, limits, {}, absl::MakeSpan(out),
                                  {},
                                  FanTraversal::kCone) == FanTraversal::kCone;
  };
  EXPECT_TRUE(walked(60));
  EXPECT_TRUE(walked(79));
  EXPECT_FALSE(walked(81));
}

// Where the walk and Embree differ (docs/numerics.md "The cone walk"): a
// ray with a zero direction component lying exactly on the upper face of a
// bounding box misses that box in Embree's traversal (its reciprocal of 0
// is +1e18, so the box's slab is [-huge, 0]), and so the primitives in it.
// On a cube of six unwelded grids, the normal rays of 54 seam vertices run
// along such faces to the far grid's boundary; the walk meets it at the
// cube's width, Embree finds nothing.
TEST(ConeWalkTest, MeetsTheFarFaceAlongASeamWhereEmbreesBoxTestMisses) {
  SKIP_WITHOUT_THE_WALK();
  const Mesh cube = testing::SixGridCube();
  const MeshTopology topo = MeshTopology::Build(cube);
  auto scene = RayScene::Create(cube, topo, BvhUpdatePolicy::kRebuild);
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ((*scene)->Intersect(Vec3(0, 0, 0), Vec3(1, 0, 0), 1e-6f, 10).prim,
            32);
  EXPECT_EQ((*scene)->Intersect(Vec3(0, 0, 1), Vec3(1, 0, 0), 1e-6f, 10).prim,
            -1);
  SdfParams normal_ray;
  normal_ray.method = SdfMethod::kNormalRay;
  for (FanTraversal traversal : {FanTraversal::kPackets, FanTraversal::kCone}) {
    auto ev = SdfEvaluator::Create(cube, {.fan_traversal = traversal});
    ASSERT_TRUE(ev.ok()) << ev.status();
    auto r = (*ev)->Compute(normal_ray, {.threads = 2});
    ASSERT_TRUE(r.ok()) << r.status();
    int64_t without = 0;
    for (size_t v = 0; v < r->values.size(); ++v) {
      if (r->status[v] != VertexStatus::kOk) {
        ++without;
      } else {
        EXPECT_EQ(r->values[v], 1) << v;
      }
    }
    EXPECT_EQ(without, traversal == FanTraversal::kCone ? 0 : 54);
  }
}

}  // namespace
}  // namespace meshgauge
