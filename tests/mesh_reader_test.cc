// lib/io readers on hostile and precise inputs: the committed seed corpus
// (tests/fuzz/corpus) holds every file of the defects reported against the
// OpenMesh-based readers; each must give its precise error (never a crash,
// a hang, an allocation from a header, or a silently shifted index), and
// coordinates must round-trip in double precision. OpenMesh reads every
// test mesh as an independent cross-check.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "lib/core/mesh.h"
#include "lib/io/mesh_io.h"
#include "lib/io/readers.h"
#include "tests/openmesh_reference.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using testing::SharedMesh;

std::string Corpus(const std::string& name) {
  return std::string(MESHGAUGE_SOURCE_DIR) + "/tests/fuzz/corpus/" + name;
}

std::string Message(const absl::StatusOr<io::MeshFile>& r) {
  return r.ok() ? "OK" : std::string(r.status().message());
}

// 0.12345678901234 rounds to this double; float32 would give
// 0.12345679104328156.
constexpr double kPrecise = 0.12345678901234;

TEST(MeshReaderTest, ObjCoordinatesAreDoublePrecision) {
  auto r = ReadMeshFile(Corpus("obj/precision.obj"));
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->mesh.positions[0].x, kPrecise);
  EXPECT_NE(r->mesh.positions[0].x,
            static_cast<double>(static_cast<float>(kPrecise)));
}

TEST(MeshReaderTest, PlyAsciiAndBinaryDoublesAreExact) {
  for (const char* name :
       {"ply/ascii_double.ply", "ply/double_le.ply", "ply/double_be.ply"}) {
    auto r = ReadMeshFile(Corpus(name));
    ASSERT_TRUE(r.ok()) << name << ": " << r.status();
    EXPECT_EQ(r->mesh.positions[0].x, kPrecise) << name;
    EXPECT_EQ(r->mesh.num_faces(), 1);
  }
}

TEST(MeshReaderTest, AsciiStlIsDoublePrecision) {
  auto r = ReadMeshFile(Corpus("stl/ascii.stl"));
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->mesh.positions[0].x, kPrecise);
}

TEST(MeshReaderTest, ObjAndOffWrittenWith17DigitsRoundTripExactly) {
  Mesh m;
  m.positions = {{kPrecise, 1e5 + 1.0 / 3, -2.5e-7}, {1, 0, 0}, {0, 1, 0}};
  m.faces = {Face::Triangle(0, 1, 2)};
  const std::string path =
      (std::filesystem::temp_directory_path() / "meshgauge_rt.obj").string();
  ASSERT_TRUE(WriteObj(path, m).ok());
  auto back = ReadMesh(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->positions, m.positions);
  std::filesystem::remove(path);
  // OFF with the same text numbers.
  auto off = ParseMeshContents(
      "OFF\n3 1 0\n0.12345678901234 100000.33333333333 -2.5e-07\n1 0 0\n0 1 "
      "0\n3 0 1 2\n",
      ".off", "rt.off");
  ASSERT_TRUE(off.ok()) << off.status();
  EXPECT_EQ(off->mesh.positions[0], m.positions[0]);
}

TEST(MeshReaderTest, PlyWithPropertyBeforeElementIsAnErrorNotACrash) {
  EXPECT_THAT(Message(ReadMeshFile(Corpus("ply/property_before_element.ply"))),
              HasSubstr(": line 3: property before any element"));
}

// A hang would be caught by the test's timeout (ctest).
TEST(MeshReaderTest, PlyWithoutEndHeaderIsAnErrorNotAHang) {
  EXPECT_THAT(Message(ReadMeshFile(Corpus("ply/no_end_header.ply"))),
              HasSubstr("no end_header"));
}

TEST(MeshReaderTest, ObjNonFiniteVertexIsAnErrorNamingTheLine) {
  EXPECT_THAT(
      Message(ReadMeshFile(Corpus("obj/nan_vertex.obj"))),
      HasSubstr("nan_vertex.obj: line 2: vertex 1: 'nan' is not a finite"));
  EXPECT_THAT(Message(ReadMeshFile(Corpus("obj/overflow_vertex.obj"))),
              HasSubstr(": line 2: vertex 1: '1e999' is not a finite"));
}

