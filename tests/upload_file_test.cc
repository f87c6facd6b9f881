// CreateSession beyond triangle arrays: mesh files read by the server's
// readers, polygons in arrays, the reorient and drop-degenerate repairs,
// the reservation of a file's parsed size, and GetMesh.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <fstream>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/cli/cli_flags.h"
#include "lib/core/shapes.h"
#include "lib/io/mesh_io.h"
#include "proto/wire/convert.h"
#include "server/mesh_upload.h"
#include "server/session.h"
#include "tests/server_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Slurp;
using ::testing::ElementsAreArray;
using ::testing::HasSubstr;
using ::testing::Not;

class UploadFileTest : public testing::ServerFixture {
 protected:
  // Streams `msgs` as one CreateSession.
  absl::StatusOr<v1::SessionInfo> Upload(
      const std::vector<v1::CreateSessionRequest>& msgs) {
    return testing::RawUpload(*client_, msgs);
  }
  absl::StatusOr<v1::GetMeshResponse> GetMesh(const std::string& id) {
    auto ctx = client_->Context(id);
    v1::GetMeshRequest request;
    request.set_session_id(id);
    v1::GetMeshResponse response;
    if (absl::Status s = wire::FromGrpc(
            client_->stub().GetMesh(ctx.get(), request, &response));
        !s.ok()) {
      return s;
    }
    return response;
  }
};

// A file upload in chunks of `step` bytes.
std::vector<v1::CreateSessionRequest> FileUpload(const std::string& contents,
                                                 const std::string& format,
                                                 bool reorient = false,
                                                 size_t step = 1000) {
  std::vector<v1::CreateSessionRequest> m(1);
  auto* h = m[0].mutable_header();
  h->set_session_id("up");
  h->set_file_format(format);
  h->set_file_bytes(std::ssize(contents));
  h->set_reorient(reorient);
  for (size_t b = 0; b < contents.size(); b += step) {
    m.emplace_back().mutable_chunk()->set_file_data(contents.substr(b, step));
  }
  m.emplace_back().mutable_footer()->set_crc32(static_cast<uint32_t>(crc32(
      0, reinterpret_cast<const Bytef*>(contents.data()), contents.size())));
  return m;
}

// Arrays: header, one chunk, footer.
std::vector<v1::CreateSessionRequest> ArraysUpload(
    const Mesh& mesh, const std::vector<std::vector<int>>& faces,
    bool declare_indices, bool reorient = false, bool drop = false) {
  std::vector<v1::CreateSessionRequest> m(3);
  auto* h = m[0].mutable_header();
  h->set_session_id("up");
  h->set_dimension(3);
  h->set_num_vertices(mesh.num_vertices());
  h->set_num_faces(std::ssize(faces));
  h->set_reorient(reorient);
  h->set_drop_degenerate_faces(drop);
  auto* c = m[1].mutable_chunk();
  wire::AppendFlattened(mesh.positions, 3, c->mutable_positions());
  int64_t indices = 0;
  for (const auto& f : faces) {
    c->add_face_sizes(std::ssize(f));
    for (int v : f) c->add_face_indices(v);
    indices += std::ssize(f);
  }
  if (declare_indices) h->set_num_face_indices(indices);
  uLong crc = crc32(0, reinterpret_cast<const Bytef*>(c->positions().data()),
                    c->positions_size() * 8);
  crc = crc32(crc, reinterpret_cast<const Bytef*>(c->face_sizes().data()),
              c->face_sizes_size() * 4);
  crc = crc32(crc, reinterpret_cast<const Bytef*>(c->face_indices().data()),
              c->face_indices_size() * 4);
  m[2].mutable_footer()->set_num_vertices(mesh.num_vertices());
  m[2].mutable_footer()->set_num_faces(std::ssize(faces));
  m[2].mutable_footer()->set_crc32(static_cast<uint32_t>(crc));
  return m;
}

// The mesh of a GetMesh reply.
Mesh FromWire(const v1::GetMeshResponse& r) {
  Mesh m;
  m.dimension = r.dimension();
  for (int i = 0; i < r.positions_size(); i += r.dimension()) {
    m.positions.push_back({r.positions(i), r.positions(i + 1),
                           r.dimension() == 3 ? r.positions(i + 2) : 0.0});
  }
  int at = 0;
  for (int s : r.face_sizes()) {
    Face f;
    f.size = s;
    for (int k = 0; k < s; ++k) f.v[k] = r.face_indices(at++);
    m.faces.push_back(f);
  }
  m.face_regions.assign(r.face_regions().begin(), r.face_regions().end());
  return m;
}

