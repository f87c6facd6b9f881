// Components, per-component orientation and the diagnostics of loaded
// meshes; quads keep their diagonal when reversed.
#include "lib/core/components.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <random>

#include "absl/strings/str_join.h"
#include "lib/core/mesh_repair.h"
#include "lib/core/missing_diagnosis.h"
#include "lib/core/missing_values.h"
#include "lib/core/shapes.h"
#include "lib/core/weld.h"
#include "lib/io/mesh_io.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

Mesh TwoBoxes(bool second_inward) {
  Mesh a = MakeBox(1, 1, 1, 0.5, /*quads=*/true);
  Mesh b = MakeBox(1, 1, 1, 0.5, /*quads=*/true);
  const int32_t offset = static_cast<int32_t>(a.positions.size());
  for (Vec3 p : b.positions) a.positions.push_back(p + Vec3(3, 0, 0));
  for (Face f : b.faces) {
    for (int k = 0; k < f.size; ++k) f.v[k] += offset;
    if (second_inward) ReverseFace(f);
    a.faces.push_back(f);
  }
  return a;
}

TEST(ComponentsTest, FindsTheInwardComponentAndFlipsOnlyIt) {
  Mesh m = TwoBoxes(true);
  ASSERT_TRUE(ValidateMesh(m).ok());
  const auto comps = ConnectedComponents(m);
  ASSERT_EQ(comps.size(), 2u);
  EXPECT_TRUE(comps[0].closed && comps[1].closed);
  EXPECT_NEAR(comps[0].signed_volume, 1, 1e-12);
  EXPECT_NEAR(comps[1].signed_volume, -1, 1e-12);
  // The total volume is zero: a whole-mesh test would see nothing wrong.
  EXPECT_NEAR(SignedVolume(m), 0, 1e-12);
  const MeshDiagnostics d = DiagnoseMesh(m);
  EXPECT_EQ(d.inward_components, std::vector<int64_t>{1});
  const Mesh before = m;
  EXPECT_EQ(ReorientComponents(m).components_turned_outward, 1);
  for (size_t f = 0; f < comps[0].faces.size(); ++f) {
    EXPECT_EQ(m.faces[f].v, before.faces[f].v);  // first body untouched.
  }
  EXPECT_TRUE(DiagnoseMesh(m).inward_components.empty());
  EXPECT_NEAR(SignedVolume(m), 2, 1e-12);
}

// Nested shells: a part's outer shell faces out of the material, a
// cavity's shell into the cavity (negative signed volume: correct), an
// island in a cavity out again. `shells` are boxes (origin, size) in
// order; `inverted` names the one turned inside out (-1: none).
struct Shell {
  Vec3 origin;
  double size;
  int depth;  // how many of the others enclose it.
};

Mesh NestedShells(const std::vector<Shell>& shells, int inverted) {
  Mesh m;
  for (size_t i = 0; i < shells.size(); ++i) {
    const Shell& s = shells[i];
    Mesh b = MakeBox(s.size, s.size, s.size, s.size / 2, /*quads=*/true);
    const int32_t offset = static_cast<int32_t>(m.positions.size());
    for (const Vec3& p : b.positions) m.positions.push_back(p + s.origin);
    // Correct: outward at even depth, into the cavity at odd depth.
    const bool reverse = (s.depth % 2 == 1) != (static_cast<int>(i) == inverted);
    for (Face f : b.faces) {
      for (int k = 0; k < f.size; ++k) f.v[k] += offset;
      if (reverse) ReverseFace(f);
      m.faces.push_back(f);
    }
  }
  return m;
}