TEST(MeshReaderTest, OffNonFiniteVertexIsAnErrorNamingTheLine) {
  EXPECT_THAT(
      Message(ReadMeshFile(Corpus("off/nan.off"))),
      HasSubstr("nan.off: line 4: vertex 1: 'nan' is not a finite number"));
}

TEST(MeshReaderTest, BinaryOffIsRejectedWithoutAllocating) {
  EXPECT_THAT(Message(ReadMeshFile(Corpus("off/binary.off"))),
              HasSubstr("binary OFF is not supported"));
}

TEST(MeshReaderTest, DeclaredCountsAreCheckedAgainstTheFileSize) {
  EXPECT_THAT(Message(ReadMeshFile(Corpus("off/negative_counts.off"))),
              HasSubstr("negative vertices count -5"));
  EXPECT_THAT(Message(ReadMeshFile(Corpus("off/huge_counts.off"))),
              HasSubstr("declares 2000000000 vertices but only"));
  EXPECT_THAT(Message(ReadMeshFile(Corpus("ply/negative_count.ply"))),
              HasSubstr("element NAME COUNT >= 0"));
  EXPECT_THAT(Message(ReadMeshFile(Corpus("ply/four_billion_faces.ply"))),
              HasSubstr("declares 4000000000 face but only"));
}

TEST(MeshReaderTest, SideFilesAreNeverOpened) {
  for (const char* name :
       {"obj/mtllib_passwd.obj", "obj/mtllib_dev_zero.obj"}) {
    auto r = ReadMeshFile(Corpus(name));
    ASSERT_TRUE(r.ok()) << name << ": " << r.status();
    EXPECT_EQ(r->mesh.num_faces(), 1);
  }
}

TEST(MeshReaderTest, DeviceFilesAreNotRead) {
  EXPECT_EQ(ReadMeshFile("/dev/zero").status().code(),
            absl::StatusCode::kNotFound);
}

TEST(MeshReaderTest, IndexOutOfRangeNamesTheLine) {
  // The index as the file writes it (1-based), not the 0-based one.
  EXPECT_THAT(Message(ReadMeshFile(Corpus("obj/index_out_of_range.obj"))),
              HasSubstr(": line 4: vertex index '4' is out of range: 3 "
                        "vertices are defined before this line"));
  EXPECT_THAT(
      Message(io::ParseObj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n", "t.obj")),
      HasSubstr(": line 4: vertex index '-4' is out of range"));
}

TEST(MeshReaderTest, ObjIndexFormsAndNegativeIndices) {
  auto r = ReadMeshFile(Corpus("obj/slash_indices.obj"));
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->mesh.faces[0].v, (std::array<int32_t, 4>{0, 1, 2, -1}));
}

// A tetrahedron: the same mesh however the three files spell it.
void ExpectTetrahedron(const absl::StatusOr<io::MeshFile>& r) {
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->mesh.num_vertices(), 4);
  EXPECT_EQ(r->mesh.positions[1].x, 1);
  EXPECT_EQ(r->mesh.positions[3].z, 1);
  ASSERT_EQ(r->mesh.num_faces(), 4);
  EXPECT_EQ(r->mesh.faces[0].v, (std::array<int32_t, 4>{0, 2, 1, -1}));
  EXPECT_EQ(r->mesh.faces[1].v, (std::array<int32_t, 4>{0, 1, 3, -1}));
  EXPECT_EQ(r->mesh.faces[3].v, (std::array<int32_t, 4>{2, 0, 3, -1}));
}

// A UTF-8 byte-order mark used to hide the first vertex and shift every
// face index by one.
TEST(MeshReaderTest, ByteOrderMarkIsSkippedNotAVertexLost) {
  ExpectTetrahedron(ReadMeshFile(Corpus("obj/bom_tetrahedron.obj")));
  ExpectTetrahedron(ParseMeshContents(
      "\xEF\xBB\xBFOFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n"
      "3 0 1 3\n3 1 2 3\n3 2 0 3\n",
      ".off", "t.off"));
}

