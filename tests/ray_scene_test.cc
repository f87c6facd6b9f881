// RayScene's packet tracing: a fan of rays from one origin, traced 16 at a
// time, finds what each ray traced alone finds, bit for bit.
#include "lib/embree/ray_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "lib/core/shapes.h"

namespace meshgauge {
namespace {

// Random unit directions, `n` per vertex (n not a multiple of 16, so the
// last packet of every fan is partial).
void ExpectFansHitAsSingleRays(const Mesh& mesh, int n) {
  const MeshTopology topo = MeshTopology::Build(mesh);
  auto scene = RayScene::Create(mesh, topo, BvhUpdatePolicy::kRebuild);
  ASSERT_TRUE(scene.ok()) << scene.status();
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss;
  std::vector<Vec3> dirs(n);
  std::vector<RayScene::Hit> fan(n);
  int64_t hits = 0;
  for (const Vec3& x : mesh.positions) {
    for (Vec3& d : dirs) {
      d = Vec3(gauss(rng), gauss(rng), mesh.dimension == 3 ? gauss(rng) : 0);
      d = d / std::sqrt(Dot(d, d));
    }
    (*scene)->IntersectFan(x, dirs, 1e-4f, 1e30f, absl::MakeSpan(fan));
    for (int k = 0; k < n; ++k) {
      const RayScene::Hit one = (*scene)->Intersect(x, dirs[k], 1e-4f, 1e30f);
      ASSERT_EQ(fan[k].prim, one.prim) << "ray " << k;
      ASSERT_EQ(fan[k].t, one.t) << "ray " << k;
      hits += one.prim >= 0;
    }
  }
  EXPECT_GT(hits, mesh.num_vertices() * n / 4);  // the test sees hits.
}

TEST(RaySceneTest, AFanTracedInPacketsHitsAsSingleRays3d) {
  ExpectFansHitAsSingleRays(MakeTorus(1.0, 0.4, 48, 24), 37);
}

TEST(RaySceneTest, AFanTracedInPacketsHitsAsSingleRays2d) {
  ExpectFansHitAsSingleRays(MakeCircle(1.0, 200), 21);
}

}  // namespace
}  // namespace meshgauge