TEST(NestingTest, CavitiesFacingIntoThemselvesAreNotInvertedAndStay) {
  const std::vector<std::vector<Shell>> parts = {
      // A hollow box: a 2-unit wall around a cavity.
      {{{0, 0, 0}, 10, 0}, {{2, 2, 2}, 6, 1}},
      // A box with two cavities.
      {{{0, 0, 0}, 10, 0}, {{1, 1, 1}, 3, 1}, {{5, 5, 5}, 3, 1}},
      // A cavity holding an island.
      {{{0, 0, 0}, 10, 0}, {{2, 2, 2}, 6, 1}, {{4, 4, 4}, 2, 2}},
  };
  for (size_t p = 0; p < parts.size(); ++p) {
    const std::vector<Shell>& shells = parts[p];
    const Mesh correct = NestedShells(shells, -1);
    const std::vector<Component> components = ConnectedComponents(correct);
    ASSERT_EQ(components.size(), shells.size());
    for (size_t i = 0; i < shells.size(); ++i) {
      EXPECT_EQ(components[i].nesting_depth, shells[i].depth) << p << " " << i;
      EXPECT_FALSE(components[i].inverted()) << p << " " << i;
    }
    const MeshDiagnostics d = DiagnoseMesh(correct);
    EXPECT_TRUE(d.inward_components.empty()) << p;
    EXPECT_TRUE(d.warnings.empty()) << p << ": " << d.warnings[0];
    Mesh reoriented = correct;
    const Reorientation r = ReorientComponents(reoriented);
    EXPECT_EQ(r.components_turned_outward, 0) << p;
    for (size_t f = 0; f < correct.faces.size(); ++f) {
      ASSERT_EQ(reoriented.faces[f].v, correct.faces[f].v) << p << " " << f;
    }
    // Each shell turned inside out, outer, cavity or island, is named
    // alone and turned back.
    for (size_t bad = 0; bad < shells.size(); ++bad) {
      Mesh wrong = NestedShells(shells, static_cast<int>(bad));
      const MeshDiagnostics w = DiagnoseMesh(wrong);
      ASSERT_EQ(w.inward_components, std::vector<int64_t>{int64_t(bad)})
          << p << " " << bad;
      ASSERT_FALSE(w.warnings.empty());
      EXPECT_THAT(w.warnings[0], HasSubstr("turned inside out"));
      const Reorientation back = ReorientComponents(wrong);
      EXPECT_EQ(back.components_turned_outward, 1) << p << " " << bad;
      for (size_t f = 0; f < correct.faces.size(); ++f) {
        ASSERT_EQ(wrong.faces[f].v, correct.faces[f].v) << p << " " << f;
      }
    }
  }
}

TEST(NestingTest, ACurveAroundAHoleIsNotInverted) {
  // The hollow square's hole runs clockwise: into the hole, as it should.
  const Mesh m = MakeHollowSquare(4, 1, 0.2);
  const MeshDiagnostics d = DiagnoseMesh(m);
  EXPECT_TRUE(d.inward_components.empty());
  Mesh reversed = m;
  for (Face& f : reversed.faces) ReverseFace(f);
  EXPECT_EQ(DiagnoseMesh(reversed).inward_components.size(), 2u);
}

TEST(WeldTest, ExactDuplicatesMergeIntoTheLowestAndFacesFollow) {
  Mesh m = testing::SixGridCube();
  const Mesh input = m;
  ASSERT_EQ(m.num_vertices(), 150);  // 6 x 25
  auto weld = WeldVertices(m, 0);
  ASSERT_TRUE(weld.ok()) << weld.status();
  EXPECT_EQ(m.num_vertices(), 98);  // 6 x 4^2 + 2
  EXPECT_EQ(weld->merged, 52);
  ASSERT_EQ(std::ssize(weld->welded_vertex), input.num_vertices());
  const std::vector<int32_t> kept = KeptInputVertices(*weld);
  ASSERT_EQ(std::ssize(kept), m.num_vertices());
  for (int64_t v = 0; v < input.num_vertices(); ++v) {
    const int32_t w = weld->welded_vertex[v];
    EXPECT_EQ(m.positions[w], input.positions[v]);
    EXPECT_LE(kept[w], v);  // the lowest input vertex of its group.
    EXPECT_EQ(input.positions[kept[w]], input.positions[v]);
  }
  for (size_t f = 0; f < m.faces.size(); ++f) {
    for (int k = 0; k < 4; ++k) {
      EXPECT_EQ(m.faces[f].v[k], weld->welded_vertex[input.faces[f].v[k]]);
    }
  }
  EXPECT_TRUE(DiagnoseMesh(m).closed);
  // Values and gradients go back to the input's indexing.
  std::vector<double> values(m.num_vertices());
  for (size_t w = 0; w < values.size(); ++w) values[w] = double(w);
  const std::vector<double> back = Unweld(*weld, values);
  std::vector<Vec3> grad(m.num_vertices(), Vec3(1, 2, 3));
  const std::vector<Vec3> g = UnweldGradient(*weld, grad);
  for (int64_t v = 0; v < input.num_vertices(); ++v) {
    EXPECT_EQ(back[v], double(weld->welded_vertex[v]));
    EXPECT_EQ(g[v], kept[weld->welded_vertex[v]] == v ? Vec3(1, 2, 3) : Vec3());
  }
  const std::vector<double> summed =
      WeldWeights(*weld, std::vector<double>(150, 1.0), m.num_vertices());
  EXPECT_EQ(std::accumulate(summed.begin(), summed.end(), 0.0), 150.0);
  EXPECT_EQ(*std::max_element(summed.begin(), summed.end()), 3.0);  // corners
}

