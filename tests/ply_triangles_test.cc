// ReadTriangleBody (lib/io/ply_body.h), the binary triangle-mesh PLY
// reader without a call per value: it must take the files it was made for
// (the shared binary meshes, the layouts exporters write) and give exactly
// ReadBody's MeshFile; on anything else, and on any value ReadBody rejects,
// it must step aside so that ReadBody's error, with its place, is what the
// caller sees; and it must keep the server's read limits.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <tuple>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "lib/io/mesh_io.h"
#include "lib/io/ply_body.h"
#include "lib/io/readers.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using ::testing::HasSubstr;

template <typename T>
void Put(std::string& out, T v) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  out.append(bytes, sizeof(T));
}

// Appends `v` as a little-endian value of the PLY type named `type`.
void PutAs(std::string& out, const std::string& type, double v) {
  if (type == "float" || type == "float32") {
    Put<float>(out, static_cast<float>(v));
  } else if (type == "double" || type == "float64") {
    Put<double>(out, v);
  } else if (type == "uchar" || type == "uint8") {
    Put<uint8_t>(out, static_cast<uint8_t>(v));
  } else if (type == "char" || type == "int8") {
    Put<int8_t>(out, static_cast<int8_t>(v));
  } else if (type == "short" || type == "int16") {
    Put<int16_t>(out, static_cast<int16_t>(v));
  } else if (type == "ushort" || type == "uint16") {
    Put<uint16_t>(out, static_cast<uint16_t>(v));
  } else if (type == "int" || type == "int32") {
    Put<int32_t>(out, static_cast<int32_t>(v));
  } else {
    Put<uint32_t>(out, static_cast<uint32_t>(v));  // uint, uint32
  }
}

// A binary little-endian PLY of a tetrahedron. `vertex`: the vertex's
// properties in order, each "TYPE NAME" or "list COUNT ITEM NAME" (written
// empty); x, y and z hold the corners, an x that a later x repeats holds 7,
// every other scalar holds `fill`. `list`: the face's "COUNT ITEM NAME".
struct Spec {
  std::vector<std::string> vertex = {"float x", "float y", "float z"};
  std::string list = "uchar int vertex_indices";
  double fill = 0.5;
};

const double kCorners[4][3] = {
    {0.1, 0.2, 0.3}, {1.0 / 3, 0, 0}, {0, 1e-7, 0}, {0, 0, 12345.678}};
const int kFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

std::vector<std::string> Words(const std::string& s) {
  return absl::StrSplit(s, ' ', absl::SkipEmpty());
}

std::string Tetrahedron(const Spec& s) {
  std::string out =
      "ply\nformat binary_little_endian 1.0\ncomment a test\nelement vertex "
      "4\n";
  for (const std::string& p : s.vertex) {
    absl::StrAppend(&out, "property ", p, "\n");
  }
  absl::StrAppend(&out, "element face 4\nproperty list ", s.list,
                  "\nend_header\n");
  for (const auto& c : kCorners) {
    for (size_t i = 0; i < s.vertex.size(); ++i) {
      const std::vector<std::string> w = Words(s.vertex[i]);
      if (w[0] == "list") {
        PutAs(out, w[1], 0);
        continue;
      }
      const std::string& name = w[1];
      const int axis = name == "x" ? 0 : name == "y" ? 1 : name == "z" ? 2 : -1;
      bool repeated = false;
      for (size_t j = i + 1; j < s.vertex.size(); ++j) {
        repeated |= axis >= 0 && Words(s.vertex[j]).back() == name;
      }
      PutAs(out, w[0], axis < 0 ? s.fill : repeated ? 7 : c[axis]);
    }
  }
  const std::vector<std::string> list = Words(s.list);
  for (const auto& f : kFaces) {
    PutAs(out, list[0], 3);
    for (int v : f) PutAs(out, list[1], v);
  }
  return out;
}

// Replaces the first occurrence of `from` in `s`.
std::string Replace(std::string s, const std::string& from,
                    const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? s : s.replace(at, from.size(), to);
}

struct BothReaders {
  std::optional<absl::StatusOr<io::MeshFile>> fast;
  absl::StatusOr<io::MeshFile> general;
};

BothReaders ReadBoth(const std::string& data,
                     const io::ReadLimits& limits = {}) {
  auto header = io::ply::ParseHeader(data, "t.ply");
  if (!header.ok()) return {std::nullopt, header.status()};
  if (absl::Status s = io::ply::CheckCounts(*header, data.size(), "t.ply");
      !s.ok()) {
    return {std::nullopt, s};
  }
  return {io::ply::ReadTriangleBody(data, *header, "t.ply", limits),
          io::ply::ReadBody(data, *header, "t.ply", limits)};
}

