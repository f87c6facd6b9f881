#include "lib/mesh_io.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "lib/obj_curve_reader.h"

namespace meshgauge {
namespace {

using OpenMesh::EdgeHandle;
using OpenMesh::FaceHandle;
using OpenMesh::HalfedgeHandle;
using OpenMesh::Vec2f;
using OpenMesh::Vec3d;
using OpenMesh::Vec3f;
using OpenMesh::Vec3uc;
using OpenMesh::Vec4f;
using OpenMesh::Vec4uc;
using OpenMesh::VertexHandle;

// Receives vertices and faces from OpenMesh's readers; ignores attributes.
class CollectingImporter : public OpenMesh::IO::BaseImporter {
 public:
  explicit CollectingImporter(Mesh* mesh) : mesh_(mesh) {}

  VertexHandle add_vertex(const Vec3f& p) override {
    return add_vertex(Vec3d(p[0], p[1], p[2]));
  }
  VertexHandle add_vertex(const Vec3d& p) override {
    mesh_->positions.push_back({p[0], p[1], p[2]});
    return VertexHandle(static_cast<int>(mesh_->positions.size() - 1));
  }
  VertexHandle add_vertex() override { return add_vertex(Vec3d(0, 0, 0)); }
  FaceHandle add_face(const VHandles& idx) override {
    Face f;
    f.size = static_cast<int32_t>(idx.size());
    if (f.size <= 4) {
      for (int k = 0; k < f.size; ++k) f.v[k] = idx[k].idx();
    } else {
      ++polygons_;
    }
    mesh_->faces.push_back(f);
    return FaceHandle(static_cast<int>(mesh_->faces.size() - 1));
  }
  void set_point(VertexHandle vh, const Vec3f& p) override {
    if (vh.idx() >= 0 && vh.idx() < static_cast<int>(mesh_->positions.size()))
      mesh_->positions[vh.idx()] = {p[0], p[1], p[2]};
  }
  size_t n_vertices() const override { return mesh_->positions.size(); }
  size_t n_faces() const override { return mesh_->faces.size(); }
  size_t n_edges() const override { return 0; }
  int64_t polygons() const { return polygons_; }

  // Attributes and halfedge-level calls are not needed.
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override {
    return HalfedgeHandle();
  }
  FaceHandle add_face(HalfedgeHandle) override { return FaceHandle(); }
  void add_face_texcoords(FaceHandle, VertexHandle,
                          const std::vector<Vec2f>&) override {}
  void add_face_texcoords(FaceHandle, VertexHandle,
                          const std::vector<Vec3f>&) override {}
  void set_face_texindex(FaceHandle, int) override {}
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_normal(VertexHandle, const Vec3f&) override {}
  void set_normal(VertexHandle, const Vec3d&) override {}
  void set_color(VertexHandle, const Vec3uc&) override {}
  void set_color(VertexHandle, const Vec4uc&) override {}
  void set_color(VertexHandle, const Vec3f&) override {}
  void set_color(VertexHandle, const Vec4f&) override {}
  void set_texcoord(VertexHandle, const Vec2f&) override {}
  void set_status(VertexHandle,
                  const OpenMesh::Attributes::StatusInfo&) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HalfedgeHandle, const Vec2f&) override {}
  void set_texcoord(VertexHandle, const Vec3f&) override {}
  void set_texcoord(HalfedgeHandle, const Vec3f&) override {}
  void set_status(HalfedgeHandle,
                  const OpenMesh::Attributes::StatusInfo&) override {}
  void set_color(EdgeHandle, const Vec3uc&) override {}
  void set_color(EdgeHandle, const Vec4uc&) override {}
  void set_color(EdgeHandle, const Vec3f&) override {}
  void set_color(EdgeHandle, const Vec4f&) override {}
  void set_status(EdgeHandle,
                  const OpenMesh::Attributes::StatusInfo&) override {}
  void set_normal(FaceHandle, const Vec3f&) override {}
  void set_normal(FaceHandle, const Vec3d&) override {}
  void set_color(FaceHandle, const Vec3uc&) override {}
  void set_color(FaceHandle, const Vec4uc&) override {}
  void set_color(FaceHandle, const Vec3f&) override {}
  void set_color(FaceHandle, const Vec4f&) override {}
  void set_status(FaceHandle,
                  const OpenMesh::Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}