TEST(WeldTest, NegativeZeroEqualsZeroAndNothingMergedLeavesTheMesh) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-0.0, 0, -0.0}, {1, 1, 0}};
  m.faces = {Face::Triangle(0, 1, 2), Face::Triangle(3, 4, 2)};
  auto weld = WeldVertices(m, 0);
  ASSERT_TRUE(weld.ok()) << weld.status();
  EXPECT_EQ(weld->merged, 1);
  EXPECT_EQ(weld->welded_vertex, (std::vector<int32_t>{0, 1, 2, 0, 3}));
  EXPECT_EQ(m.faces[1].v[0], 0);
  Mesh tetra = MakeIcosphere(1, 1);
  const Mesh before = tetra;
  auto none = WeldVertices(tetra, 0);
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->merged, 0);
  EXPECT_TRUE(none->welded_vertex.empty());
  EXPECT_EQ(tetra.positions, before.positions);
}

TEST(WeldTest, ATolerancePastAFacesEdgeIsRefusedNamingTheFace) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1e-9, 0, 0}, {1, 1, 0}};
  m.faces = {Face::Triangle(0, 1, 2), Face::Triangle(3, 4, 2)};
  Mesh near = m;
  auto weld = WeldVertices(near, 1e-6);
  ASSERT_TRUE(weld.ok()) << weld.status();
  EXPECT_EQ(weld->merged, 1);
  EXPECT_EQ(weld->welded_vertex[3], 0);
  Mesh collapsed = m;
  collapsed.faces.push_back(Face::Triangle(0, 3, 4));
  auto refused = WeldVertices(collapsed, 1e-6);
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(refused.status().message(), HasSubstr("face 2"));
  EXPECT_THAT(refused.status().message(), HasSubstr("smaller tolerance"));
  for (double bad : {-1.0, 1e-13, 0.02, std::nan("")}) {
    Mesh copy = m;
    EXPECT_EQ(WeldVertices(copy, bad).status().code(),
              absl::StatusCode::kInvalidArgument)
        << bad;
  }
}

TEST(ComponentsTest, ReversedQuadKeepsItsDiagonal) {
  Face q = Face::Quad(10, 11, 12, 13);
  ReverseFace(q);
  EXPECT_EQ(q.v, (std::array<int32_t, 4>{10, 13, 12, 11}));
  // The split (0,1,2), (0,2,3) still uses the diagonal 10-12.
  EXPECT_EQ(q.v[0], 10);
  EXPECT_EQ(q.v[2], 12);
  Face s = Face::Segment(1, 2);
  ReverseFace(s);
  EXPECT_EQ(s.v[0], 2);
  EXPECT_EQ(s.v[1], 1);
}

// Faces with a face of the same corners in the opposite cyclic order, by
// comparing every pair.
int64_t BruteForceDoubleSided(const Mesh& m) {
  auto same_cycle = [](const Face& a, const Face& b) {
    if (a.size != b.size) return false;
    for (int shift = 0; shift < a.size; ++shift) {
      bool all = true;
      for (int k = 0; k < a.size; ++k) {
        all &= a.v[k] == b.v[(k + shift) % b.size];
      }
      if (all) return true;
    }
    return false;
  };
  int64_t count = 0;
  for (size_t i = 0; i < m.faces.size(); ++i) {
    Face reversed = m.faces[i];
    ReverseFace(reversed);
    for (size_t j = 0; j < m.faces.size(); ++j) {
      if (j != i && same_cycle(reversed, m.faces[j])) {
        ++count;
        break;
      }
    }
  }
  return count;
}

TEST(ComponentsTest, DoubleSidedFacesMatchAPairwiseCountInLargeFans) {
  // A fan of 60 triangles and 20 quads around vertex 0 (more than the 32 a
  // vertex's group sorts by insertion), some repeated in either
  // orientation and rotation, and faces whose smallest corner is elsewhere.
  Mesh m;
  for (int i = 0; i < 64; ++i) m.positions.push_back({1.0 * i, 1.0 * i * i, 0});
  uint32_t state = 12345;
  auto next = [&state](int n) {
    state = state * 1664525u + 1013904223u;
    return static_cast<int32_t>((state >> 8) % n);
  };
  for (int i = 0; i < 80; ++i) {
    const int32_t a = 1 + next(30), b = 31 + next(30);
    Face f = i < 60 ? Face::Triangle(0, a, b) : Face::Quad(0, a, b, 62);
    if (i % 3 == 0) ReverseFace(f);
    if (i % 5 == 0)
      std::rotate(f.v.begin(), f.v.begin() + 1, f.v.begin() + f.size);
    m.faces.push_back(f);
    if (i % 4 == 0) {
      Face g = f;
      if (i % 8 == 0) ReverseFace(g);
      m.faces.push_back(g);
    }
  }
  m.faces.push_back(Face::Triangle(5, 6, 7));
  m.faces.push_back(Face::Triangle(6, 5, 7));
  const int64_t want = BruteForceDoubleSided(m);
  EXPECT_GT(want, 10);
  EXPECT_EQ(DiagnoseMesh(m).double_sided_faces, want);
}

