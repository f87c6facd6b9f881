#include "lib/io/mesh_io.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "lib/io/readers.h"
#include "lib/io/scan.h"

namespace meshgauge {
namespace {

using Parser = absl::StatusOr<io::MeshFile> (*)(absl::string_view,
                                                const std::string&,
                                                const io::ReadLimits&);

// Appends v's bytes (this is a little-endian host: the PLY writers say so).
template <typename T>
void PutBinary(std::ostream& out, T v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof(v));
}

// The parser of a file extension, or null.
Parser ParserFor(absl::string_view extension) {
  const std::string ext = absl::AsciiStrToLower(extension);
  if (ext == ".obj") return io::ParseObj;
  if (ext == ".off") return io::ParseOff;
  if (ext == ".ply") return io::ParsePly;
  if (ext == ".stl") return io::ParseStl;
  return nullptr;
}

absl::Status Unsupported(absl::string_view ext, const std::string& name) {
  return absl::InvalidArgumentError(
      absl::StrCat("unsupported mesh format '", ext, "' for '", name,
                   "' (use .obj, .off, .ply or .stl)"));
}

}  // namespace

bool IsMeshExtension(absl::string_view extension) {
  return ParserFor(extension) != nullptr;
}

absl::StatusOr<io::MeshFile> ParseMeshContents(absl::string_view contents,
                                               absl::string_view extension,
                                               const std::string& name,
                                               const io::ReadLimits& limits) {
  const Parser parse = ParserFor(extension);
  if (!parse) return Unsupported(extension, name);
  // A byte-order mark would hide the first statement of a text format (an
  // OBJ would lose its first vertex and shift every index): skipped. A
  // binary STL's 80-byte header may start with anything, so STL is read
  // as it is.
  const std::string ext = absl::AsciiStrToLower(extension);
  if (ext != ".stl") absl::ConsumePrefix(&contents, io::kUtf8Bom);
  return parse(contents, name, limits);
}

absl::StatusOr<io::MeshFile> ReadMeshFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat("cannot open mesh file '", path,
                                            "': no such regular file"));
  }
  const std::string ext = std::filesystem::path(path).extension().string();
  if (!ParserFor(ext)) return Unsupported(ext, path);
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size > static_cast<uintmax_t>(kMaxMeshFileBytes)) {
    return absl::InvalidArgumentError(
        absl::StrCat("'", path, "' is larger than the limit of ",
                     kMaxMeshFileBytes, " bytes"));
  }
  std::ifstream in(path, std::ios::binary);
  std::string contents(size, '\0');
  if (!in || !in.read(contents.data(), static_cast<std::streamsize>(size))) {
    return absl::NotFoundError(
        absl::StrCat("cannot read mesh file '", path, "'"));
  }
  return ParseMeshContents(contents, ext, path);
}

absl::StatusOr<Mesh> ReadMesh(const std::string& path) {
  auto file = ReadMeshFile(path);
  if (!file.ok()) return file.status();
  return std::move(file->mesh);
}

std::vector<std::string> ReaderWarnings(const io::MeshFile& file) {
  std::vector<std::string> out;
  if (file.polygons_fallback > 0) {
    out.push_back(absl::StrCat(
        file.polygons_fallback,
        " polygons are not simple in their best-fit plane (non-planar or "
        "self-touching; first: face ",
        file.first_fallback_polygon,
        "): triangulated by the fallback (largest smallest triangle)"));
  }
  return out;
}

absl::StatusOr<RepairedMesh> RepairFileMesh(io::MeshFile file,
                                            const RepairOptions& options) {
  std::vector<std::string> warnings = ReaderWarnings(file);
  auto repaired = RepairAndDiagnose(std::move(file.mesh), options);
  if (!repaired.ok()) return repaired.status();
  for (std::string& w : repaired->diagnostics.warnings) {
    warnings.push_back(std::move(w));
  }
  repaired->diagnostics.warnings = std::move(warnings);
  return repaired;
}

absl::Status WriteObj(const std::string& path, const Mesh& mesh) {
  std::ofstream out(path);
  if (!out)
    return absl::InternalError(absl::StrCat("cannot write '", path, "'"));
  out.precision(17);
  for (const Vec3& p : mesh.positions) {
    out << "v " << p.x << " " << p.y << " " << p.z << "\n";
  }
  int32_t region = 0;
  for (int64_t f = 0; f < mesh.num_faces(); ++f) {
    if (mesh.RegionOf(f) != region || f == 0) {
      region = mesh.RegionOf(f);
      out << "g " << region << "\n";
    }
    const Face& face = mesh.faces[f];
    out << (face.size == 2 ? "l" : "f");
    for (int k = 0; k < face.size; ++k) out << " " << face.v[k] + 1;
    out << "\n";
  }
  if (!out)
    return absl::InternalError(absl::StrCat("error writing '", path, "'"));
  return absl::OkStatus();
}

