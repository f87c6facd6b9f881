// MeshTopology's incidences against brute-force definitions, and what it
// stores (issue 27: no list held twice, no unused capacity).
#include "lib/core/topology.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "lib/core/normals.h"
#include "lib/core/shapes.h"
#include "lib/embree/sdf_evaluator.h"

namespace meshgauge {
namespace {

// A triangle mesh, a quad mesh and a 2D curve with a hole.
std::vector<Mesh> Meshes() {
  return {MakeIcosphere(1.0, 3), MakeBox(1.0, 2.0, 0.5, 0.25, /*quads=*/true),
          MakeHollowSquare(2.0, 0.5, 0.1)};
}

// The primitives a hit near an edge must consider are those across that
// edge, whatever the valence of its ends (counted, not timed: every
// primitive of both ends made a pass quadratic on fan caps).
TEST(TopologyTest, PrimitivesNearAPointAreAcrossItsEdgeNotAroundAHub) {
  for (int n : {4000, 16000}) {
    const Mesh cone = MakeFanCone(n);
    const MeshTopology topo = MeshTopology::Build(cone);
    std::vector<int32_t> out;
    // Mantle triangle 0 = (apex, rim 0, rim 1); a point halfway up its edge
    // apex-rim 0, just inside.
    const Vec3 apex = cone.positions[0], rim = cone.positions[2];
    const Vec3 mid = (apex + rim) * 0.5;
    AppendPrimitivesNear(topo, cone, 0, mid, 1e-9, &out);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    // This triangle and the mantle triangle across the edge.
    EXPECT_EQ(out.size(), 2u) << n;
    // Near the rim vertex: its one ring (two mantle, two base triangles).
    out.clear();
    AppendPrimitivesNear(topo, cone, 0, rim + (apex - rim) * 1e-12, 1e-9,
                         &out);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    EXPECT_EQ(out.size(), 4u) << n;
    // Only a point at the apex itself gets the apex's whole fan.
    out.clear();
    AppendPrimitivesNear(topo, cone, 0, apex, 1e-9, &out);
    EXPECT_EQ(std::ssize(out), n);
    // Far from every edge and corner: nothing.
    out.clear();
    AppendPrimitivesNear(topo, cone, 0, (apex + rim + cone.positions[3]) / 3,
                         1e-9, &out);
    EXPECT_TRUE(out.empty()) << n;
  }
}

TEST(TopologyTest, PrimitivesOfAVertexAreThoseContainingIt) {
  for (const Mesh& mesh : Meshes()) {
    const MeshTopology topo = MeshTopology::Build(mesh);
    for (int64_t p = 0; p < mesh.num_vertices(); ++p) {
      std::vector<int32_t> want;
      for (size_t q = 0; q < topo.primitives.size(); ++q) {
        const auto& v = topo.primitives[q].v;
        if (std::find(v.begin(), v.end(), p) != v.end()) {
          want.push_back(static_cast<int32_t>(q));
        }
      }
      const auto got = topo.PrimitivesOf(p);
      ASSERT_EQ(std::vector<int32_t>(got.begin(), got.end()), want)
          << "vertex " << p;
    }
  }
}

TEST(TopologyTest, NeighborsAreTheOtherEndsOfTheFaceEdges) {
  for (const Mesh& mesh : Meshes()) {
    const MeshTopology topo = MeshTopology::Build(mesh);
    std::vector<std::vector<int32_t>> want(mesh.num_vertices());
    for (const Face& f : mesh.faces) {
      const int edges = f.size == 2 ? 1 : f.size;  // a quad's four sides.
      for (int k = 0; k < edges; ++k) {
        const int32_t a = f.v[k], b = f.v[(k + 1) % f.size];
        want[a].push_back(b);
        want[b].push_back(a);
      }
    }
    std::vector<int32_t> got;
    for (int64_t p = 0; p < mesh.num_vertices(); ++p) {
      std::sort(want[p].begin(), want[p].end());
      want[p].erase(std::unique(want[p].begin(), want[p].end()), want[p].end());
      VertexNeighbors(mesh, topo, p, &got);
      ASSERT_EQ(got, want[p]) << "vertex " << p;
    }
  }
}

TEST(TopologyTest, ATriangleMeshStoresEachListOnceWithoutSpareCapacity) {
  const Mesh mesh = MakeIcosphere(1.0, 8);
  auto ev = SdfEvaluator::Create(mesh);
  ASSERT_TRUE(ev.ok()) << ev.status();
  const int64_t nv = mesh.num_vertices(), nf = mesh.num_faces();
  // One primitive per face, each face's three corners listed once by
  // vertex, one cone direction per vertex and the vertices' Morton order:
  // nothing else.
  const int64_t want = nf * sizeof(Primitive) +
                       (nv + 1 + 3 * nf) * sizeof(int32_t) +
                       nv * sizeof(ConeDirection) + nv * sizeof(int32_t);
  EXPECT_EQ((*ev)->DerivedBytes(), want);
}

TEST(TopologyTest, OneVertexNormalIsTheSumOverEveryPrimitiveContainingIt) {
  for (const Mesh& mesh : Meshes()) {
    const MeshTopology topo = MeshTopology::Build(mesh);
    // SPEC §2's sum over all primitives, in ascending order (bit-identical
    // when the per-vertex lists are right and ascending).
    std::vector<Vec3> want(mesh.num_vertices());
    for (const Primitive& prim : topo.primitives) {
      for (int32_t v : prim.v) {
        if (v >= 0) want[v] += PrimitiveNormal(mesh, prim);
      }
    }
    for (int64_t p = 0; p < mesh.num_vertices(); ++p) {
      const Vec3 one =
          UnnormalizedNormal(mesh, topo, p, NormalWeighting::kArea);
      ASSERT_EQ(std::memcmp(&one, &want[p], sizeof(Vec3)), 0) << "vertex " << p;
    }
  }
}

}  // namespace
}  // namespace meshgauge
