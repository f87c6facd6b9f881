// Mesh files: every test mesh loads with data/meshes/README.md's exact
// counts, no face is lost, and 2D OBJ polylines are read.
#include "lib/io/mesh_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>

#include "lib/embree/sdf.h"
#include "lib/io/mesh_builder.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using ::testing::HasSubstr;
using testing::SharedMesh;

struct Expected {
  const char* file;
  int64_t vertices, faces;
  bool closed;
};

// The test's name and CTest's show the file (a struct would print as its
// bytes, pointer included: names that changed from build to build).
void PrintTo(const Expected& e, std::ostream* os) { *os << e.file; }

class SharedMeshTest : public ::testing::TestWithParam<Expected> {};

TEST_P(SharedMeshTest, LoadsWithReadmeCounts) {
  const Expected e = GetParam();
  auto mesh = ReadMesh(SharedMesh(e.file));
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->num_vertices(), e.vertices);
  EXPECT_EQ(mesh->num_faces(), e.faces);
  EXPECT_EQ(mesh->dimension, 3);
  EXPECT_TRUE(ValidateMesh(*mesh).ok());
  EXPECT_EQ(IsClosed(*mesh), e.closed);
}

INSTANTIATE_TEST_SUITE_P(
    Readme, SharedMeshTest,
    ::testing::Values(Expected{"decimated-knight.off", 502, 1000, true},
                      Expected{"1002_tray_bottom.STL", 2216, 4520, true},
                      Expected{"spot_triangulated.obj", 2930, 5856, true},
                      Expected{"teapot.obj", 3644, 6320, false},
                      Expected{"fandisk.obj", 6475, 12946, true},
                      Expected{"rocker-arm.obj", 10044, 20088, true},
                      Expected{"stanford-bunny.obj", 35947, 69451, false},
                      Expected{"horse.ply", 48485, 96966, true},
                      Expected{"igea-triangles.ply", 134345, 268686, true}),
    [](const ::testing::TestParamInfo<Expected>& info) {
      std::string name = info.param.file;
      for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      }
      return name;
    });

TEST(MeshIoTest, HorseIsInwardOriented) {
  auto mesh = ReadMesh(SharedMesh("horse.ply"));
  ASSERT_TRUE(mesh.ok());
  EXPECT_NEAR(SignedVolume(*mesh), -2.634e-4, 1e-7);
  ReverseFaces(*mesh);
  EXPECT_NEAR(SignedVolume(*mesh), 2.634e-4, 1e-7);
}

TEST(MeshIoTest, BunnyUnreferencedVerticesGetNoFaces) {
  auto mesh = ReadMesh(SharedMesh("stanford-bunny.obj"));
  ASSERT_TRUE(mesh.ok());
  SdfParams params;
  params.rays = 8;
  auto r = ComputeSdf(*mesh, params);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->CountStatus(VertexStatus::kNoFaces), 1113);
}

TEST(MeshIoTest, OpenMeshesGiveNoHitNeverNaNValues) {
  for (const char* name : {"teapot.obj", "stanford-bunny.obj"}) {
    auto mesh = ReadMesh(SharedMesh(name));
    ASSERT_TRUE(mesh.ok());
    SdfParams params;
    params.rays = 16;
    auto r = ComputeSdf(*mesh, params);
    ASSERT_TRUE(r.ok());
    for (int64_t i = 0; i < mesh->num_vertices(); ++i) {
      if (r->status[i] == VertexStatus::kOk) {
        ASSERT_TRUE(std::isfinite(r->values[i])) << name << " " << i;
        ASSERT_GT(r->values[i], 0);
      } else {
        ASSERT_TRUE(std::isnan(r->values[i]));
      }
    }
  }
  // A flat open sheet: every ray misses.
  Mesh sheet;
  sheet.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  sheet.faces = {Face::Quad(0, 1, 2, 3)};
  auto r = ComputeSdf(sheet, {});
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->CountStatus(VertexStatus::kNoHit), 4);
}

class TempDir : public ::testing::Test {
 protected:
  std::string Write(const std::string& name, const std::string& text) {
    const std::string path =
        (std::filesystem::temp_directory_path() /
         (std::string("meshgauge_io_") + std::to_string(::getpid()) + name))
            .string();
    std::ofstream(path) << text;
    files_.push_back(path);
    return path;
  }
  void TearDown() override {
    for (const auto& f : files_) std::filesystem::remove(f);
  }
  std::vector<std::string> files_;
};

using MeshFileTest = TempDir;

TEST_F(MeshFileTest, ReadsObjPolylinesAs2DWithRegions) {
  const std::string path = Write("curve.obj",
                                 "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                 "g 0\nl 1 2 3\ng 7\nl 3 4 1\n");
  auto mesh = ReadMesh(path);
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->dimension, 2);
  EXPECT_EQ(mesh->num_faces(), 4);
  EXPECT_EQ(mesh->face_regions, (std::vector<int32_t>{0, 0, 7, 7}));
  EXPECT_TRUE(ValidateMesh(*mesh).ok());
}