// The same MeshFile, positions compared bit for bit.
void ExpectSameFile(const io::MeshFile& a, const io::MeshFile& b) {
  ASSERT_EQ(a.mesh.positions.size(), b.mesh.positions.size());
  EXPECT_EQ(std::memcmp(a.mesh.positions.data(), b.mesh.positions.data(),
                        a.mesh.positions.size() * sizeof(Vec3)),
            0);
  ASSERT_EQ(a.mesh.faces.size(), b.mesh.faces.size());
  for (size_t f = 0; f < a.mesh.faces.size(); ++f) {
    ASSERT_EQ(a.mesh.faces[f].v, b.mesh.faces[f].v) << f;
    ASSERT_EQ(a.mesh.faces[f].size, b.mesh.faces[f].size) << f;
  }
  EXPECT_EQ(a.mesh.face_regions, b.mesh.face_regions);
  EXPECT_EQ(a.mesh.dimension, b.mesh.dimension);
  EXPECT_EQ(a.format, b.format);
  EXPECT_EQ(a.file_faces, b.file_faces);
  EXPECT_EQ(a.polygons_triangulated, b.polygons_triangulated);
}

std::string FileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

TEST(PlyTrianglesTest,
     TheSharedBinaryMeshesAreReadByItAndMatchTheGeneralReader) {
  for (const char* name : {"horse.ply", "igea-triangles.ply"}) {
    const BothReaders r = ReadBoth(FileBytes(testing::SharedMesh(name)));
    ASSERT_TRUE(r.fast.has_value())
        << name << ": the fast reader stepped aside";
    ASSERT_TRUE(r.fast->ok()) << r.fast->status();
    ASSERT_TRUE(r.general.ok()) << r.general.status();
    ExpectSameFile(**r.fast, *r.general);
  }
}

TEST(PlyTrianglesTest, ExportersLayoutsAreReadByItAndMatchTheGeneralReader) {
  const std::vector<Spec> specs = {
      {},
      {.vertex = {"double x", "double y", "double z"}},
      // Normals, a colour, flags, a confidence and a quality around and
      // between x, y and z.
      {.vertex = {"float confidence", "float z", "uchar red", "float x",
                  "float nx", "short flags", "double quality", "float y"}},
      // x twice: the last one counts.
      {.vertex = {"float x", "float y", "float z", "float x"}},
      {.list = "uint8 uint32 vertex_indices"},
      {.list = "int int vertex_index"},
      {.list = "ushort uint vertex_indices"},
      {.list = "char int vertex_indices"},
  };
  for (const Spec& s : specs) {
    SCOPED_TRACE(absl::StrJoin(s.vertex, ", ") + "; " + s.list);
    const BothReaders r = ReadBoth(Tetrahedron(s));
    ASSERT_TRUE(r.fast.has_value());
    ASSERT_TRUE(r.fast->ok()) << r.fast->status();
    ASSERT_TRUE(r.general.ok()) << r.general.status();
    ExpectSameFile(**r.fast, *r.general);
    const bool dbl = s.vertex[0] == "double x";
    EXPECT_EQ((*r.fast)->mesh.positions[1].x,
              dbl ? 1.0 / 3 : static_cast<double>(static_cast<float>(1.0 / 3)));
  }
  // Through ParsePly too.
  auto parsed = io::ParsePly(Tetrahedron(specs[1]), "t.ply");
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  EXPECT_EQ(parsed->mesh.positions[1].x, 1.0 / 3);
}

// Well-formed files (each body matches its header) that the fast reader
// leaves to the general one, which reads those that hold a mesh.
TEST(PlyTrianglesTest, OtherLayoutsAreLeftToTheGeneralReader) {
  const std::string plain = Tetrahedron({});
  const std::string no_faces = Replace(plain.substr(0, plain.size() - 4 * 13),
                                       "element face 4", "element face 0");
  struct Other {
    const char* what;
    std::string data;
    bool mesh;  // whether the general reader reads a mesh from it.
  };
  const std::vector<Other> others = {
      {"trailing bytes", plain + std::string(3, '\0'), false},
      {"an element after the faces",
       Replace(plain, "end_header",
               "element edge 0\nproperty int vertex1\nend_header"),
       true},
      {"big endian",
       Replace(plain, "binary_little_endian", "binary_big_endian"), false},
      {"no faces", no_faces, false},
      {"short items", Tetrahedron({.list = "uchar short vertex_indices"}),
       true},
      {"integer coordinates",
       Tetrahedron({.vertex = {"int x", "int y", "int z"}}), true},
      {"coordinates of two types",
       Tetrahedron({.vertex = {"float x", "double y", "float z"}}), true},
      {"a list among the vertex's properties",
       Tetrahedron({.vertex = {"list uchar int stuff", "float x", "float y",
                               "float z"}}),
       true},
      {"tristrips", Replace(plain, "element face", "element tristrips"), true},
  };
  for (const Other& o : others) {
    auto header = io::ply::ParseHeader(o.data, "t.ply");
    ASSERT_TRUE(header.ok()) << o.what << ": " << header.status();
    EXPECT_FALSE(io::ply::ReadTriangleBody(o.data, *header, "t.ply", {}))
        << o.what;
    EXPECT_EQ(io::ParsePly(o.data, "t.ply").ok(), o.mesh) << o.what;
  }
}