// A curve has no face to compare (the face-key grouping gets no items).
TEST(ComponentsTest, ACurveHasNoDoubleSidedFaces) {
  const MeshDiagnostics d = DiagnoseMesh(MakeCircle(1.0, 12));
  EXPECT_EQ(d.double_sided_faces, 0);
  EXPECT_TRUE(d.closed);
}

TEST(ComponentsTest, CountsDoubleSidedFacesAndBoundaryEdges) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  m.faces = {Face::Triangle(0, 1, 2), Face::Triangle(1, 2, 0),
             Face::Triangle(0, 2, 1), Face::Triangle(1, 3, 2)};
  const MeshDiagnostics d = DiagnoseMesh(m);
  EXPECT_EQ(d.double_sided_faces, 3);  // 0 and 1 face 2 (a rotation of 0).
  EXPECT_GT(d.boundary_edges, 0);
  EXPECT_EQ(d.shared_edges, 3);  // the three copies' edges.
  EXPECT_EQ(d.warnings.size(), 3u);
}

// Outsider report: cubes exported with texture seams (trimesh's
// cube_blender_uv.ply, BoxTextured.ply) were only called open.
TEST(ComponentsTest, UnweldedSeamsAreNamed) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0},
                 {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  m.faces = {Face::Triangle(0, 1, 2), Face::Triangle(3, 5, 4)};
  const MeshDiagnostics d = DiagnoseMesh(m);
  EXPECT_EQ(d.boundary_edges, 6);
  EXPECT_EQ(d.coincident_boundary_vertices, 4);  // 1 and 3, 2 and 4.
  EXPECT_THAT(absl::StrJoin(d.warnings, ""),
              HasSubstr("4 boundary vertices have exactly the position of "
                        "another (unwelded seams"));
  // Welded, the square has no such vertex.
  m.faces[1] = Face::Triangle(1, 5, 2);
  EXPECT_EQ(DiagnoseMesh(m).coincident_boundary_vertices, 0);
  EXPECT_EQ(DiagnoseMesh(MakeBox(1, 1, 1, 0.5)).coincident_boundary_vertices,
            0);
}

TEST(ComponentsTest, DropDegenerateFacesKeepsVerticesAndRegions) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}};
  m.faces = {Face::Triangle(0, 1, 2), Face::Triangle(0, 1, 3),
             Face::Triangle(2, 2, 1)};
  m.face_regions = {4, 5, 6};
  EXPECT_EQ(DropDegenerateFaces(m), 2);
  EXPECT_EQ(m.num_vertices(), 4);
  EXPECT_EQ(m.face_regions, std::vector<int32_t>{4});
}

TEST(ComponentsTest, TinyCoordinatesAreWarnedAbout) {
  Mesh tiny = MakeIcosphere(1, 2);
  for (Vec3& p : tiny.positions) p = p * 4e-320;  // subnormal coordinates.
  const MeshDiagnostics d = DiagnoseMesh(tiny);
  ASSERT_FALSE(d.warnings.empty());
  EXPECT_THAT(d.warnings.back(), HasSubstr("coordinates are tiny"));
  for (const std::string& w : DiagnoseMesh(MakeIcosphere(1, 2)).warnings) {
    EXPECT_THAT(w, Not(HasSubstr("tiny")));
  }
}

TEST(ComponentsTest, SignedVolumeIsExactFarFromTheOrigin) {
  Mesh box = MakeBox(1, 1, 1, 1);
  for (Vec3& p : box.positions) p += Vec3(1e7, 1e7, 1e7);
  EXPECT_NEAR(SignedVolume(box), 1, 1e-6);
}

// A sphere with `flipped` faces reversed (every third face from the 5th).
Mesh SphereWithFlippedFaces(int* flipped) {
  Mesh m = MakeIcosphere(1, 3);
  *flipped = 0;
  for (size_t f = 5; f < m.faces.size(); f += 3) {
    ReverseFace(m.faces[f]);
    ++*flipped;
  }
  return m;
}