absl::Status WriteQualityPly(const std::string& path, const Mesh& mesh,
                             const std::vector<double>& values,
                             const std::vector<Rgb>& colors, QualityOn on) {
  const bool per_face = on == QualityOn::kFaces;
  const size_t expected = per_face ? mesh.faces.size() : mesh.positions.size();
  if (values.size() != expected) {
    return absl::InvalidArgumentError(
        absl::StrCat(values.size(), " values for ", expected,
                     per_face ? " faces" : " vertices"));
  }
  if (!colors.empty() && colors.size() != mesh.positions.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        colors.size(), " colours for ", mesh.positions.size(), " vertices"));
  }
  std::ofstream out(path, std::ios::binary);
  if (!out)
    return absl::InternalError(absl::StrCat("cannot write '", path, "'"));
  const bool curve = mesh.dimension == 2;
  out << "ply\nformat binary_little_endian 1.0\n"
      << "comment meshgauge SDF in property quality\n"
      << "element vertex " << mesh.positions.size() << "\n"
      << "property float x\nproperty float y\nproperty float z\n";
  if (!per_face) out << "property float quality\n";
  if (!colors.empty()) {
    out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  }
  if (curve) {
    out << "element edge " << mesh.faces.size() << "\n"
        << "property int vertex1\nproperty int vertex2\n";
  } else {
    int64_t tris = 0;
    for (const Face& f : mesh.faces) tris += f.size - 2;
    out << "element face " << (per_face ? std::ssize(mesh.faces) : tris) << "\n"
        << "property list uchar int vertex_indices\n";
  }
  if (per_face) out << "property float quality\n";
  out << "end_header\n";
  auto put = [&out](auto v) { PutBinary(out, v); };
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    put(static_cast<float>(p.x));
    put(static_cast<float>(p.y));
    put(static_cast<float>(p.z));
    if (!per_face) put(static_cast<float>(values[i]));
    if (!colors.empty()) {
      put(colors[i].r);
      put(colors[i].g);
      put(colors[i].b);
    }
  }
  for (size_t i = 0; i < mesh.faces.size(); ++i) {
    const Face& f = mesh.faces[i];
    if (curve) {
      put(static_cast<int32_t>(f.v[0]));
      put(static_cast<int32_t>(f.v[1]));
    } else if (per_face) {
      put(static_cast<uint8_t>(f.size));
      for (int k = 0; k < f.size; ++k) put(static_cast<int32_t>(f.v[k]));
    } else {
      for (int t = 0; t + 2 < f.size; ++t) {
        put(static_cast<uint8_t>(3));
        put(static_cast<int32_t>(f.v[0]));
        put(static_cast<int32_t>(f.v[t + 1]));
        put(static_cast<int32_t>(f.v[t + 2]));
      }
    }
    if (per_face) put(static_cast<float>(values[i]));
  }
  if (!out)
    return absl::InternalError(absl::StrCat("error writing '", path, "'"));
  return absl::OkStatus();
}

absl::Status WriteSegmentsPly(const std::string& path,
                              absl::Span<const Vec3> from,
                              absl::Span<const Vec3> to,
                              absl::Span<const double> values) {
  if (to.size() != from.size() || values.size() != from.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat(from.size(), " samples, ", to.size(),
                     " opposite points and ", values.size(), " values"));
  }
  std::vector<int32_t> drawn;
  for (size_t i = 0; i < from.size(); ++i) {
    const Vec3& q = to[i];
    if (std::isfinite(values[i]) && std::isfinite(q.x) && std::isfinite(q.y) &&
        std::isfinite(q.z)) {
      drawn.push_back(static_cast<int32_t>(i));
    }
  }
  std::ofstream out(path, std::ios::binary);
  if (!out)
    return absl::InternalError(absl::StrCat("cannot write '", path, "'"));
  out << "ply\nformat binary_little_endian 1.0\n"
      << "comment meshgauge thickness segments: sample -> opposite point\n"
      << "element vertex " << 2 * drawn.size() << "\n"
      << "property double x\nproperty double y\nproperty double z\n"
      << "property double quality\nproperty int sample\n"
      << "element edge " << drawn.size() << "\n"
      << "property int vertex1\nproperty int vertex2\n"
      << "end_header\n";
  for (int32_t i : drawn) {
    for (const Vec3* p : {&from[i], &to[i]}) {
      PutBinary(out, p->x);
      PutBinary(out, p->y);
      PutBinary(out, p->z);
      PutBinary(out, values[i]);
      PutBinary(out, i);
    }
  }
  for (size_t e = 0; e < drawn.size(); ++e) {
    PutBinary(out, static_cast<int32_t>(2 * e));
    PutBinary(out, static_cast<int32_t>(2 * e + 1));
  }
  if (!out)
    return absl::InternalError(absl::StrCat("error writing '", path, "'"));
  return absl::OkStatus();
}

}  // namespace meshgauge