TEST(MeshReaderTest, ObjLineContinuationJoinsTheNextLine) {
  ExpectTetrahedron(ReadMeshFile(Corpus("obj/line_continuation.obj")));
  // A face continued on a line of its own keeps the later line numbers.
  EXPECT_THAT(Message(io::ParseObj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 \\\n2 3\n"
                                   "f 1 2 9\n",
                                   "t.obj")),
              HasSubstr(": line 6: vertex index '9' is out of range"));
}

TEST(MeshReaderTest, OffFaceAndVertexMaySpreadOverLines) {
  ExpectTetrahedron(ReadMeshFile(Corpus("off/face_over_two_lines.off")));
}

TEST(MeshReaderTest, MalformedFaceTokenIsAnErrorNamingTheLine) {
  EXPECT_THAT(Message(ReadMeshFile(Corpus("obj/malformed_texture_index.obj"))),
              HasSubstr(": line 5: '1/x' is not a vertex index"));
  for (const char* bad : {"1/2/3/4", "1/2/x", "x/1", "1/x/", "/1"}) {
    const std::string text =
        absl::StrCat("v 0 0 0\nv 1 0 0\nv 0 1 0\nf ", bad, " 2 3\n");
    EXPECT_FALSE(io::ParseObj(text, "t.obj").ok()) << bad;
  }
  // Empty texture or normal parts, as some exporters write them.
  for (const char* empty : {"1/", "1//", "1/2/", "1//3"}) {
    const std::string text =
        absl::StrCat("v 0 0 0\nv 1 0 0\nv 0 1 0\nf ", empty, " 2 3\n");
    auto r = io::ParseObj(text, "t.obj");
    ASSERT_TRUE(r.ok()) << empty << ": " << r.status();
    EXPECT_EQ(r->mesh.faces[0].v, (std::array<int32_t, 4>{0, 1, 2, -1}));
  }
}

// Outsider report: a tetrahedron with classic Mac OS line ends failed with
// "'v' is not a finite number" (one long line); trimesh's wireframe OBJ of
// 3D polylines was called a 2D mesh of mixed dimensions.
TEST(MeshReaderTest, CrOnlyLineEndsAndThreeDimensionalPolylinesAreNamed) {
  for (const char* ext : {".obj", ".off"}) {
    const std::string text = std::string(ext) == ".obj"
                                 ? "v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r"
                                 : "OFF\r3 1 0\r0 0 0\r1 0 0\r0 1 0\r3 0 1 2\r";
    EXPECT_THAT(Message(ParseMeshContents(text, ext, "t")),
                HasSubstr("t: its lines end in CR alone (classic Mac OS)"))
        << ext;
  }
  // CR LF is fine.
  EXPECT_TRUE(
      io::ParseObj("v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n", "t.obj")
          .ok());
  EXPECT_THAT(Message(io::ParseObj("v 0 0 0\nv 1 0 0.5\nl 1 2\n", "t.obj")),
              HasSubstr("line 2: vertex 1 has z = 0.5, but the file has "
                        "polylines (l) and no faces (f)"));
}

// Outsider report: common-3d-test-models' igea.ply holds triangle strips
// and was read as "no faces"; a PLY cut inside its header was an "unknown
// header keyword".
TEST(MeshReaderTest, PlyTriangleStripsAreReadAndACutHeaderIsNamed) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\n"
      "property float y\nproperty float z\n";
  const std::string vertices = "0 0 0\n1 0 0\n2 0 0\n0 1 0\n1 1 0\n2 1 0\n";
  // Every other triangle reversed; -1 restarts; "4 4" turns (no face).
  auto r = ParseMeshContents(header +
                                 "element tristrips 1\nproperty list int int "
                                 "vertex_indices\nend_header\n" +
                                 vertices + "10 0 3 1 4 -1 1 4 4 2 5\n",
                             ".ply", "t.ply");
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->mesh.num_faces(), 3);
  EXPECT_EQ(r->mesh.faces[0].v, (std::array<int32_t, 4>{0, 3, 1, -1}));
  EXPECT_EQ(r->mesh.faces[1].v, (std::array<int32_t, 4>{1, 3, 4, -1}));
  EXPECT_EQ(r->mesh.faces[2].v, (std::array<int32_t, 4>{4, 2, 5, -1}));
  EXPECT_THAT(Message(ParseMeshContents(
                  header +
                      "element tristrips 1\nproperty list int int "
                      "vertex_indices\nend_header\n" +
                      vertices + "4 0 3 1 9\n",
                  ".ply", "t.ply")),
              HasSubstr("refers to vertex 9 but 6 vertices"));
  EXPECT_THAT(
      Message(ParseMeshContents(
          header + "element edge 0\nend_header\n" + vertices, ".ply", "t.ply")),
      HasSubstr("no faces (elements: vertex 6, edge 0; faces are read from "
                "'face' and 'tristrips')"));
  EXPECT_THAT(Message(ParseMeshContents("ply\nformat ascii 1.0\nelem", ".ply",
                                        "t.ply")),
              HasSubstr("line 3: the header has no end_header line (the file "
                        "is cut short, or 'elem' is not a header keyword)"));
}

