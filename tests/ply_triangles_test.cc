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

#include "absl/strings/str_cat.h"
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

// A binary little-endian PLY of a tetrahedron with the given declarations:
// `vertex_properties` (each "TYPE NAME"; x, y, z among them, written as
// `Coordinate`, every other property as zero bytes of its type's size),
// faces of `list` ("COUNT_TYPE ITEM_TYPE NAME").
struct Spec {
  std::vector<std::pair<std::string, int>> vertex_properties;  // name, bytes
  std::string list = "uchar int vertex_indices";
  int count_bytes = 1;
  bool uint_items = false;
  bool double_coordinates = false;
};

std::string TypeName(const std::pair<std::string, int>& p, bool dbl) {
  if (p.first == "x" || p.first == "y" || p.first == "z") {
    return dbl ? "double" : "float";
  }
  return p.second == 1 ? "uchar" : p.second == 2 ? "short" : "int";
}

const double kCorners[4][3] = {
    {0.1, 0.2, 0.3}, {1.0 / 3, 0, 0}, {0, 1e-7, 0}, {0, 0, 12345.678}};
const int kFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

std::string Tetrahedron(const Spec& s) {
  std::string out =
      "ply\nformat binary_little_endian 1.0\ncomment a test\nelement vertex "
      "4\n";
  for (const auto& p : s.vertex_properties) {
    absl::StrAppend(&out, "property ", TypeName(p, s.double_coordinates), " ",
                    p.first, "\n");
  }
  absl::StrAppend(&out, "element face 4\nproperty list ", s.list,
                  "\nend_header\n");
  for (const auto& c : kCorners) {
    for (const auto& p : s.vertex_properties) {
      const int axis = p.first == "x"   ? 0
                       : p.first == "y" ? 1
                       : p.first == "z" ? 2
                                        : -1;
      if (axis < 0) {
        out.append(p.second, '\0');
      } else if (s.double_coordinates) {
        Put<double>(out, c[axis]);
      } else {
        Put<float>(out, static_cast<float>(c[axis]));
      }
    }
  }
  for (const auto& f : kFaces) {
    out.append(s.count_bytes, '\0');
    out[out.size() - s.count_bytes] = 3;
    for (int v : f) {
      if (s.uint_items) {
        Put<uint32_t>(out, static_cast<uint32_t>(v));
      } else {
        Put<int32_t>(out, v);
      }
    }
  }
  return out;
}

Spec Plain() { return {.vertex_properties = {{"x", 4}, {"y", 4}, {"z", 4}}}; }

struct BothReaders {
  std::optional<absl::StatusOr<io::MeshFile>> fast;
  absl::StatusOr<io::MeshFile> general;
};

BothReaders ReadBoth(const std::string& data,
                     const io::ReadLimits& limits = {}) {
  auto header = io::ply::ParseHeader(data, "t.ply");
  EXPECT_TRUE(header.ok()) << header.status();
  EXPECT_TRUE(io::ply::CheckCounts(*header, data.size(), "t.ply").ok());
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
  std::vector<Spec> specs;
  specs.push_back(Plain());
  Spec doubles = Plain();
  doubles.double_coordinates = true;
  specs.push_back(doubles);
  // Normals, a colour and a confidence around and between x, y and z.
  specs.push_back({.vertex_properties = {{"confidence", 4},
                                         {"z", 4},
                                         {"red", 1},
                                         {"x", 4},
                                         {"nx", 2},
                                         {"y", 4}}});
  for (const auto& [list, count_bytes, uint_items] :
       {std::tuple{"uint8 uint32 vertex_indices", 1, true},
        {"int int vertex_index", 4, false},
        {"ushort uint vertex_indices", 2, true},
        {"char int vertex_indices", 1, false}}) {
    Spec s = Plain();
    s.list = list;
    s.count_bytes = count_bytes;
    s.uint_items = uint_items;
    specs.push_back(s);
  }
  for (const Spec& s : specs) {
    const BothReaders r = ReadBoth(Tetrahedron(s));
    ASSERT_TRUE(r.fast.has_value()) << s.list;
    ASSERT_TRUE(r.fast->ok()) << r.fast->status();
    ASSERT_TRUE(r.general.ok()) << r.general.status();
    ExpectSameFile(**r.fast, *r.general);
    EXPECT_EQ((*r.fast)->mesh.positions[1].x,
              s.double_coordinates
                  ? 1.0 / 3
                  : static_cast<double>(static_cast<float>(1.0 / 3)));
  }
  // Through ParsePly too.
  auto parsed = io::ParsePly(Tetrahedron(doubles), "t.ply");
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  EXPECT_EQ(parsed->mesh.positions[1].x, 1.0 / 3);
}

