// Hub fans (lib/embree/hub_fans.h): which primitives form them, that a ray's
// work in them grows with the logarithm of the hub's valence (by count), that
// RayScene finds the same candidates as with Embree tracing them, whatever
// the BVH's history, and that rays through their shared edges are not lost.
#include "lib/embree/hub_fans.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "lib/core/shapes.h"
#include "lib/embree/ray_scene.h"
#include "tests/ray_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

// An edge shared by `pages` triangles (both ends are hubs).
Mesh EdgeFan(int pages) {
  Mesh m;
  m.positions = {{0, 0, 0}, {0, 0, 1}};
  for (int i = 0; i < pages; ++i) {
    const double a = 2 * M_PI * i / pages;
    m.positions.push_back({std::cos(a), std::sin(a), 0.5});
    m.faces.push_back(Face::Triangle(0, 1, 2 + i));
  }
  return m;
}

TEST(HubFansTest, AConeIsTwoFansACylinderTwoCapsAnEdgeFanNone) {
  const Mesh cone = MakeFanCone(600);
  const HubFans cone_fans =
      HubFans::Find(MeshTopology::Build(cone), cone.positions.size());
  EXPECT_EQ(cone_fans.num_fans(), 2);
  EXPECT_EQ(cone_fans.num_owned(), 1200);
  const Mesh cylinder = MakeFanCylinder(600);
  const MeshTopology topo = MeshTopology::Build(cylinder);
  const HubFans caps = HubFans::Find(topo, cylinder.positions.size());
  EXPECT_EQ(caps.num_fans(), 2);
  EXPECT_EQ(caps.num_owned(), 1200);
  for (size_t p = 0; p < topo.primitives.size(); ++p) {
    const auto& v = topo.primitives[p].v;
    const bool cap = v[0] <= 1 || v[1] <= 1 || v[2] <= 1;
    EXPECT_EQ(caps.Owns(static_cast<int32_t>(p)), cap) << p;
  }
  // At the threshold (a hub is in more than 512 primitives): no fan.
  const Mesh small = MakeFanCone(HubFans::kHubValence);
  EXPECT_TRUE(HubFans::Find(MeshTopology::Build(small), small.positions.size())
                  .empty());
  const Mesh edge = EdgeFan(1000);
  EXPECT_TRUE(
      HubFans::Find(MeshTopology::Build(edge), edge.positions.size()).empty());
}

// A session's memory estimate covers what the fans hold, from the faces.
TEST(HubFansTest, TheEstimateFromTheFacesCoversTheBytesHeld) {
  for (const Mesh& mesh : {MakeFanCone(5000), MakeFanCylinder(5000)}) {
    const MeshTopology topo = MeshTopology::Build(mesh);
    auto scene = RayScene::Create(mesh, topo, BvhUpdatePolicy::kRebuild);
    ASSERT_TRUE(scene.ok());
    const int64_t held = (*scene)->hub_fans().bytes();
    EXPECT_GT(held, 5000 * 100);
    EXPECT_GE(HubFans::EstimateBytes(mesh), held);
    EXPECT_LT(HubFans::EstimateBytes(mesh), 3 * held);
  }
  EXPECT_EQ(HubFans::EstimateBytes(MakeTorus(1, 0.3, 100, 40)), 0);
}

// Directions within 15 degrees of `axis` (unit).
std::vector<Vec3> ConeDirections(const Vec3& axis, int n, std::mt19937& rng) {
  std::normal_distribution<double> gauss;
  std::vector<Vec3> dirs;
  while (static_cast<int>(dirs.size()) < n) {
    Vec3 d(gauss(rng), gauss(rng), gauss(rng));
    d = d / Norm(d);
    if (Dot(d, axis) >= std::cos(M_PI / 12)) dirs.push_back(d);
  }
  return dirs;
}

// Nodes and triangles HubFans tests per ray for the rays a pass traces from
// the rim of a fan cone (16 per vertex, within 15 degrees of the inward
// direction), over all fans.
double WorkPerRay(int rim) {
  const Mesh cone = MakeFanCone(rim);
  const MeshTopology topo = MeshTopology::Build(cone);
  auto scene = RayScene::Create(cone, topo, BvhUpdatePolicy::kRebuild);
  EXPECT_TRUE(scene.ok());
  const HubFans& fans = (*scene)->hub_fans();
  EXPECT_EQ(fans.num_fans(), 2);
  std::mt19937 rng(7);
  HubFans::Counts counts;
  int64_t rays = 0, hits = 0;
  for (int i = 0; i < 400; ++i) {
    const Vec3& x = cone.positions[2 + (i * rim) / 400];
    const Vec3 inward = (Vec3(0, 0, 0.4) - x) / Norm(Vec3(0, 0, 0.4) - x);
    const Vec3 o = x - (*scene)->origin();
    for (const Vec3& d : ConeDirections(inward, 16, rng)) {
      ++rays;
      for (int f = 0; f < fans.num_fans(); ++f) {
        fans.Trace(
            f, o, d, 1e-6, 1e30,
            [&](const HubFans::Hit& h) {
              hits += h.t > 1e-3;
              return 1e30;
            },
            &counts);
      }
    }
  }
  EXPECT_GT(hits, rays / 2);  // the rays cross the cone.
  return static_cast<double>(counts.nodes + counts.triangles) / rays;
}