// Each value ReadBody rejects makes ReadTriangleBody step aside, so that
// ParsePly's error is ReadBody's, with its place.
TEST(PlyTrianglesTest, AValueTheGeneralReaderRejectsGivesItsErrorAndPlace) {
  const std::string plain = Tetrahedron({});
  const size_t body = plain.find("end_header\n") + 11;
  auto at = [](std::string data, size_t offset, auto value) {
    std::memcpy(data.data() + offset, &value, sizeof(value));
    return data;
  };
  const size_t faces = body + 4 * 12;
  // A vertex's normal (VCG writes NaN ones) is checked like a coordinate.
  const std::string normals =
      Tetrahedron({.vertex = {"float x", "float y", "float z", "float nx"}});
  const size_t normals_body = normals.find("end_header\n") + 11;
  const std::vector<std::tuple<const char*, std::string, const char*>> bad = {
      {"NaN", at(plain, body + 4, std::numeric_limits<float>::quiet_NaN()),
       "vertex 0 of 4: property y is missing or not a finite number"},
      {"infinity",
       at(plain, body + 3 * 12 + 8, std::numeric_limits<float>::infinity()),
       "vertex 3 of 4: property z is missing or not a finite number"},
      {"a NaN normal",
       at(normals, normals_body + 16 + 12,
          std::numeric_limits<float>::quiet_NaN()),
       "vertex 1 of 4: property nx is missing or not a finite number"},
      {"index out of range", at(plain, faces + 13 + 1 + 4, int32_t{4}),
       "face 1 refers to vertex 4 but 4 vertices are defined"},
      {"negative index", at(plain, faces + 1, int32_t{-1}),
       "face 0 refers to vertex -1"},
      {"a count of 2", at(plain, faces + 2 * 13, uint8_t{2}),
       "face 2 has 2 corners"},
  };
  for (const auto& [what, data, message] : bad) {
    auto header = io::ply::ParseHeader(data, "t.ply");
    ASSERT_TRUE(header.ok());
    EXPECT_FALSE(io::ply::ReadTriangleBody(data, *header, "t.ply", {})) << what;
    auto parsed = io::ParsePly(data, "t.ply");
    EXPECT_EQ(parsed.status().code(), absl::StatusCode::kInvalidArgument)
        << what;
    EXPECT_THAT(std::string(parsed.status().message()), HasSubstr(message))
        << what;
    EXPECT_THAT(std::string(parsed.status().message()), HasSubstr("byte "))
        << what;
  }
  // An unsigned index of 2^32 - 1.
  const std::string uints = Tetrahedron({.list = "uchar uint vertex_indices"});
  const std::string huge =
      at(uints, uints.find("end_header\n") + 11 + 4 * 12 + 1, ~uint32_t{0});
  auto header = io::ply::ParseHeader(huge, "t.ply");
  ASSERT_TRUE(header.ok());
  EXPECT_FALSE(io::ply::ReadTriangleBody(huge, *header, "t.ply", {}));
  EXPECT_THAT(std::string(io::ParsePly(huge, "t.ply").status().message()),
              HasSubstr("refers to vertex 4294967295"));
}

TEST(PlyTrianglesTest, TheReadLimitsStopItWithTheirCause) {
  const std::string plain = Tetrahedron({});
  auto fast = [&](const io::ReadLimits& limits) {
    auto header = io::ply::ParseHeader(plain, "t.ply");
    auto read = io::ply::ReadTriangleBody(plain, *header, "t.ply", limits);
    EXPECT_TRUE(read.has_value());
    return read.value_or(absl::InternalError("stepped aside")).status();
  };
  EXPECT_THAT(std::string(fast({.max_vertices = 3}).message()),
              HasSubstr("3 vertices (max_vertices)"));
  EXPECT_THAT(std::string(fast({.max_faces = 3}).message()),
              HasSubstr("3 faces (max_faces"));
  EXPECT_EQ(fast({.cancelled = [] { return true; }}).code(),
            absl::StatusCode::kCancelled);
  // What it will store is reported before it stores it: the positions,
  // then the positions and the faces.
  std::vector<int64_t> reported;
  EXPECT_TRUE(fast({.reserve = [&](int64_t bytes) {
                reported.push_back(bytes);
                return absl::OkStatus();
              }}).ok());
  EXPECT_EQ(reported,
            (std::vector<int64_t>{4 * int64_t{sizeof(Vec3)},
                                  4 * int64_t{sizeof(Vec3) + sizeof(Face)}}));
  EXPECT_EQ(fast({.reserve =
                      [](int64_t) {
                        return absl::ResourceExhaustedError("no room");
                      }})
                .message(),
            "no room");
}

}  // namespace
}  // namespace meshgauge
