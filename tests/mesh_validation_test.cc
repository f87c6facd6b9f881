// SPEC §1: every invalid input is rejected with a precise message; tests are
// named after the input they reject.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <functional>
#include <limits>
#include <vector>

#include "lib/core/mesh.h"
#include "lib/core/shapes.h"
#include "lib/embree/sdf.h"

namespace meshgauge {
namespace {

using ::testing::HasSubstr;

Mesh Tetrahedron() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.faces = {Face::Triangle(0, 2, 1), Face::Triangle(0, 1, 3),
             Face::Triangle(0, 3, 2), Face::Triangle(1, 2, 3)};
  return m;
}

std::string Error(const Mesh& m) {
  const absl::Status s = ValidateMesh(m);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  return std::string(s.message());
}

TEST(MeshValidationTest, AcceptsTetrahedron) {
  EXPECT_TRUE(ValidateMesh(Tetrahedron()).ok());
}

TEST(MeshValidationTest, RejectsNonFiniteCoordinates) {
  Mesh m = Tetrahedron();
  m.positions[2].y = std::numeric_limits<double>::quiet_NaN();
  m.positions[3].z = std::numeric_limits<double>::infinity();
  EXPECT_THAT(
      Error(m),
      HasSubstr(
          "2 vertices have non-finite coordinates (first vertex ids: 2, 3)"));
}

TEST(MeshValidationTest, RejectsIndexOutOfRange) {
  Mesh m = Tetrahedron();
  m.faces[1].v[2] = 4;
  m.faces[3].v[0] = -1;
  EXPECT_THAT(Error(m), HasSubstr("2 faces have vertex indices out of range "
                                  "[0, 4) (first face ids: 1, 3)"));
}

TEST(MeshValidationTest, RejectsRepeatedIndexInFace) {
  Mesh m = Tetrahedron();
  m.faces[2] = Face::Triangle(0, 3, 0);
  EXPECT_THAT(Error(m),
              HasSubstr("1 faces repeat a vertex index (first face ids: 2)"));
}

TEST(MeshValidationTest, RejectsZeroAreaFaces) {
  Mesh m = Tetrahedron();
  m.positions.push_back({2, 0, 0});  // collinear with 0 and 1.
  m.faces.push_back(Face::Triangle(0, 1, 4));
  EXPECT_THAT(Error(m),
              HasSubstr("1 faces have zero area (first face ids: 4)"));
}

TEST(MeshValidationTest, RejectsZeroLengthSegment) {
  Mesh m = MakeCircle(1, 8);
  m.positions[3] = m.positions[4];
  EXPECT_THAT(Error(m),
              HasSubstr("segments have zero length (first face ids: 3)"));
}

TEST(MeshValidationTest, RejectsConflictingRegionDirectionsAtVertex) {
  Mesh m = Tetrahedron();
  m.face_regions = {0, 1, 0, 0};
  m.region_directions[1] = ConeDirection::kOutward;
  EXPECT_THAT(Error(m),
              HasSubstr("3 vertices touch faces of regions with different cone "
                        "directions (first vertex ids: 0, 1, 3)"));
}

TEST(MeshValidationTest, AcceptsDifferentRegionsWithSameDirection) {
  Mesh m = Tetrahedron();
  m.face_regions = {0, 1, 2, 0};
  m.region_directions[2] = ConeDirection::kInward;
  EXPECT_TRUE(ValidateMesh(m).ok());
}

TEST(MeshValidationTest, RejectsEmptyMesh) {
  EXPECT_THAT(Error(Mesh{}), HasSubstr("empty mesh"));
  Mesh no_faces = Tetrahedron();
  no_faces.faces.clear();
  EXPECT_THAT(Error(no_faces), HasSubstr("empty mesh: 4 vertices and 0 faces"));
}

TEST(MeshValidationTest, RejectsSegmentsInA3DMesh) {
  Mesh m = Tetrahedron();
  m.faces.push_back(Face::Segment(0, 1));
  EXPECT_THAT(Error(m), HasSubstr("mixed dimensions"));
}

TEST(MeshValidationTest, RejectsNonZeroZInA2DMesh) {
  Mesh m = MakeCircle(1, 8);
  m.positions[5].z = 0.1;
  EXPECT_THAT(Error(m), HasSubstr("1 vertices of a 2D mesh have z != 0 (mixed "
                                  "dimensions) (first vertex ids: 5)"));
}

TEST(MeshValidationTest, RejectsTrianglesInA2DMesh) {
  Mesh m = MakeCircle(1, 8);
  m.faces.push_back(Face::Triangle(0, 1, 2));
  EXPECT_THAT(Error(m), HasSubstr("faces are not segments in a 2D mesh"));
}

TEST(MeshValidationTest, RejectsBadDimension) {
  Mesh m = Tetrahedron();
  m.dimension = 4;
  EXPECT_THAT(Error(m), HasSubstr("dimension must be 2 or 3, got 4"));
}

TEST(MeshValidationTest, RejectsRegionListOfWrongLength) {
  Mesh m = Tetrahedron();
  m.face_regions = {0, 0};
  EXPECT_THAT(Error(m),
              HasSubstr("face_regions has 2 entries but the mesh has 4 faces"));
}

TEST(MeshValidationTest, ReportsSeveralDefectsTogether) {
  Mesh m = Tetrahedron();
  m.positions[0].x = std::numeric_limits<double>::quiet_NaN();
  m.faces[3].v[1] = 9;
  const std::string e = Error(m);
  EXPECT_THAT(e, HasSubstr("non-finite"));
  EXPECT_THAT(e, HasSubstr("out of range"));
}

// The checks run in blocks of faces and vertices side by side: a message
// still counts every defect and lists the first ids in id order, for any
// thread count.
TEST(MeshValidationTest,
     RejectsDefectsInSeveralBlocksListingTheFirstInIdOrder) {
  constexpr int kFaces = 200000;
  Mesh m;
  for (int f = 0; f < kFaces; ++f) {
    m.positions.push_back({1.0 * f, 0, 0});
    m.positions.push_back({f + 1.0, 0, 0});
    m.positions.push_back({1.0 * f, 1, 0});
    m.faces.push_back(Face::Triangle(3 * f, 3 * f + 1, 3 * f + 2));
  }
  Mesh flat = m;
  for (int f : {70000, 3, 140000, 65535, 65536, 200, kFaces - 1}) {
    flat.positions[3 * f + 2] = {f + 0.5, 0, 0};
  }
  const std::string expected =
      "7 faces have zero area (first face ids: 3, 200, 65535, 65536, 70000)";
  for (int threads : {1, 2}) {
    tbb::task_arena arena(threads);
    arena.execute([&] {
      EXPECT_THAT(Error(flat), HasSubstr(expected)) << threads << " threads";
    });
  }
  Mesh nan = m;
  for (int v : {3 * kFaces - 1, 5, 400000}) {
    nan.positions[v].z = std::numeric_limits<double>::quiet_NaN();
  }
  EXPECT_THAT(Error(nan), HasSubstr("3 vertices have non-finite coordinates "
                                    "(first vertex ids: 5, 400000, 599999)"));
}

TEST(MeshValidationTest, UnreferencedVerticesAreValidAndGetNoFaces) {
  Mesh m = Tetrahedron();
  m.positions.push_back({5, 5, 5});
  ASSERT_TRUE(ValidateMesh(m).ok());
  auto r = ComputeSdf(m, {});
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->status[4], VertexStatus::kNoFaces);
  EXPECT_TRUE(std::isnan(r->values[4]));
  EXPECT_EQ(r->status[0], VertexStatus::kOk);
}