// Embree's boxes make this quadratic (docs/benchmarks.md: the 16k cone took
// 15 times the 4k one); here four times the valence costs a few more levels.
TEST(HubFansTest, WorkPerRayGrowsWithTheLogarithmOfTheValence) {
  const double at_4k = WorkPerRay(4000), at_16k = WorkPerRay(16000);
  EXPECT_LT(at_16k, 1.5 * at_4k) << at_4k << " " << at_16k;
  EXPECT_LT(at_4k, 200);
}

// Every vertex's rays (its one-ring excluded, as in a pass) find the same
// candidates whoever traces the fans: the same primitives and edge flags, at
// distances within single-precision rounding of each other.
void ExpectSameCandidatesAsEmbree(const Mesh& mesh) {
  const MeshTopology topo = MeshTopology::Build(mesh);
  auto ours = RayScene::Create(mesh, topo, BvhUpdatePolicy::kRebuild);
  auto embree = RayScene::Create(mesh, topo, BvhUpdatePolicy::kRebuild,
                                 RayTest::kWatertight, FanTracing::kEmbree);
  ASSERT_TRUE(ours.ok() && embree.ok());
  ASSERT_FALSE((*ours)->hub_fans().empty());
  ASSERT_TRUE((*embree)->hub_fans().empty());
  const int n = 21;
  int64_t hits = 0;
  testing::CompareFans(
      mesh, topo, **ours, **embree, n, 13,
      [&](int64_t v, const std::vector<int32_t>&, const std::vector<Vec3>& dirs,
          const std::vector<HitCandidates>& a,
          const std::vector<HitCandidates>& b) {
        for (int k = 0; k < n; ++k) {
          ASSERT_EQ(a[k].count(), b[k].count())
              << "vertex " << v << " ray " << k;
          hits += a[k].count() > 0;
          for (int i = 0; i < a[k].count(); ++i) {
            ASSERT_EQ(a[k][i].prim, b[k][i].prim) << "vertex " << v;
            ASSERT_EQ(a[k][i].edge, b[k][i].edge) << "vertex " << v;
            // Single-precision coordinates make a distance err by about
            // 2^-24 over the cosine between the ray and the triangle's
            // normal (grazing rays: cosines down to 1e-3 here).
            const auto& c = topo.primitives[a[k][i].prim].v;
            const Vec3 normal =
                Cross(mesh.positions[c[1]] - mesh.positions[c[0]],
                      mesh.positions[c[2]] - mesh.positions[c[0]]);
            const double cosine = std::abs(Dot(normal, dirs[k])) / Norm(normal);
            ASSERT_NEAR(a[k][i].t, b[k][i].t, 1e-6 * (1 + b[k][i].t) / cosine);
          }
        }
      });
  EXPECT_GT(hits, mesh.num_vertices() * n / 10);
}

TEST(HubFansTest, CandidatesAreEmbreesOnAFanCone) {
  ExpectSameCandidatesAsEmbree(MakeFanCone(600));
}

// The caps' rims are shared with the wall, which Embree traces: the wall's
// triangles along them are traced by both.
TEST(HubFansTest, CandidatesAreEmbreesOnAFanCappedCylinder) {
  ExpectSameCandidatesAsEmbree(MakeFanCylinder(600));
}

// Rays aimed from outside at every vertex of a posed, fan-capped cylinder
// and at points of its edges as the ray tracer sees them (its corners rounded
// to single precision): the hubs, the edges between two cap triangles (both
// traced by HubFans), the rims (a cap triangle and a wall triangle) and the
// wall's edges. A ray is lost when it does not meet the surface at the point
// aimed at.
// A rotation about (1, 2, 3) by 0.7 radians and a shift (coordinates whose
// single-precision rounding is not exact in any axis), times `scale`, and
// then for a small scale moved into the unit box.
Vec3 Pose(const Vec3& p, double scale) {
  const Vec3 k = Vec3(1, 2, 3) / std::sqrt(14.0);
  const double c = std::cos(0.7), s = std::sin(0.7);
  const Vec3 r = p * c + Cross(k, p) * s + k * (Dot(k, p) * (1 - c));
  const Vec3 at = scale == 1 ? Vec3() : Vec3(0.8, 0.7, 0.6);
  return (r + Vec3(0.31, -0.22, 0.13)) * scale + at;
}

