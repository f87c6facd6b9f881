#include "lib/io/mesh_io.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
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

// "an OBJ file" for ".obj", ...
std::string FormatName(absl::string_view ext) {
  if (ext == ".obj") return "an OBJ file";
  if (ext == ".off") return "an OFF file";
  if (ext == ".ply") return "a PLY file";
  return "an STL file";
}

uint32_t LittleEndian32(absl::string_view bytes) {
  uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = v << 8 | static_cast<uint8_t>(bytes[k]);
  return v;
}

// The lines of the first `limit` bytes (split at LF or CR), without the
// partial last one when the text goes on.
std::vector<absl::string_view> HeadLines(absl::string_view text, size_t limit) {
  const absl::string_view head = text.substr(0, limit);
  std::vector<absl::string_view> lines =
      absl::StrSplit(head, absl::ByAnyChar("\r\n"), absl::SkipEmpty());
  if (head.size() < text.size() && !lines.empty()) lines.pop_back();
  return lines;
}

// The first whitespace-separated token of the text after `#` comment lines.
absl::string_view FirstToken(absl::string_view text) {
  for (absl::string_view line : HeadLines(text, 4096)) {
    line = absl::StripLeadingAsciiWhitespace(line);
    if (line.empty() || line[0] == '#') continue;
    return line.substr(0, std::min(line.find_first_of(" \t"), line.size()));
  }
  return "";
}

// What the sniffers below look at.
struct SniffInput {
  absl::string_view all;   // the contents as given.
  absl::string_view text;  // without a UTF-8 byte-order mark.
  absl::string_view head;  // text's first 4096 bytes.
  bool has_nul = false;    // in head.
};

// Text in a wide encoding: UTF-32 or UTF-16 with a byte-order mark, or
// UTF-16 without one.
std::optional<io::Sniffed> SniffWideText(absl::string_view contents) {
  const size_t n = contents.size();
  // Byte-order marks of the wide encodings (UTF-32's first: FF FE 00 00
  // starts as UTF-16 LE's FF FE does).
  if (absl::StartsWith(contents, absl::string_view("\xFF\xFE\0\0", 4)) ||
      absl::StartsWith(contents, absl::string_view("\0\0\xFE\xFF", 4))) {
    return io::Sniffed{"utf-32", "UTF-32 text (byte-order mark)",
                       "save it as UTF-8 or ASCII"};
  }
  if (absl::StartsWith(contents, "\xFF\xFE") ||
      absl::StartsWith(contents, "\xFE\xFF")) {
    return io::Sniffed{
        "utf-16",
        absl::StrCat("UTF-16 text (byte-order mark ",
                     contents[0] == '\xFF' ? "FF FE, little" : "FE FF, big",
                     "-endian)"),
        "save it as UTF-8 or ASCII"};
  }
  // UTF-16 without a mark: ASCII characters each followed (LE) or
  // preceded (BE) by a NUL byte.
  if (n < 8) return std::nullopt;
  const size_t m = std::min<size_t>(n, 512) & ~size_t{1};
  int nul[2] = {0, 0}, printable[2] = {0, 0};
  for (size_t i = 0; i < m; ++i) {
    const unsigned char c = contents[i];
    nul[i % 2] += c == 0;
    printable[i % 2] +=
        c == '\t' || c == '\n' || c == '\r' || (c >= 0x20 && c < 0x7f);
  }
  for (int odd : {0, 1}) {
    if (nul[odd] * 10 >= static_cast<int>(m / 2) * 9 &&
        printable[1 - odd] * 10 >= static_cast<int>(m / 2) * 9) {
      return io::Sniffed{
          "utf-16",
          absl::StrCat("UTF-16 text (NUL bytes between the characters, ",
                       odd ? "little" : "big", "-endian, no byte-order mark)"),
          "save it as UTF-8 or ASCII"};
    }
  }
  return std::nullopt;
}

std::optional<io::Sniffed> SniffPly(const SniffInput& in) {
  if (!absl::StartsWith(in.text, "ply\n") &&
      !absl::StartsWith(in.text, "ply\r")) {
    return std::nullopt;
  }
  std::string format;
  for (absl::string_view line : HeadLines(in.text, 1024)) {
    if (absl::ConsumePrefix(&line, "format ")) {
      format = absl::StrCat(
          ", format ", line.substr(0, std::min(line.find(' '), line.size())));
      break;
    }
  }
  return io::Sniffed{".ply",
                     absl::StrCat("a PLY file ('ply' header", format, ")"),
                     "rename it .ply"};
}

std::optional<io::Sniffed> SniffStl(const SniffInput& in) {
  const absl::string_view stripped = absl::StripLeadingAsciiWhitespace(in.head);
  if (absl::StartsWith(stripped, "solid") && !in.has_nul &&
      absl::StrContains(in.head, "facet")) {
    return io::Sniffed{".stl", "an ASCII STL ('solid' and 'facet' lines)",
                       "rename it .stl"};
  }
  if (in.all.size() < 84) return std::nullopt;
  const uint64_t count = LittleEndian32(in.all.substr(80, 4));
  if (84 + 50 * count != in.all.size()) return std::nullopt;
  return io::Sniffed{".stl",
                     absl::StrCat("a binary STL (80-byte header, ", count,
                                  count == 1 ? " triangle)" : " triangles)"),
                     "rename it .stl"};
}