TEST(MeshValidationTest, ComputeSdfRejectsInvalidMesh) {
  Mesh m = Tetrahedron();
  m.faces[0].v[0] = 7;
  EXPECT_EQ(ComputeSdf(m, {}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(ParamsValidationTest, RejectsOutOfRangeParameters) {
  const Mesh m = Tetrahedron();
  auto code = [&](SdfParams p) { return ComputeSdf(m, p).status(); };
  SdfParams p;
  p.cone_angle_degrees = 180;
  EXPECT_THAT(code(p).message(), HasSubstr("cone angle must be in (0, 180)"));
  p = {};
  p.cone_angle_degrees = 0;
  EXPECT_EQ(code(p).code(), absl::StatusCode::kInvalidArgument);
  p = {};
  p.rays = 4097;
  EXPECT_THAT(code(p).message(), HasSubstr("ray count must be in [1, 4096]"));
  p = {};
  p.kappa = -1;
  EXPECT_THAT(code(p).message(), HasSubstr("kappa"));
  p = {};
  p.max_distance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(code(p).message(), HasSubstr("max distance"));
  EXPECT_THAT(ComputeSdf(m, {}, {.threads = -2}).status().message(),
              HasSubstr("threads"));
}

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

// The server reuses a cached pass when SdfParams compare equal (a defaulted
// operator==). The binding has one name per field, so a new field does not
// compile here until it is listed below, where changing it must make the
// parameters differ (a parameter the cache ignored would serve stale
// values).
TEST(ParamsEqualityTest, EveryFieldSelectsTheCachedPass) {
  [[maybe_unused]] const auto& [method, cone_angle, rays, min_weight, kappa,
                                epsilon, max_distance, weighting,
                                opposite, contact_angle, samples,
                                range] = SdfParams{};
  const std::vector<std::function<void(SdfParams&)>> changes = {
      [](SdfParams& p) { p.method = SdfMethod::kNormalRay; },
      [](SdfParams& p) { p.cone_angle_degrees = 31; },
      [](SdfParams& p) { p.rays = 7; },
      [](SdfParams& p) { p.min_weight_angle = 0.01; },
      [](SdfParams& p) { p.kappa = 2; },
      [](SdfParams& p) { p.self_hit_epsilon = 1e-5; },
      [](SdfParams& p) { p.max_distance = 3; },
      [](SdfParams& p) { p.normal_weighting = NormalWeighting::kAngle; },
      [](SdfParams& p) { p.opposite_points = true; },
      [](SdfParams& p) { p.contact_angle_degrees = 45; },
      [](SdfParams& p) { p.range = {0, 1}; },
      [](SdfParams& p) { p.samples = SampleSet::kFaces; },
  };
  for (size_t i = 0; i < changes.size(); ++i) {
    SdfParams p;
    EXPECT_TRUE(p == SdfParams{});
    changes[i](p);
    EXPECT_FALSE(p == SdfParams{}) << "field " << i;
  }
}

}  // namespace
}  // namespace meshgauge