// Outsider report: trimesh's nancolor.obj has `v x y z nan nan nan`; the
// colour is not used, and the error called it a coordinate.
TEST(MeshReaderTest, ObjColoursMayBeNanButCoordinatesMayNot) {
  auto r = io::ParseObj(
      "v 0 0 0 nan nan nan\nv 1 0 0 0.5 inf 1\nv 0 1 0 1\nf 1 2 3\n", "t.obj");
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->mesh.positions[1], Vec3(1, 0, 0));
  EXPECT_THAT(Message(io::ParseObj("v 0 nan 0\n", "t.obj")),
              HasSubstr("line 1: vertex 0: 'nan' is not a finite number"));
  EXPECT_THAT(Message(io::ParseObj("v 0 0 0 red\n", "t.obj")),
              HasSubstr("'red' (w or a colour) is not a number"));
}

TEST(MeshReaderTest, PolygonsAreTriangulatedAndCounted) {
  auto hex = ReadMeshFile(Corpus("obj/hexagon.obj"));
  ASSERT_TRUE(hex.ok()) << hex.status();
  EXPECT_EQ(hex->polygons_triangulated, 1);
  EXPECT_EQ(hex->mesh.num_faces(), 4);
  auto p13 = ReadMeshFile(Corpus("off/polygon13.off"));
  ASSERT_TRUE(p13.ok()) << p13.status();
  EXPECT_EQ(p13->mesh.num_faces(), 11);
  // The triangles cover the polygon with its orientation (+z).
  double area = 0;
  for (const Face& f : p13->mesh.faces) {
    const auto& p = p13->mesh.positions;
    area += Cross(p[f.v[1]] - p[f.v[0]], p[f.v[2]] - p[f.v[0]]).z / 2;
  }
  EXPECT_NEAR(area, 13.0 / 2 * std::sin(2 * M_PI / 13), 1e-12);
  // A quad stays a quad.
  auto quad = ReadMeshFile(Corpus("off/quad.off"));
  ASSERT_TRUE(quad.ok());
  EXPECT_EQ(quad->mesh.faces[0].size, 4);
  EXPECT_EQ(quad->polygons_triangulated, 0);
}

TEST(MeshReaderTest, NonSimplePolygonsAreTriangulatedByTheFallback) {
  // A self-crossing pentagon: no ear clipping in its plane, but a
  // triangulation of its corners in order with no zero-area triangle.
  auto bowtie = ReadMeshFile(Corpus("obj/bowtie.obj"));
  ASSERT_TRUE(bowtie.ok()) << bowtie.status();
  EXPECT_EQ(bowtie->polygons_triangulated, 1);
  EXPECT_EQ(bowtie->polygons_fallback, 1);
  EXPECT_EQ(bowtie->first_fallback_polygon, 0);
  ASSERT_EQ(bowtie->mesh.num_faces(), 3);
  EXPECT_TRUE(ValidateMesh(bowtie->mesh).ok());
  // A non-planar hexagon folded like a saddle, after a simple triangle: it
  // is simple in its best-fit plane, so ear clipping splits it, every
  // triangle facing the polygon's way.
  auto saddle = ParseMeshContents(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
      "v 1 0 1\nv 0.5 0.87 -1\nv -0.5 0.87 1\nv -1 0 -1\nv -0.5 -0.87 1\n"
      "v 0.5 -0.87 -1\nf 1 2 3\nf 4 5 6 7 8 9\n",
      ".obj", "saddle.obj");
  ASSERT_TRUE(saddle.ok()) << saddle.status();
  EXPECT_EQ(saddle->mesh.num_faces(), 1 + 4);
  EXPECT_EQ(saddle->polygons_fallback, 0);
  EXPECT_TRUE(ValidateMesh(saddle->mesh).ok());
  // Its Newell normal is +z.
  for (int f = 1; f < 5; ++f) {
    const auto& p = saddle->mesh.positions;
    const Face& t = saddle->mesh.faces[f];
    EXPECT_GT(Cross(p[t.v[1]] - p[t.v[0]], p[t.v[2]] - p[t.v[0]]).z, 0) << f;
  }
  // Collinear corners have no triangulation without a zero-area triangle:
  // an error naming the face.
  EXPECT_THAT(
      Message(ParseMeshContents("v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nv 4 0 0\n"
                                "f 1 2 3 4 5\n",
                                ".obj", "line.obj")),
      HasSubstr("polygon face 0 (5 corners): the polygon has no area "
                "in its best-fit plane, and every triangulation of it "
                "has a triangle of no area"));
}