TEST_F(MeshFileTest, RejectsObjMixingFacesAndPolylines) {
  const std::string path =
      Write("mixed.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nl 1 2\n");
  EXPECT_THAT(ReadMesh(path).status().message(),
              HasSubstr("mixes faces (f) and polylines (l)"));
}

TEST_F(MeshFileTest, KeepsFacesWithRepeatedIndicesForValidationToReject) {
  const std::string path = Write(
      "dup.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 1 4\n");
  auto mesh = ReadMesh(path);
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->num_faces(), 2);
  EXPECT_THAT(std::string(ValidateMesh(*mesh).message()),
              HasSubstr("repeat a vertex index"));
}

TEST_F(MeshFileTest, WeldsAsciiStlByExactCoordinates) {
  const std::string path =
      Write("t.stl",
            "solid t\n"
            "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 "
            "0\nvertex 0 1 0\nendloop\nendfacet\n"
            "facet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 "
            "0\nvertex 0 1 0\nendloop\nendfacet\n"
            "endsolid t\n");
  auto mesh = ReadMesh(path);
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->num_vertices(), 4);
  EXPECT_EQ(mesh->num_faces(), 2);
}

TEST_F(MeshFileTest, ReadsAsciiPly) {
  const std::string path =
      Write("a.ply",
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
            "property float y\nproperty float z\nelement face 2\n"
            "property list uchar int vertex_indices\nend_header\n"
            "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n");
  auto mesh = ReadMesh(path);
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->num_vertices(), 4);
  EXPECT_EQ(mesh->num_faces(), 2);
  EXPECT_EQ(mesh->positions[2], Vec3(1, 1, 0));
}

TEST_F(MeshFileTest, ReadsAndWeldsBinaryStl) {
  std::string data(80, ' ');
  const uint32_t count = 2;
  data.append(reinterpret_cast<const char*>(&count), 4);
  const float tris[2][9] = {{0, 0, 0, 1, 0, 0, 0, 1, 0},
                            {1, 0, 0, 1, 1, 0, 0, 1, 0}};
  for (const auto& t : tris) {
    const float normal[3] = {0, 0, 1};
    data.append(reinterpret_cast<const char*>(normal), 12);
    data.append(reinterpret_cast<const char*>(t), 36);
    data.append(2, '\0');
  }
  const std::string path = Write("b.stl", data);
  auto mesh = ReadMesh(path);
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->num_vertices(), 4);
  EXPECT_EQ(mesh->num_faces(), 2);
}

TEST_F(MeshFileTest, MissingFileIsNotFound) {
  EXPECT_EQ(ReadMesh("/nonexistent/x.obj").status().code(),
            absl::StatusCode::kNotFound);
}

TEST_F(MeshFileTest, UnknownExtensionIsRejected) {
  const std::string path = Write("x.xyz", "1 2 3\n");
  EXPECT_THAT(ReadMesh(path).status().message(),
              HasSubstr("unsupported mesh format '.xyz'"));
}

TEST_F(MeshFileTest, QualityPlyRoundTripsGeometry) {
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(mesh.ok());
  std::vector<double> q(mesh->num_vertices(), 0.5);
  const std::string path = Write("q.ply", "");
  ASSERT_TRUE(WriteQualityPly(path, *mesh, q).ok());
  auto back = ReadMesh(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->num_vertices(), mesh->num_vertices());
  EXPECT_EQ(back->num_faces(), mesh->num_faces());
  std::ifstream in(path, std::ios::binary);
  std::string header((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(header.find("property float quality"), std::string::npos);
}

// The server's cancellation check is a call into the transport: a builder
// polls it at a bounded rate, never per element (an upload of igea took
// 10x a local read when it was polled per face).
TEST(MeshBuilderTest, CancellationIsPolledEvery65536FacesNotPerFace) {
  int64_t polls = 0;
  io::ReadLimits limits{.cancelled = [&polls] {
    ++polls;
    return false;
  }};
  io::MeshBuilder builder("arrays", 3, &limits);
  constexpr int64_t kFaces = 300'000;
  ASSERT_TRUE(builder.ReservePositions(3).ok());
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(builder.AddVertex({double(k == 1), double(k == 2), 0}).ok());
  }
  const int64_t corners[] = {0, 1, 2};
  for (int64_t f = 0; f < kFaces; ++f) {
    ASSERT_TRUE(
        builder.AddFace(corners, 0, [] { return std::string("face_indices"); })
            .ok());
  }
  // Every 65,536 faces, and when an array doubles (about log2 F times).
  EXPECT_LE(polls, kFaces / 65536 + 3 * 20);
  EXPECT_GE(polls, kFaces / 65536);
}

}  // namespace
}  // namespace meshgauge