TEST(OrientationTest, EdgesUsedTwiceInOneDirectionAreNamedPerComponent) {
  int flipped = 0;
  const Mesh m = SphereWithFlippedFaces(&flipped);
  const MeshDiagnostics d = DiagnoseMesh(m);
  // Each flipped face disagrees with its 3 neighbours unless one of them is
  // flipped too: at least one disagreeing edge per flipped face.
  EXPECT_GE(d.inconsistent_edges, flipped);
  EXPECT_EQ(d.inconsistent_components, std::vector<int64_t>{0});
  EXPECT_THAT(absl::StrJoin(d.warnings, "\n"),
              HasSubstr("used twice in the same direction) in components 0"));
  EXPECT_EQ(DiagnoseMesh(MakeIcosphere(1, 3)).inconsistent_edges, 0);
}

TEST(OrientationTest, ReorientMakesEachComponentConsistentThenOutward) {
  int flipped = 0;
  Mesh sphere = SphereWithFlippedFaces(&flipped);
  // Second body: a box turned inside out, with one face then put back.
  Mesh m = TwoBoxes(/*second_inward=*/true);
  const int32_t offset = static_cast<int32_t>(m.positions.size());
  ReverseFace(m.faces[m.faces.size() - 1]);
  for (Vec3 p : sphere.positions) m.positions.push_back(p + Vec3(0, 5, 0));
  for (Face f : sphere.faces) {
    for (int k = 0; k < f.size; ++k) f.v[k] += offset;
    m.faces.push_back(f);
  }
  ASSERT_TRUE(ValidateMesh(m).ok());
  const Reorientation r = ReorientComponents(m);
  EXPECT_EQ(r.faces_made_consistent, flipped + 1);
  EXPECT_EQ(r.components_made_consistent, 2);
  EXPECT_EQ(r.components_turned_outward, 1);  // the box.
  EXPECT_EQ(r.non_orientable_components, 0);
  const MeshDiagnostics d = DiagnoseMesh(m);
  EXPECT_EQ(d.inconsistent_edges, 0);
  EXPECT_TRUE(d.inward_components.empty());
  for (const Component& c : ConnectedComponents(m)) {
    EXPECT_GT(c.signed_volume, 0);
  }
}

// The shared-analysis ReorientAndDiagnose gives what the two calls give,
// on meshes where every one of its updates matters: faces made consistent
// (pair directions), a component turned outward (volumes), a double-sided
// pair, a reversed segment of a curve, a duplicated face that turning
// makes double-sided.
TEST(OrientationTest, ReorientAndDiagnoseEqualsTheTwoCalls) {
  int flipped = 0;
  Mesh sphere = SphereWithFlippedFaces(&flipped);
  Mesh boxes = TwoBoxes(/*second_inward=*/true);
  ReverseFace(boxes.faces.back());
  Mesh sided = MakeIcosphere(1, 2);
  Face back = sided.faces[0];
  ReverseFace(back);
  sided.faces.push_back(back);
  Mesh curve = MakeCircle(1, 16);
  ReverseFace(curve.faces[3]);
  // Two copies of one triangle, alike: they disagree across all three
  // edges, and making them agree turns one into the other's back.
  Mesh twins;
  twins.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  twins.faces = {Face::Triangle(0, 1, 2), Face::Triangle(0, 1, 2)};
  {
    Mesh t = twins;
    Reorientation r;
    EXPECT_EQ(DiagnoseMesh(t).double_sided_faces, 0);
    EXPECT_EQ(ReorientAndDiagnose(t, &r).double_sided_faces, 2);
    EXPECT_EQ(r.faces_made_consistent, 1);
  }
  for (const Mesh& m : {sphere, boxes, sided, curve, twins}) {
    Mesh a = m, b = m;
    const Reorientation ra = ReorientComponents(a);
    const MeshDiagnostics da = DiagnoseMesh(a);
    Reorientation rb;
    const MeshDiagnostics db = ReorientAndDiagnose(b, &rb);
    EXPECT_EQ(ra.faces_made_consistent, rb.faces_made_consistent);
    EXPECT_EQ(ra.components_made_consistent, rb.components_made_consistent);
    EXPECT_EQ(ra.components_turned_outward, rb.components_turned_outward);
    EXPECT_EQ(ra.non_orientable_components, rb.non_orientable_components);
    EXPECT_EQ(da.warnings, db.warnings);
    EXPECT_EQ(da.inconsistent_edges, db.inconsistent_edges);
    EXPECT_EQ(da.inward_components, db.inward_components);
    EXPECT_EQ(da.double_sided_faces, db.double_sided_faces);
    for (size_t f = 0; f < a.faces.size(); ++f) {
      EXPECT_EQ(a.faces[f].v, b.faces[f].v) << f;
    }
  }
}