TEST(MeshReaderTest, PolygonTrianglesKeepTheRegion) {
  auto r = ParseMeshContents(
      "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nv 0 0 1\n"
      "g 3\nf 1 2 3 4 5\ng 0\nf 1 6 2\n",
      ".obj", "regions.obj");
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->mesh.face_regions, (std::vector<int32_t>{3, 3, 3, 0}));
}

TEST(MeshReaderTest, StlDefects) {
  EXPECT_THAT(Message(ReadMeshFile(Corpus("stl/binary_nan.stl"))),
              HasSubstr("byte 108: facet 0: corner 1 is not finite"));
  EXPECT_THAT(Message(ReadMeshFile(Corpus("stl/ascii_truncated.stl"))),
              HasSubstr(": line 5: expected a finite number"));
  EXPECT_THAT(Message(ReadMeshFile(Corpus("stl/wrong_size_binary.stl"))),
              HasSubstr("declares 1000000 facets"));
  auto bin = ReadMeshFile(Corpus("stl/binary.stl"));
  ASSERT_TRUE(bin.ok());
  EXPECT_EQ(bin->mesh.num_vertices(), 4);
  EXPECT_EQ(bin->welded_corners, 2);
  // Outsider report: a binary STL whose header starts with "solid" and
  // whose size does not match its count was "line 1: missing 'endsolid'".
  std::ifstream in(Corpus("stl/binary.stl"), std::ios::binary);
  std::string solid((std::istreambuf_iterator<char>(in)), {});
  solid.replace(0, 5, "solid");
  EXPECT_TRUE(ParseMeshContents(solid, ".stl", "s.stl").ok());
  EXPECT_THAT(Message(ParseMeshContents(solid.substr(0, solid.size() - 10),
                                        ".stl", "s.stl")),
              HasSubstr("s.stl: a binary STL whose size does not match its "
                        "facet count (the header declares 2 facets, 184 "
                        "bytes, but the file has 174; its header starts with "
                        "'solid'"));
}

std::string FileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

// `text` in UTF-16: each character then NUL (LE) or NUL then it (BE),
// after the byte-order mark when `bom`.
std::string Utf16(absl::string_view text, bool little, bool bom) {
  std::string out = bom ? (little ? "\xFF\xFE" : "\xFE\xFF") : "";
  for (char c : text) {
    out += little ? std::string{c, '\0'} : std::string{'\0', c};
  }
  return out;
}

constexpr absl::string_view kTetObj =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
    "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