void ExpectSameMesh(const Mesh& a, const Mesh& b) {
  ASSERT_EQ(a.num_vertices(), b.num_vertices());
  ASSERT_EQ(a.num_faces(), b.num_faces());
  for (int64_t v = 0; v < a.num_vertices(); ++v) {
    ASSERT_EQ(a.positions[v], b.positions[v]) << "vertex " << v;
  }
  for (int64_t f = 0; f < a.num_faces(); ++f) {
    ASSERT_EQ(a.faces[f].size, b.faces[f].size) << "face " << f;
    for (int k = 0; k < a.faces[f].size; ++k) {
      ASSERT_EQ(a.faces[f].v[k], b.faces[f].v[k]) << "face " << f;
    }
  }
  EXPECT_EQ(a.face_regions, b.face_regions);
}

TEST_F(UploadFileTest, AFileIsReadAsTheCliReadsIt) {
  for (const char* name : {"fandisk.obj", "horse.ply", "decimated-knight.off",
                           "1002_tray_bottom.STL"}) {
    SCOPED_TRACE(name);
    const std::string path = testing::SharedMesh(name);
    std::string format = std::string(path.substr(path.size() - 3));
    for (char& c : format) c = static_cast<char>(std::tolower(c));
    auto info = Upload(FileUpload(Slurp(path), format, /*reorient=*/true,
                                  /*step=*/1 << 20));
    ASSERT_TRUE(info.ok()) << info.status();
    cli::MeshFlags flags;
    flags.reorient = true;
    auto cli = cli::LoadMesh(path, flags, /*threads=*/0);
    ASSERT_TRUE(cli.ok()) << cli.status();
    EXPECT_EQ(info->num_vertices(), cli->mesh.num_vertices());
    EXPECT_EQ(info->num_faces(), cli->mesh.num_faces());
    EXPECT_THAT(info->warnings(), ElementsAreArray(cli->warnings));
    EXPECT_EQ(info->signed_volume(), cli->signed_volume);
    auto mesh = GetMesh("up");
    ASSERT_TRUE(mesh.ok()) << mesh.status();
    ExpectSameMesh(FromWire(*mesh), cli->mesh);
    ASSERT_TRUE(client_->Delete("up").ok());
  }
}

TEST_F(UploadFileTest, AByteOrderMarkShiftsNothing) {
  const std::string obj =
      "\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
      "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
  auto info = Upload(FileUpload(obj, "obj", false, 7));
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->num_vertices(), 4);
  EXPECT_TRUE(info->closed());
  EXPECT_GT(info->signed_volume(), 0);
}

TEST_F(UploadFileTest, NonSimplePolygonsInAFileAreTriangulatedAndNamed) {
  const std::string path =
      absl::StrCat(MESHGAUGE_SOURCE_DIR, "/tests/fuzz/corpus/obj/bowtie.obj");
  auto info = Upload(FileUpload(Slurp(path), "obj"));
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->num_faces(), 3);
  EXPECT_THAT(info->warnings(0),
              HasSubstr("1 polygons are not simple in their best-fit plane"));
}

TEST_F(UploadFileTest, BadFileUploadsAreRefusedWithTheirCause) {
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  auto expect = [&](std::vector<v1::CreateSessionRequest> msgs,
                    absl::StatusCode code, const std::string& text) {
    auto r = Upload(msgs);
    EXPECT_EQ(r.status().code(), code) << r.status();
    EXPECT_THAT(std::string(r.status().message()), HasSubstr(text));
  };
  auto msgs = FileUpload(obj, "3ds");
  expect(msgs, absl::StatusCode::kInvalidArgument, "obj, off, ply or stl");
  msgs = FileUpload(obj, "obj");
  msgs[0].mutable_header()->set_num_vertices(3);
  expect(msgs, absl::StatusCode::kInvalidArgument, "the file holds them");
  msgs = FileUpload(obj, "obj");
  msgs.back().mutable_footer()->set_crc32(1);
  expect(msgs, absl::StatusCode::kInvalidArgument, "checksum mismatch");
  msgs = FileUpload(obj, "obj");
  msgs[0].mutable_header()->set_file_bytes(10);
  expect(msgs, absl::StatusCode::kInvalidArgument, "more than the declared");
  msgs = FileUpload(obj, "obj");
  msgs[1].mutable_chunk()->add_positions(1);
  expect(msgs, absl::StatusCode::kInvalidArgument, "file_data only");
  msgs = FileUpload(obj, "obj");
  msgs.erase(msgs.end() - 2);  // a chunk lost: fewer bytes than declared.
  expect(msgs, absl::StatusCode::kInvalidArgument, "file bytes, declared");
  expect(FileUpload("v 0 0 0\nf 1 2 3\n", "obj"),
         absl::StatusCode::kInvalidArgument, "line 2");
  msgs = FileUpload(obj, "obj");
  msgs[0].mutable_header()->set_file_bytes(int64_t{1} << 40);
  expect(msgs, absl::StatusCode::kResourceExhausted, "--max_upload_file_bytes");
  EXPECT_EQ(client_->List()->size(), 0u);
}