TEST(OrientationTest, AMoebiusBandIsNamedNonOrientable) {
  // A band of 8 quads whose ends join with a half twist.
  Mesh m;
  constexpr int kN = 8;
  for (int i = 0; i < kN; ++i) {
    const double a = 2 * M_PI * i / kN, t = 0.5 * a;
    for (double s : {-0.3, 0.3}) {
      m.positions.push_back({(1 + s * std::cos(t)) * std::cos(a),
                             (1 + s * std::cos(t)) * std::sin(a),
                             s * std::sin(t)});
    }
  }
  for (int i = 0; i < kN; ++i) {
    const int32_t a0 = 2 * i, a1 = 2 * i + 1;
    int32_t b0 = 2 * ((i + 1) % kN), b1 = b0 + 1;
    if (i == kN - 1) std::swap(b0, b1);  // the half twist.
    m.faces.push_back(Face::Quad(a0, b0, b1, a1));
  }
  ASSERT_TRUE(ValidateMesh(m).ok());
  EXPECT_EQ(ReorientComponents(m).non_orientable_components, 1);
  EXPECT_EQ(DiagnoseMesh(m).inconsistent_edges, 1);
}

TEST(OrientationTest, AReversedSegmentOfACurveIsFound) {
  Mesh c = MakeCircle(1, 16);
  ReverseFace(c.faces[3]);
  EXPECT_EQ(DiagnoseMesh(c).inconsistent_edges, 2);
  EXPECT_EQ(ReorientComponents(c).faces_made_consistent, 1);
  EXPECT_EQ(DiagnoseMesh(c).inconsistent_edges, 0);
  EXPECT_GT(SignedVolume(c), 0);
}

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

// Appends `part` to `mesh` as a new component, shifted by `offset`.
void Append(Mesh& mesh, const Mesh& part, const Vec3& offset) {
  const int32_t base = static_cast<int32_t>(mesh.positions.size());
  for (const Vec3& p : part.positions) mesh.positions.push_back(p + offset);
  for (Face f : part.faces) {
    for (int k = 0; k < f.size; ++k) f.v[k] += base;
    mesh.faces.push_back(f);
  }
}

// Warnings for `part` with the values of `missing_faces` (all faces when
// empty) removed, their vertices given `cause`.
std::vector<std::string> WarningsFor(const Mesh& part,
                                     VertexStatus cause = VertexStatus::kNoHit,
                                     std::vector<int32_t> missing_faces = {},
                                     double warn_fraction = 0.01) {
  std::vector<double> values(part.positions.size(), 1.0);
  std::vector<VertexStatus> status(part.positions.size(), VertexStatus::kOk);
  if (missing_faces.empty()) {
    missing_faces.resize(part.faces.size());
    std::iota(missing_faces.begin(), missing_faces.end(), 0);
  }
  for (int32_t f : missing_faces) {
    for (int k = 0; k < part.faces[f].size; ++k) {
      values[part.faces[f].v[k]] = std::numeric_limits<double>::quiet_NaN();
      status[part.faces[f].v[k]] = cause;
    }
  }
  return MissingValueWarnings(part, values, status, warn_fraction);
}