// Outsider report: a binary STL, a UTF-16 text file or random bytes named
// .obj all said "no faces (f) or polylines (l)". The file's real kind is
// named, with what to do, before the reader's own message.
TEST(MeshReaderTest, AFileWhoseExtensionLiesIsNamedForWhatItIs) {
  const std::string stl = FileBytes(Corpus("stl/binary.stl"));  // 2 facets.
  ASSERT_EQ(stl.size(), 84u + 2 * 50);
  EXPECT_THAT(
      Message(ParseMeshContents(stl, ".obj", "part.obj")),
      HasSubstr("part.obj: this looks like a binary STL (80-byte header, 2 "
                "triangles), not an OBJ file: rename it .stl (read as an OBJ "
                "file: part.obj: "));
  for (bool little : {true, false}) {
    for (bool bom : {true, false}) {
      const std::string m =
          Message(ParseMeshContents(Utf16(kTetObj, little, bom), ".obj", "u.obj"));
      EXPECT_THAT(m, HasSubstr("u.obj: this looks like UTF-16 text (")) << m;
      EXPECT_THAT(m, HasSubstr(little ? "little-endian" : "big-endian"));
      EXPECT_THAT(m, HasSubstr(bom ? "byte-order mark" : "NUL bytes"));
      EXPECT_THAT(m, HasSubstr("save it as UTF-8 or ASCII"));
    }
  }
  // The same text in UTF-8 reads.
  EXPECT_TRUE(ParseMeshContents(kTetObj, ".obj", "u.obj").ok());
  std::string noise(1000, '\0');
  uint32_t x = 12345;
  for (char& c : noise) {
    x = x * 1103515245 + 12345;
    c = static_cast<char>(x >> 16);
  }
  EXPECT_THAT(Message(ParseMeshContents(noise, ".obj", "r.obj")),
              HasSubstr("r.obj: this looks like binary data, not text, not an "
                        "OBJ file"));
  EXPECT_THAT(Message(ParseMeshContents(noise, ".off", "r.off")),
              HasSubstr("r.off: this looks like binary data, not text"));
  const std::string ply = FileBytes(Corpus("ply/double_le.ply"));
  EXPECT_THAT(Message(ParseMeshContents(ply, ".obj", "p.obj")),
              HasSubstr("p.obj: this looks like a PLY file ('ply' header, "
                        "format binary_little_endian), not an OBJ file: "
                        "rename it .ply"));
  const std::string off = "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
                          "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  EXPECT_THAT(Message(ParseMeshContents(off, ".obj", "o.obj")),
              HasSubstr("o.obj: this looks like an OFF file ('OFF' header), "
                        "not an OBJ file: rename it .off"));
  // The other readers given the wrong kind.
  EXPECT_THAT(Message(ParseMeshContents(kTetObj, ".off", "t.off")),
              HasSubstr("t.off: this looks like an OBJ file ('v' and 'f' "
                        "lines), not an OFF file: rename it .obj"));
  EXPECT_THAT(Message(ParseMeshContents(kTetObj, ".ply", "t.ply")),
              HasSubstr("not a PLY file: rename it .obj"));
  EXPECT_THAT(Message(ParseMeshContents(kTetObj, ".stl", "t.stl")),
              HasSubstr("not an STL file: rename it .obj"));
  EXPECT_THAT(Message(ParseMeshContents(ply, ".stl", "p.stl")),
              HasSubstr("a PLY file ('ply' header, format "
                        "binary_little_endian), not an STL file"));
  EXPECT_THAT(Message(ParseMeshContents(stl, ".ply", "s.ply")),
              HasSubstr("a binary STL (80-byte header, 2 triangles), not a "
                        "PLY file: rename it .stl"));
  EXPECT_THAT(Message(ParseMeshContents(off, ".stl", "o.stl")),
              HasSubstr("an OFF file ('OFF' header), not an STL file"));
  const std::string ascii_stl = FileBytes(Corpus("stl/ascii.stl"));
  EXPECT_THAT(Message(ParseMeshContents(ascii_stl, ".off", "a.off")),
              HasSubstr("an ASCII STL ('solid' and 'facet' lines), not an OFF "
                        "file: rename it .stl"));
  EXPECT_THAT(Message(ParseMeshContents(Utf16(ascii_stl, true, true), ".stl",
                                        "w.stl")),
              HasSubstr("w.stl: this looks like UTF-16 text"));
  EXPECT_THAT(Message(ParseMeshContents(std::string("PK\x03\x04", 4) + noise,
                                        ".stl", "m.stl")),
              HasSubstr("a ZIP archive (a 3MF file is one)"));
  // A file of the extension's kind keeps its reader's message alone.
  EXPECT_EQ(Message(ParseMeshContents("v 0 0 0\nv 1 0 0\n", ".obj", "n.obj")),
            "n.obj: no faces (f) or polylines (l)");
  EXPECT_THAT(Message(ParseMeshContents(stl.substr(0, 150), ".stl", "c.stl")),
              Not(HasSubstr("looks like")));
}