TEST_F(UploadFileTest, AFileOverTheVertexLimitIsRefusedAfterReading) {
  server::ServerOptions o;
  o.max_vertices = 3;
  RestartServer(o);
  auto r = Upload(
      FileUpload("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n", "obj"));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("max_vertices"));
}

// Polygons count their triangles against --max_faces, from the header.
TEST_F(UploadFileTest, PolygonsOverTheFaceLimitAreRefusedAtTheHeader) {
  server::ServerOptions o;
  o.max_faces = 100;
  RestartServer(o);
  std::vector<v1::CreateSessionRequest> m(1);
  auto* h = m[0].mutable_header();
  h->set_dimension(3);
  h->set_num_vertices(256);
  h->set_num_faces(1);
  h->set_num_face_indices(256);  // one 256-gon: 254 triangles.
  auto r = Upload(m);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(r.status().message()),
              HasSubstr("make at least 253 faces"));
  // Quads stay quads: 100 quads with their indices declared fit 100 faces.
  std::vector<std::vector<int>> quads;
  Mesh strip;
  for (int i = 0; i <= 100; ++i) {
    strip.positions.push_back({double(i), 0, 0});
    strip.positions.push_back({double(i), 1, 0});
  }
  for (int i = 0; i < 100; ++i) {
    quads.push_back({2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1});
  }
  auto fits = Upload(ArraysUpload(strip, quads, /*declare_indices=*/true));
  EXPECT_TRUE(fits.ok()) << fits.status();
}

// The file limit is also what the budget can reserve (8 bytes per byte),
// refused at the header as GetServerInfo reports it.
TEST_F(UploadFileTest, AFileOverAnEighthOfTheBudgetIsRefusedAtTheHeader) {
  server::ServerOptions o;
  o.memory_budget_bytes = 1 << 20;
  RestartServer(o);
  auto msgs = FileUpload(std::string(200'000, ' '), "obj");
  msgs.resize(1);
  auto r = Upload(msgs);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(r.status().message()),
              HasSubstr("exceeds the limit of 131072 bytes"));
}

// Eviction makes room only for file bytes that arrived: the first bytes
// of a large declared file do not push out a session the budget holds.
TEST_F(UploadFileTest, TheFirstBytesOfAFileEvictNothing) {
  const Mesh torus = MakeTorus(2, 0.5, 76, 26);
  server::ServerOptions o;
  o.memory_budget_bytes = 1 << 20;
  const int64_t declared = 100'000;
  const int64_t session = server::Session::EstimateBaseBytes(torus);
  // The session fits, the declared file on top of it would not.
  ASSERT_LT(session, o.memory_budget_bytes);
  ASSERT_GT(session + declared, o.memory_budget_bytes);
  ASSERT_LE(declared * server::kFileReadFactor, o.memory_budget_bytes);
  RestartServer(o);
  auto t = client_->Upload(torus, "t");
  ASSERT_TRUE(t.ok()) << t.status();
  auto msgs = FileUpload(std::string(declared, ' '), "obj");
  msgs.resize(2);
  msgs[1].mutable_chunk()->set_file_data("v 0 0 0\n");
  // A second header ends the stream after the chunk was taken in.
  msgs.push_back(msgs[0]);
  EXPECT_THAT(std::string(Upload(msgs).status().message()),
              HasSubstr("a second header"));
  EXPECT_TRUE(client_->Get("t").ok());
}

// A file of short face lines parses to far more than its own size: the
// reservation is grown to the parsed mesh, and refused when it does not fit.
TEST_F(UploadFileTest, AFileWhoseMeshExceedsTheBudgetIsRefusedAfterReading) {
  std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  while (obj.size() < 300'000) obj += "f 1 2 3\n";
  server::ServerOptions o;
  o.memory_budget_bytes = 4 << 20;  // holds 8 x the file, not its mesh.
  ASSERT_LT(std::ssize(obj) * server::kFileReadFactor, o.memory_budget_bytes);
  RestartServer(o);
  auto r = Upload(FileUpload(obj, "obj", false, 1 << 16));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kResourceExhausted)
      << r.status();
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("memory budget"));
  EXPECT_EQ(client_->List()->size(), 0u);
}

// A hexagonal prism: two hexagons and six quads, outward.
Mesh HexPrism(std::vector<std::vector<int>>* faces) {
  Mesh m;
  for (int z = 0; z < 2; ++z) {
    for (int k = 0; k < 6; ++k) {
      m.positions.push_back(
          {std::cos(k * M_PI / 3), std::sin(k * M_PI / 3), double(z)});
    }
  }
  faces->push_back({5, 4, 3, 2, 1, 0});
  faces->push_back({6, 7, 8, 9, 10, 11});
  for (int k = 0; k < 6; ++k) {
    const int n = (k + 1) % 6;
    faces->push_back({k, n, n + 6, k + 6});
  }
  return m;
}