TEST(MissingValueWarningsTest, NamesEachComponentsCause) {
  Mesh inward = MakeBox(1, 1, 1, 0.5);
  ReverseFaces(inward);
  EXPECT_THAT(absl::StrJoin(WarningsFor(inward), ""),
              HasSubstr("component 0 (48 faces): 100% of its area (100% of "
                        "the mesh's) has no value, 26 vertices: it is closed "
                        "and turned inside out"));
  Mesh mixed = MakeIcosphere(0.6, 2);
  ReverseFace(mixed.faces[3]);
  EXPECT_THAT(absl::StrJoin(WarningsFor(mixed), ""),
              HasSubstr("disagree on orientation"));
  EXPECT_THAT(absl::StrJoin(WarningsFor(MakeBox(1, 1, 1, 0.5),
                                        VertexStatus::kDegenerateNormal),
                            ""),
              HasSubstr("degenerate normal"));
  Mesh sheet = MakeBox(1, 1, 1, 0.5);
  sheet.faces.resize(8);  // one side of the box: flat and open.
  EXPECT_THAT(absl::StrJoin(WarningsFor(sheet), ""), HasSubstr("flat sheet"));
  Mesh open = MakeBox(1, 1, 1, 0.5);
  open.faces.resize(open.faces.size() - 8);  // a side removed.
  EXPECT_THAT(absl::StrJoin(WarningsFor(open), ""), HasSubstr("it is open"));
  // Outsider report: a tetrahedron with one face duplicated, reversed, was
  // called open; it has no boundary edge.
  Mesh doubled = MakeBox(1, 1, 1, 0.5);
  doubled.faces.push_back(doubled.faces[0]);
  ReverseFace(doubled.faces.back());
  EXPECT_THAT(absl::StrJoin(WarningsFor(doubled), ""),
              HasSubstr("it has no boundary, but edges shared by more than "
                        "two faces"));
  // And the mesh's own warnings count such edges (a fin on one edge was
  // only "open, 6 boundary edges").
  EXPECT_EQ(DiagnoseMesh(doubled).shared_edges, 3);
  EXPECT_THAT(absl::StrJoin(DiagnoseMesh(doubled).warnings, ""),
              HasSubstr("3 edges are shared by more than two faces"));
  EXPECT_EQ(DiagnoseMesh(open).shared_edges, 0);
  // The penalty's and face samples' one-line cause too (it said "open or
  // planar").
  EXPECT_THAT(LikelyMissingCause(doubled, {.no_hit = 10}),
              HasSubstr("the mesh has no boundary, but edges shared by more "
                        "than two faces"));
  EXPECT_THAT(LikelyMissingCause(open, {.no_hit = 10}),
              HasSubstr("open or planar"));
  EXPECT_THAT(absl::StrJoin(WarningsFor(MakeIcosphere(1, 3),
                                        VertexStatus::kNoHit, {0, 1, 2}),
                            ""),
              HasSubstr("rays lost at sharp or coarse corners"));
  // The closing error of a closed, outward mesh names the same cause and its
  // fixes (it blamed max_distance and the cone's direction).
  const std::string cause =
      LikelyMissingCause(MakeBox(1, 1, 1, 1), {.no_hit = 2});
  EXPECT_THAT(cause, HasSubstr("closed and outward"));
  EXPECT_THAT(cause, HasSubstr("--samples faces"));
  EXPECT_THAT(cause, HasSubstr("--cone-angle 60"));
  EXPECT_THAT(cause, Not(HasSubstr("max_distance")));
}

// Outsider report: two unit parts 2e7 apart lost the far one's values, and
// the warning blamed the one-ring exclusion.
TEST(MissingValueWarningsTest, APartTooSmallForSinglePrecisionIsNamed) {
  Mesh two;
  Append(two, MakeIcosphere(1, 2), {0, 0, 0});
  Append(two, MakeIcosphere(1, 2), {2e7, 0, 0});
  std::vector<int32_t> far(two.faces.size() / 2);
  std::iota(far.begin(), far.end(), static_cast<int32_t>(far.size()));
  EXPECT_THAT(absl::StrJoin(WarningsFor(two, VertexStatus::kNoHit, far), ""),
              HasSubstr("it spans 3.46 while the mesh spans 2e+07, where "
                        "the ray tracer's single-precision coordinates step "
                        "by about 2.38"));
  // Parts 1e4 apart: resolved, so the usual cause.
  Mesh near;
  Append(near, MakeIcosphere(1, 2), {0, 0, 0});
  Append(near, MakeIcosphere(1, 2), {1e4, 0, 0});
  EXPECT_THAT(absl::StrJoin(WarningsFor(near, VertexStatus::kNoHit, far), ""),
              HasSubstr("rays lost at sharp or coarse corners"));
}

TEST(MissingValueWarningsTest, BelowTheThresholdNothingAndBeyondFiveACount) {
  // One face of 2880 and its neighbours: under 1 % of the surface.
  EXPECT_TRUE(
      WarningsFor(MakeIcosphere(1, 12), VertexStatus::kNoHit, {0}).empty());
  EXPECT_FALSE(
      WarningsFor(MakeIcosphere(1, 3), VertexStatus::kNoHit, {0}, 0.001)
          .empty());
  Mesh seven;
  for (int i = 0; i < 7; ++i)
    Append(seven, MakeBox(1, 1, 1 + i, 0.5), {3.0 * i, 0, 0});
  const auto w = WarningsFor(seven);
  ASSERT_EQ(w.size(), 6u);
  EXPECT_THAT(w[0], HasSubstr("component 6 ("));  // the largest first.
  EXPECT_EQ(w[5],
            "2 more components have more than 1% of the surface "
            "without values");
}