TEST(MeshReaderTest, SniffingNamesEachKind) {
  EXPECT_EQ(SniffMeshContents(kTetObj).kind, ".obj");
  EXPECT_EQ(SniffMeshContents(FileBytes(Corpus("stl/binary.stl"))).kind, ".stl");
  EXPECT_EQ(SniffMeshContents(FileBytes(Corpus("stl/ascii.stl"))).kind, ".stl");
  EXPECT_EQ(SniffMeshContents(FileBytes(Corpus("ply/ascii_double.ply"))).kind,
            ".ply");
  EXPECT_EQ(SniffMeshContents("# x\nCOFF\n").kind, ".off");
  EXPECT_EQ(SniffMeshContents(std::string("\xFF\xFE\0\0", 4)).kind, "utf-32");
  EXPECT_EQ(SniffMeshContents(std::string("\x1F\x8B\x08\0", 4)).kind, "other");
  EXPECT_EQ(SniffMeshContents("hello world\n").kind, "");
}

TEST(MeshReaderTest, EveryTruncationOfAValidFileIsAnErrorOrAMesh) {
  // Cut a binary PLY and an ASCII OFF at every byte: never a crash.
  for (const char* name : {"ply/double_le.ply", "off/polygon13.off"}) {
    std::ifstream in(Corpus(name), std::ios::binary);
    const std::string data((std::istreambuf_iterator<char>(in)), {});
    const std::string ext = std::filesystem::path(name).extension().string();
    int errors = 0;
    for (size_t n = 0; n < data.size(); ++n) {
      errors += !ParseMeshContents(data.substr(0, n), ext, name).ok();
    }
    EXPECT_GT(errors, 0);
  }
}

struct Shared {
  const char* file;
};

class SharedMeshCrossCheck : public ::testing::TestWithParam<Shared> {};