TEST_F(UploadFileTest, PolygonsInArraysAreTriangulatedAsInAFile) {
  std::vector<std::vector<int>> faces;
  const Mesh prism = HexPrism(&faces);
  auto refused = Upload(ArraysUpload(prism, faces, false));
  EXPECT_THAT(std::string(refused.status().message()),
              HasSubstr("declare header.num_face_indices"));
  auto info = Upload(ArraysUpload(prism, faces, true));
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->num_faces(), 2 * 4 + 6);
  EXPECT_TRUE(info->closed());
  EXPECT_NEAR(info->signed_volume(), 1.5 * std::sqrt(3.0), 1e-12);
  // The same prism as an OBJ file reads to the same triangles.
  std::string obj;
  for (const Vec3& p : prism.positions) {
    absl::StrAppend(&obj, "v ",
                    absl::StrFormat("%.17g %.17g %.17g", p.x, p.y, p.z), "\n");
  }
  for (const auto& f : faces) {
    obj += "f";
    for (int v : f) absl::StrAppend(&obj, " ", v + 1);
    obj += "\n";
  }
  auto file = ParseMeshContents(obj, ".obj", "prism.obj");
  ASSERT_TRUE(file.ok()) << file.status();
  auto mesh = GetMesh("up");
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  ExpectSameMesh(FromWire(*mesh), file->mesh);
  // A wrong declared total is named.
  ASSERT_TRUE(client_->Delete("up").ok());
  auto msgs = ArraysUpload(prism, faces, true);
  msgs[0].mutable_header()->set_num_face_indices(
      msgs[0].header().num_face_indices() + 1);
  EXPECT_THAT(std::string(Upload(msgs).status().message()),
              HasSubstr("num_face_indices declared"));
}

TEST_F(UploadFileTest, ReorientMakesComponentsConsistentAndOutward) {
  std::vector<std::vector<int>> faces;
  const Mesh prism = HexPrism(&faces);
  for (auto& f : faces) std::reverse(f.begin(), f.end());  // all inward
  std::reverse(faces[3].begin(), faces[3].end());          // one disagrees
  auto plain = Upload(ArraysUpload(prism, faces, true));
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_THAT(absl::StrJoin(plain->warnings(), "\n"),
              HasSubstr("disagreeing orientation"));
  ASSERT_TRUE(client_->Delete("up").ok());
  auto fixed = Upload(ArraysUpload(prism, faces, true, /*reorient=*/true));
  ASSERT_TRUE(fixed.ok()) << fixed.status();
  EXPECT_NEAR(fixed->signed_volume(), 1.5 * std::sqrt(3.0), 1e-12);
  const std::string warnings = absl::StrJoin(fixed->warnings(), "\n");
  EXPECT_THAT(warnings, HasSubstr("reversed to agree with their neighbours"));
  EXPECT_THAT(warnings,
              HasSubstr("1 inward-oriented closed components reversed"));
  EXPECT_THAT(warnings, Not(HasSubstr("disagreeing orientation")));
}

TEST_F(UploadFileTest, DropDegenerateFacesIsOptIn) {
  std::vector<std::vector<int>> faces;
  Mesh prism = HexPrism(&faces);
  prism.positions.push_back({0, 0, 5});
  faces.push_back({0, 12, 0});  // a repeated index: zero area.
  auto refused = Upload(ArraysUpload(prism, faces, true));
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  auto dropped = Upload(ArraysUpload(prism, faces, true, false, true));
  ASSERT_TRUE(dropped.ok()) << dropped.status();
  EXPECT_EQ(dropped->num_faces(), 14);
  EXPECT_THAT(dropped->warnings(0), HasSubstr("1 zero-area faces dropped"));
}

TEST_F(UploadFileTest, GetMeshFollowsPositionUpdates) {
  const Mesh sphere = MakeIcosphere(1, 1.0);
  ASSERT_TRUE(client_->Upload(sphere, "s").ok());
  std::vector<Vec3> moved = sphere.positions;
  for (Vec3& p : moved) p = p * 1.5;
  auto gen = client_->UpdatePositions("s", 0, 3, moved);
  ASSERT_TRUE(gen.ok()) << gen.status();
  auto mesh = GetMesh("s");
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->generation(), 1);
  Mesh expected = sphere;
  expected.positions = moved;
  ExpectSameMesh(FromWire(*mesh), expected);
  EXPECT_EQ(GetMesh("nope").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace meshgauge