std::optional<io::Sniffed> SniffOff(const SniffInput& in) {
  const absl::string_view first = FirstToken(in.text);
  if (in.has_nul || (first != "OFF" && first != "COFF" && first != "NOFF" &&
                     first != "CNOFF" && first != "STOFF")) {
    return std::nullopt;
  }
  return io::Sniffed{".off", absl::StrCat("an OFF file ('", first, "' header)"),
                     "rename it .off"};
}

// Archives, compressed data and other formats known by their first bytes.
std::optional<io::Sniffed> SniffMagic(const SniffInput& in) {
  struct Magic {
    absl::string_view bytes, what, advice;
  };
  static constexpr Magic kMagic[] = {
      {"PK\x03\x04", "a ZIP archive (a 3MF file is one)",
       "export the mesh as OBJ, OFF, PLY or STL, or unpack it"},
      {"\x1F\x8B", "gzip-compressed data", "decompress it (gunzip)"},
      {"glTF", "a binary glTF (.glb)",
       "export the mesh as OBJ, OFF, PLY or STL"},
      {"Kaydara FBX Binary", "a binary FBX file",
       "export the mesh as OBJ, OFF, PLY or STL"},
      {"\x89PNG", "a PNG image", ""},
      {"%PDF", "a PDF document", ""},
  };
  for (const Magic& m : kMagic) {
    if (absl::StartsWith(in.text, m.bytes)) {
      return io::Sniffed{"other", std::string(m.what), std::string(m.advice)};
    }
  }
  return std::nullopt;
}

// A NUL byte, or over a tenth of control characters, in the head.
std::optional<io::Sniffed> SniffBinary(const SniffInput& in) {
  int control = 0;
  for (unsigned char c : in.head) {
    control += (c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\f' &&
                c != '\v') ||
               c == 0x7f;
  }
  if (!in.has_nul && control * 10 <= static_cast<int>(in.head.size())) {
    return std::nullopt;
  }
  return io::Sniffed{"binary", "binary data, not text",
                     "a mesh file of another format or no mesh at all"};
}

// OBJ: `v` lines and `f` or `l` lines.
std::optional<io::Sniffed> SniffObj(const SniffInput& in) {
  bool v = false, f = false;
  for (absl::string_view line : HeadLines(in.text, 1 << 16)) {
    line = absl::StripLeadingAsciiWhitespace(line);
    v |= absl::StartsWith(line, "v ") || absl::StartsWith(line, "v\t");
    f |= absl::StartsWith(line, "f ") || absl::StartsWith(line, "f\t") ||
         absl::StartsWith(line, "l ") || absl::StartsWith(line, "l\t");
    if (v && f) {
      return io::Sniffed{".obj", "an OBJ file ('v' and 'f' lines)",
                         "rename it .obj"};
    }
  }
  return std::nullopt;
}

}  // namespace

io::Sniffed SniffMeshContents(absl::string_view contents) {
  if (auto wide = SniffWideText(contents)) return *wide;
  SniffInput in;
  in.all = contents;
  in.text = contents;
  absl::ConsumePrefix(&in.text, io::kUtf8Bom);
  in.head = in.text.substr(0, 4096);
  in.has_nul = in.head.find('\0') != absl::string_view::npos;
  // In this order: a PLY header before the binary STL's size check, the
  // known magic bytes before the binary-data verdict.
  for (auto sniff :
       {SniffPly, SniffStl, SniffOff, SniffMagic, SniffBinary, SniffObj}) {
    if (auto found = sniff(in)) return *found;
  }
  return {};
}

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
  const absl::string_view original = contents;
  if (ext != ".stl") absl::ConsumePrefix(&contents, io::kUtf8Bom);
  auto parsed = parse(contents, name, limits);
  if (parsed.ok() ||
      parsed.status().code() != absl::StatusCode::kInvalidArgument) {
    return parsed;
  }
  // Nothing valid: when the contents look like another kind of file (the
  // extension lies), say which, before the reader's own complaint.
  const io::Sniffed sniffed = SniffMeshContents(original);
  if (sniffed.kind.empty() || sniffed.kind == ext ||
      (sniffed.kind == "binary" && (ext == ".stl" || ext == ".ply"))) {
    return parsed;
  }
  return absl::InvalidArgumentError(absl::StrCat(
      name, ": this looks like ", sniffed.what, ", not ", FormatName(ext),
      sniffed.advice.empty() ? "" : ": ", sniffed.advice, " (read as ",
      FormatName(ext), ": ", parsed.status().message(), ")"));
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
  // Not zeroed first: the read writes every byte (a memset of the whole
  // file cost a tenth of reading a 42 MB binary PLY).
  const auto contents = std::make_unique_for_overwrite<char[]>(size);
  if (!in || !in.read(contents.get(), static_cast<std::streamsize>(size))) {
    return absl::NotFoundError(
        absl::StrCat("cannot read mesh file '", path, "'"));
  }
  return ParseMeshContents(absl::string_view(contents.get(), size), ext, path);
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