// With `caps_only`, only the edges of cap triangles (the fans' own and their
// rims) are aimed at. With `scale` below 1 the cylinder is that small inside
// a unit box: a fan far smaller than the scene's coordinates, whose rounding
// is then large against the fan.
int64_t RaysLostOnACylinder(FanTracing tracing, RayTest test,
                            bool caps_only = false, double scale = 1) {
  const int rim = 601;
  const Mesh local = MakeFanCylinder(rim);
  Mesh mesh = local;
  for (Vec3& p : mesh.positions) p = Pose(p, scale);
  if (scale != 1) {
    const Mesh box = MakeBox(1, 1, 1, 0.25);
    const auto first = static_cast<int32_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), box.positions.begin(),
                          box.positions.end());
    for (Face f : box.faces) {
      for (int k = 0; k < f.size; ++k) f.v[k] += first;
      mesh.faces.push_back(f);
    }
  }
  const MeshTopology topo = MeshTopology::Build(mesh);
  auto scene =
      RayScene::Create(mesh, topo, BvhUpdatePolicy::kRebuild, test, tracing);
  EXPECT_TRUE(scene.ok());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> along(0, 1);
  // Points of the edges as the ray tracer sees them: between the corners
  // rounded to single precision (relative to the scene's origin), where
  // the sides' tests decide on rounding (in the local frame).
  const Vec3 origin = (*scene)->origin();
  auto rounded = [&](int32_t v) {
    const Vec3 p = mesh.positions[v] - origin;
    return Vec3(static_cast<float>(p.x), static_cast<float>(p.y),
                static_cast<float>(p.z)) +
           origin;
  };
  struct Target {
    Vec3 local;  // where on the cylinder (which side to come from).
    Vec3 aimed;  // the point aimed at, on the rounded surface.
  };
  std::vector<Target> targets;
  for (int64_t v = 0; v < local.num_vertices(); ++v) {
    targets.push_back({local.positions[v], rounded(v)});
  }
  for (const Face& f : local.faces) {
    if (caps_only && f.v[0] > 1 && f.v[1] > 1 && f.v[2] > 1) continue;
    for (int k = 0; k < 3; ++k) {
      const int32_t a = f.v[k], b = f.v[(k + 1) % 3];
      for (int i = 0; i < 8; ++i) {
        const double s = along(rng);
        targets.push_back(
            {local.positions[a] + (local.positions[b] - local.positions[a]) * s,
             rounded(a) + (rounded(b) - rounded(a)) * s});
      }
    }
  }
  std::uniform_real_distribution<double> tilt(-0.3, 0.3);
  int64_t aimed = 0, lost = 0;
  for (const auto& [target, at] : targets) {
    // From below or above a cap (outside its rim for a rim), or from outside
    // the wall, obliquely.
    const double r = std::hypot(target.x, target.y);
    Vec3 out;
    if (std::abs(target.z - 0.5) > 0.5 - 1e-12) {
      out = Vec3(0, 0, target.z < 0.5 ? -1 : 1);
      if (r > 0.99) out = out + Vec3(target.x, target.y, 0) * 0.5;
    } else {
      out = Vec3(target.x / r, target.y / r, 0);
    }
    const Vec3 from =
        Pose(target + (out + Vec3(tilt(rng), tilt(rng), 0)) * 0.3, scale);
    ++aimed;
    lost += testing::RayIsLost(**scene, from, at);
  }
  EXPECT_EQ(aimed, static_cast<int64_t>(targets.size()));
  return lost;
}

TEST(HubFansTest, RaysThroughSharedEdgesAndVerticesAreNotLost) {
  EXPECT_EQ(RaysLostOnACylinder(FanTracing::kHubFans, RayTest::kWatertight), 0);
  EXPECT_EQ(RaysLostOnACylinder(FanTracing::kEmbree, RayTest::kWatertight), 0);
}

// Embree's fast test decides by its rounding and loses rays at shared edges,
// a cap's rim among them. Where a wall triangle meets a cap it never decides
// alone, as HubFans traces the wall triangles near the cap's vertices too: no
// ray aimed at a cap's edges is lost even then (without those copies, 1432
// of them were).
TEST(HubFansTest, AFansRimNeverDependsOnEmbreesRounding) {
  EXPECT_GT(RaysLostOnACylinder(FanTracing::kEmbree, RayTest::kFast, true),
            100);
  EXPECT_EQ(RaysLostOnACylinder(FanTracing::kHubFans, RayTest::kFast, true), 0);
}

// A primitive reported twice at different distances (by Embree and by
// HubFans) keeps the nearer report, in either order.
TEST(HubFansTest, ARepeatedCandidateKeepsItsNearestReport) {
  HitCandidates a(1), b(1);
  a.Add(7, 2.0f, false);
  a.Add(3, 2.00001f, false);
  a.Add(7, 1.9999999f, true);
  b.Add(7, 1.9999999f, true);
  b.Add(3, 2.00001f, false);
  b.Add(7, 2.0f, false);
  ASSERT_EQ(a.count(), b.count());
  for (int i = 0; i < a.count(); ++i) {
    EXPECT_EQ(a[i].prim, b[i].prim);
    EXPECT_EQ(a[i].t, b[i].t);
    EXPECT_EQ(a[i].edge, b[i].edge);
  }
  EXPECT_EQ(a[0].prim, 7);
  EXPECT_EQ(a[0].t, 1.9999999f);
  EXPECT_TRUE(a[0].edge);
}

}  // namespace
}  // namespace meshgauge