 private:
  Mesh* mesh_;
  int64_t polygons_ = 0;
};

std::string LowerExtension(const std::string& path) {
  return absl::AsciiStrToLower(
      std::filesystem::path(path).extension().string());
}

// Counts the faces a file declares, independently of OpenMesh, so that a
// face the reader skipped (degenerate, repeated index) is reported instead
// of silently lost. Returns -1 when the format does not allow a cheap count.
int64_t DeclaredFaceCount(const std::string& path, const std::string& ext) {
  std::ifstream in(path, std::ios::binary);
  if (ext == ".stl") {
    char header[80];
    uint32_t count = 0;
    in.read(header, 80);
    in.read(reinterpret_cast<char*>(&count), 4);
    const auto size = std::filesystem::file_size(path);
    if (in && size == 84 + 50ull * count) return count;  // binary STL.
    in.clear();
    in.seekg(0);
    int64_t facets = 0;
    std::string word;
    while (in >> word) facets += (word == "facet");
    return facets;
  }
  if (ext == ".obj") {
    int64_t faces = 0;
    std::string line;
    while (std::getline(in, line)) {
      const absl::string_view s = absl::StripLeadingAsciiWhitespace(line);
      faces += s.size() > 1 && s[0] == 'f' && (s[1] == ' ' || s[1] == '\t');
    }
    return faces;
  }
  return -1;  // OFF and PLY headers declare counts that OpenMesh honours.
}

}  // namespace

absl::StatusOr<Mesh> ReadMesh(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat("cannot open mesh file '", path,
                                            "': no such regular file"));
  }
  const std::string ext = LowerExtension(path);
  if (ext != ".obj" && ext != ".off" && ext != ".ply" && ext != ".stl") {
    return absl::InvalidArgumentError(
        absl::StrCat("unsupported mesh format '", ext, "' for '", path,
                     "' (use .obj, .off, .ply or .stl)"));
  }
  if (ext == ".obj") {
    auto curve = ReadObjCurveIfAny(path);
    if (!curve.ok()) return curve.status();
    if (curve->has_value()) return std::move(**curve);
  }
  Mesh mesh;
  mesh.dimension = 3;
  CollectingImporter importer(&mesh);
  OpenMesh::IO::Options options;
  if (ext == ".ply" || ext == ".stl") options += OpenMesh::IO::Options::Binary;
  if (!OpenMesh::IO::IOManager().read(path, importer, options)) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot parse mesh file '", path, "'"));
  }
  if (importer.polygons() > 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", path, "' has ", importer.polygons(),
        " polygons with more than 4 vertices (only triangles and quads are "
        "supported)"));
  }
  const int64_t declared = DeclaredFaceCount(path, ext);
  if (declared >= 0 && declared != mesh.num_faces()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", path, "' declares ", declared, " faces but ", mesh.num_faces(),
        " could be read: ", declared - mesh.num_faces(),
        " faces are degenerate (repeated or collapsed vertices) or malformed"));
  }
  return mesh;
}

absl::Status WriteQualityPly(const std::string& path, const Mesh& mesh,
                             const std::vector<double>& values) {
  std::ofstream out(path, std::ios::binary);
  if (!out)
    return absl::InternalError(absl::StrCat("cannot write '", path, "'"));
  const bool curve = mesh.dimension == 2;
  out << "ply\nformat binary_little_endian 1.0\n"
      << "comment meshgauge SDF in property quality\n"
      << "element vertex " << mesh.positions.size() << "\n"
      << "property float x\nproperty float y\nproperty float z\n"
      << "property float quality\n";
  if (curve) {
    out << "element edge " << mesh.faces.size() << "\n"
        << "property int vertex1\nproperty int vertex2\n";
  } else {
    int64_t tris = 0;
    for (const Face& f : mesh.faces) tris += f.size - 2;
    out << "element face " << tris << "\n"
        << "property list uchar int vertex_indices\n";
  }
  out << "end_header\n";
  auto put = [&out](auto v) {
    out.write(reinterpret_cast<const char*>(&v), sizeof(v));
  };
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    put(static_cast<float>(p.x));
    put(static_cast<float>(p.y));
    put(static_cast<float>(p.z));
    put(static_cast<float>(values[i]));
  }
  for (const Face& f : mesh.faces) {
    if (curve) {
      put(static_cast<int32_t>(f.v[0]));
      put(static_cast<int32_t>(f.v[1]));
      continue;
    }
    for (int t = 0; t + 2 < f.size; ++t) {
      put(static_cast<uint8_t>(3));
      put(static_cast<int32_t>(f.v[0]));
      put(static_cast<int32_t>(f.v[t + 1]));
      put(static_cast<int32_t>(f.v[t + 2]));
    }
  }
  if (!out)
    return absl::InternalError(absl::StrCat("error writing '", path, "'"));
  return absl::OkStatus();
}

}  // namespace meshgauge