// A pass's warnings skip the components' topology pass when the missing
// share of the surface is under the threshold: at the threshold's edge,
// they are the diagnosis's, named component or none.
TEST(MissingValueWarningsTest, APassAtTheThresholdGetsTheDiagnosisWarnings) {
  Mesh mesh;
  Append(mesh, MakeIcosphere(1, 3), {0, 0, 0});
  Append(mesh, MakeBox(1, 1, 1, 0.5), {3, 0, 0});
  SdfResult pass;
  pass.values.assign(mesh.positions.size(), 1.0);
  pass.status.assign(mesh.positions.size(), VertexStatus::kOk);
  const Face& face = mesh.faces[7];
  for (int k = 0; k < face.size; ++k) {
    pass.values[face.v[k]] = std::numeric_limits<double>::quiet_NaN();
    pass.status[face.v[k]] = VertexStatus::kNoHit;
  }
  pass.missing = CountMissing(mesh, pass.values);
  const double share = pass.missing.area_fraction;
  ASSERT_GT(share, 0);
  for (const double warn :
       {share * (1 - 1e-12), share * (1 + 1e-12), share / 2, share * 2, 0.0}) {
    const auto diagnosed =
        MissingValueWarnings(mesh, pass.values, pass.status, warn);
    EXPECT_EQ(MissingValueWarnings(mesh, pass, warn), diagnosed) << warn;
    EXPECT_EQ(diagnosed.empty(), warn > share) << warn;
  }
}

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

// A million duplicate faces (half of them reversed) are read, repaired and
// diagnosed in time linear in the file (this took 15 s of CPU for 80,000
// when diagnostics compared face pairs; the test's 300 s timeout catches a
// quadratic step). The times are printed, not asserted.
// SortedEdgeUses against a plain stable sort of every use by key, on faces
// in a scrambled order with a vertex of 120 incident faces (longer lists are
// sorted differently from short ones) and a quad.
TEST(LinearDiagnosticsTest, EdgeUsesAreSortedWithEachEdgesUsesInFaceOrder) {
  Mesh mesh = MakeIcosphere(1.0, 6);
  // Vertex 0, the smallest, is every fan edge's bucket: 240 uses.
  for (int32_t k = 1; k <= 120; ++k) {
    mesh.faces.push_back(Face::Triangle(0, k, k + 1));
  }
  mesh.faces.push_back(Face::Quad(0, 5, 9, 2));
  std::shuffle(mesh.faces.begin(), mesh.faces.end(), std::mt19937(1));
  std::vector<EdgeUse> want;
  for (int32_t id = 0; id < static_cast<int32_t>(mesh.num_faces()); ++id) {
    const Face& f = mesh.faces[id];
    for (int k = 0; k < f.size; ++k) {
      const int32_t a = f.v[k], b = f.v[(k + 1) % f.size];
      want.push_back({EdgeKey(a, b), id, a < b});
    }
  }
  std::stable_sort(
      want.begin(), want.end(),
      [](const EdgeUse& a, const EdgeUse& b) { return a.key < b.key; });
  const std::vector<EdgeUse> got = SortedEdgeUses(mesh);
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].key, want[i].key) << i;
    ASSERT_EQ(got[i].face, want[i].face) << i;
    ASSERT_EQ(got[i].forward, want[i].forward) << i;
  }
}

TEST(LinearDiagnosticsTest, AMillionDuplicateFacesAreDiagnosed) {
  std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i < 500'000; ++i) obj += "f 1 2 3\nf 1 3 2\n";
  const auto t0 = std::chrono::steady_clock::now();
  auto file = ParseMeshContents(obj, ".obj", "duplicates.obj");
  ASSERT_TRUE(file.ok()) << file.status();
  const auto t1 = std::chrono::steady_clock::now();
  auto repaired = RepairAndDiagnose(std::move(file->mesh), {.reorient = true});
  ASSERT_TRUE(repaired.ok()) << repaired.status();
  const auto t2 = std::chrono::steady_clock::now();
  EXPECT_EQ(repaired->mesh.num_faces(), 1'000'000);
  EXPECT_EQ(repaired->diagnostics.components, 1);
  EXPECT_EQ(repaired->diagnostics.double_sided_faces, 1'000'000);
  EXPECT_FALSE(repaired->diagnostics.closed);
  // Edges of a million faces join no two faces: nothing to make agree.
  EXPECT_EQ(repaired->reorientation.faces_made_consistent, 0);
  std::printf("read %.3f s, repair and diagnose %.3f s (%zu bytes)\n",
              std::chrono::duration<double>(t1 - t0).count(),
              std::chrono::duration<double>(t2 - t1).count(), obj.size());
}

}  // namespace
}  // namespace meshgauge