// Replaces the first occurrence of `from` in `s`.
std::string Replace(std::string s, const std::string& from,
                    const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return s.replace(at, from.size(), to);
}

TEST(PlyTrianglesTest, OtherLayoutsAreLeftToTheGeneralReader) {
  const std::string plain = Tetrahedron(Plain());
  const std::string body = plain.substr(plain.find("end_header\n") + 11);
  const std::vector<std::pair<const char*, std::string>> others = {
      {"trailing bytes", plain + std::string(3, '\0')},
      {"an element after the faces",
       Replace(plain, "end_header",
               "element edge 0\nproperty int vertex1\nend_header")},
      {"a face property beside the list",
       Replace(plain, "vertex_indices\n",
               "vertex_indices\nproperty uchar flags\n")},
      {"short items", Replace(plain, "uchar int vertex", "uchar short vertex")},
      {"integer coordinates", Replace(plain, "float x", "int x")},
      {"a list among the vertex's properties",
       Replace(plain, "property float x",
               "property list uchar int stuff\nproperty float x")},
      {"big endian",
       Replace(plain, "binary_little_endian", "binary_big_endian")},
      {"tristrips", Replace(plain, "element face", "element tristrips")},
  };
  for (const auto& [what, data] : others) {
    auto header = io::ply::ParseHeader(data, "t.ply");
    ASSERT_TRUE(header.ok()) << what << ": " << header.status();
    EXPECT_FALSE(io::ply::ReadTriangleBody(data, *header, "t.ply", {})) << what;
  }
}

// Each value ReadBody rejects makes ReadTriangleBody step aside, so that
// ParsePly's error is ReadBody's, with its place.
TEST(PlyTrianglesTest, AValueTheGeneralReaderRejectsGivesItsErrorAndPlace) {
  const std::string plain = Tetrahedron(Plain());
  const size_t body = plain.find("end_header\n") + 11;
  auto at = [&](size_t offset, auto value) {
    std::string data = plain;
    std::memcpy(data.data() + body + offset, &value, sizeof(value));
    return data;
  };
  const size_t faces = 4 * 12;
  const std::vector<std::tuple<const char*, std::string, const char*>> bad = {
      {"NaN", at(4, std::numeric_limits<float>::quiet_NaN()),
       "vertex 0 of 4: property y is missing or not a finite number"},
      {"infinity", at(3 * 12 + 8, std::numeric_limits<float>::infinity()),
       "vertex 3 of 4: property z is missing or not a finite number"},
      {"index out of range", at(faces + 13 + 1 + 4, int32_t{4}),
       "face 1 refers to vertex 4 but 4 vertices are defined"},
      {"negative index", at(faces + 1, int32_t{-1}),
       "face 0 refers to vertex -1"},
      {"a quad's count", at(faces + 2 * 13, uint8_t{2}),
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
}

TEST(PlyTrianglesTest, TheReadLimitsStopItWithTheirCause) {
  const std::string plain = Tetrahedron(Plain());
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
  // What it will hold is reported before it holds it: the positions, then
  // the positions and the faces.
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