TEST_P(SharedMeshCrossCheck, AgreesWithOpenMeshToFloatPrecision) {
  const std::string path = SharedMesh(GetParam().file);
  auto ours = ReadMeshFile(path);
  ASSERT_TRUE(ours.ok()) << ours.status();
  auto reference = testing::ReadWithOpenMesh(path);
  ASSERT_TRUE(reference.ok()) << reference.status();
  ASSERT_EQ(ours->file_faces, reference->num_faces());
  ASSERT_EQ(ours->mesh.num_vertices(), reference->num_vertices());
  int64_t differ = 0;
  for (int64_t i = 0; i < reference->num_vertices(); ++i) {
    for (int c = 0; c < 3; ++c) {
      differ += static_cast<float>(ours->mesh.positions[i][c]) !=
                static_cast<float>(reference->positions[i][c]);
    }
  }
  EXPECT_EQ(differ, 0);
  for (int64_t f = 0; f < reference->num_faces(); ++f) {
    if (reference->faces[f].size > 4) continue;
    ASSERT_EQ(ours->mesh.faces[f].v, reference->faces[f].v) << f;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Shared, SharedMeshCrossCheck,
    ::testing::Values(Shared{"fandisk.obj"}, Shared{"decimated-knight.off"},
                      Shared{"horse.ply"}, Shared{"igea-triangles.ply"},
                      Shared{"rocker-arm.obj"}, Shared{"spot_triangulated.obj"},
                      Shared{"stanford-bunny.obj"}, Shared{"teapot.obj"}),
    [](const auto& info) {
      std::string n = info.param.file;
      for (char& c : n)
        c = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
      return n;
    });

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

// An OBJ of `n` bow-tie pentagons (not simple in their plane: fallback).
std::string BowTies(int n) {
  std::string obj = "v 0 0 0\nv 1 1 0\nv 1 0 0\nv 0 1 0\nv 0.5 2 0\n";
  for (int i = 0; i < n; ++i) obj += "f 1 2 3 4 5\n";
  return obj;
}

TEST(ReadLimitsTest, EachLimitStopsTheReaderWithItsCause) {
  auto read = [](const std::string& text, const io::ReadLimits& limits) {
    return ParseMeshContents(text, ".obj", "t.obj", limits).status();
  };
  io::ReadLimits vertices{.max_vertices = 4};
  EXPECT_EQ(read(BowTies(1), vertices).code(),
            absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(read(BowTies(1), vertices).message()),
              HasSubstr("4 vertices (max_vertices)"));
  // 3 pentagons are 9 triangles.
  EXPECT_TRUE(read(BowTies(3), {.max_faces = 9}).ok());
  EXPECT_THAT(std::string(read(BowTies(3), {.max_faces = 8}).message()),
              HasSubstr("8 faces (max_faces"));
  // Each fallback pentagon costs 125 units.
  EXPECT_TRUE(read(BowTies(4), {.max_fallback_work = 500}).ok());
  EXPECT_THAT(
      std::string(read(BowTies(5), {.max_fallback_work = 500}).message()),
      HasSubstr("triangulate them before sending"));
  EXPECT_EQ(read(BowTies(1), {.cancelled = [] { return true; }}).code(),
            absl::StatusCode::kCancelled);
  // The reader reports what it will hold, growing, before it holds it.
  std::vector<int64_t> reported;
  io::ReadLimits reserve{.reserve = [&](int64_t bytes) {
    reported.push_back(bytes);
    return absl::OkStatus();
  }};
  std::string many = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i < 200'000; ++i) many += "f 1 2 3\n";
  ASSERT_TRUE(read(many, reserve).ok());
  ASSERT_GE(reported.size(), 2u);
  EXPECT_TRUE(std::is_sorted(reported.begin(), reported.end()));
  // 200,000 faces: flat arrays, then the Face array of the mesh.
  EXPECT_GT(reported.back(), 200'000 * int64_t{sizeof(Face) + 16});
  io::ReadLimits refuse{.reserve = [](int64_t) {
    return absl::ResourceExhaustedError("no room");
  }};
  EXPECT_EQ(read(many, refuse).message(), "no room");
}

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

// A count a file declares is checked against the limits before the reader
// reserves room for it.
TEST(ReadLimitsTest, ADeclaredVertexCountIsCheckedBeforeItIsReserved) {
  std::vector<int64_t> reported;
  io::ReadLimits limits{.max_vertices = 3, .reserve = [&](int64_t bytes) {
                          reported.push_back(bytes);
                          return absl::OkStatus();
                        }};
  auto off = ParseMeshContents(
      "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
      "3 0 1 2\n",
      ".off", "t.off", limits);
  EXPECT_EQ(off.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(off.status().message()),
              HasSubstr("3 vertices (max_vertices)"));
  limits.max_vertices = io::ReadLimits::kNone;
  ASSERT_TRUE(ParseMeshContents("OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
                                "3 0 1 2\n",
                                ".off", "t.off", limits)
                  .ok());
  ASSERT_FALSE(reported.empty());
  EXPECT_GE(reported.front(), 4 * int64_t{sizeof(Vec3)});
}

// The face arrays are reserved from the header's count, so the count is
// checked there: a file declaring more faces than allowed is refused before
// its faces are read (here it holds one of the two it declares).
TEST(ReadLimitsTest, ADeclaredFaceCountIsCheckedBeforeItIsReserved) {
  io::ReadLimits limits{.max_faces = 1};
  const std::string off = "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n" +
                          std::string(16, ' ');
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 2\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" +
      std::string(16, ' ');
  for (const auto& [text, ext] : {std::pair{off, ".off"}, {ply, ".ply"}}) {
    auto read = ParseMeshContents(text, ext, "t", limits);
    EXPECT_EQ(read.status().code(), absl::StatusCode::kResourceExhausted)
        << ext << ": " << read.status();
    EXPECT_THAT(std::string(read.status().message()),
                HasSubstr("1 faces (max_faces"));
    // Without the limit the missing face is what is wrong.
    auto unlimited = ParseMeshContents(text, ext, "t", {});
    EXPECT_EQ(unlimited.status().code(), absl::StatusCode::kInvalidArgument)
        << ext;
  }
}

}  // namespace
}  // namespace meshgauge
