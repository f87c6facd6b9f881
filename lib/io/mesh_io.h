// Mesh files: OBJ, OFF (ASCII), PLY (ASCII, binary little and big endian)
// and STL (ASCII, binary), read in double precision by our own parsers
// (lib/io/readers.h), and the OBJ and quality-PLY writers.
//
// Reading guarantees: a decimal coordinate is rounded once to the nearest
// double and binary values are exact; vertices are never dropped or
// renumbered (STL corners are welded by exactly equal coordinates); memory
// is bounded by a small multiple of the file size and time is linear in it;
// every defect is InvalidArgument naming the line or byte offset; no other
// file is opened (OBJ mtllib is ignored) and nothing is printed. Polygons
// with more than four corners are triangulated by ear clipping in their
// best-fit plane (at most kMaxPolygonCorners corners).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/types/span.h"
#include "lib/core/image.h"
#include "lib/core/mesh.h"
#include "lib/core/mesh_repair.h"
#include "lib/io/mesh_file.h"

namespace meshgauge {

// Largest file ReadMeshFile accepts.
inline constexpr int64_t kMaxMeshFileBytes = int64_t{4} << 30;

// Reads a mesh by file extension (.obj .off .ply .stl, case-insensitive).
// The mesh is not validated (call ValidateMesh). Errors: NotFound (missing
// file, not a regular file), InvalidArgument (unknown extension, too large,
// any defect of the contents).
absl::StatusOr<io::MeshFile> ReadMeshFile(const std::string& path);
absl::StatusOr<Mesh> ReadMesh(const std::string& path);

// True for the extensions ReadMeshFile reads (".obj" ..., any case).
bool IsMeshExtension(absl::string_view extension);

// Parses file contents of the format named by `extension` (".obj", ...);
// `name` names them in messages. ReadMeshFile without the file, within
// `limits` (ResourceExhausted, or the callbacks' errors).
absl::StatusOr<io::MeshFile> ParseMeshContents(
    absl::string_view contents, absl::string_view extension,
    const std::string& name, const io::ReadLimits& limits = {});

namespace io {
// What a file's contents look like, whatever its extension says.
struct Sniffed {
  // ".obj", ".off", ".ply", ".stl" (a format we read), "utf-16", "utf-32",
  // "binary" (not text), "other" (a known format we do not read), or empty
  // (nothing recognised).
  std::string kind;
  std::string what;    // e.g. "a binary STL (80-byte header, 12 triangles)".
  std::string advice;  // e.g. "rename it .stl"; may be empty.
};
}  // namespace io

// Looks at the contents' first bytes (magic numbers, byte-order marks, NUL
// bytes, the binary STL's size rule, the first statements); O(64 KiB).
// ParseMeshContents calls it when the extension's reader fails, and names
// the kind found when it is not the extension's: a binary STL named .obj is
// "this looks like a binary STL (80-byte header, N triangles), not an OBJ
// file: rename it .stl (read as an OBJ file: ...the reader's message)".
io::Sniffed SniffMeshContents(absl::string_view contents);

// One sentence per thing the reader did that a user should know of
// (polygons triangulated by the fallback), for summaries and SessionInfo.
std::vector<std::string> ReaderWarnings(const io::MeshFile& file);

// The file's mesh repaired, validated and diagnosed (RepairAndDiagnose),
// with the reader's warnings first: how the CLI and the server's uploads
// prepare what they read. Errors: RepairAndDiagnose's.
absl::StatusOr<RepairedMesh> RepairFileMesh(io::MeshFile file,
                                            const RepairOptions& options);

// Writes OBJ: `v` lines with 17 significant digits (they read back
// exactly), `f` faces (3D) or `l` segments (2D), `g ID` before each run of
// faces of region ID. Errors: Internal when the file cannot be written.
absl::Status WriteObj(const std::string& path, const Mesh& mesh);

// Which element a quality PLY's values belong to.
enum class QualityOn { kVertices, kFaces };

// Writes a binary little-endian PLY with float x y z and a float `quality`
// property (MeshLab's colour source) holding values[i] (NaN is written as
// NaN): per vertex (#V; 3D faces as triangle lists, quads split) or, with
// QualityOn::kFaces, per face (#F; each face as its own list, 3 or 4
// corners, then its quality); and, when `colors` is not empty (#V), uchar
// red green blue per vertex. 2D segments as an `edge` element. Errors:
// InvalidArgument for a value or colour count other than #V (#F); Internal
// when the file cannot be written.
absl::Status WriteQualityPly(const std::string& path, const Mesh& mesh,
                             const std::vector<double>& values,
                             const std::vector<Rgb>& colors = {},
                             QualityOn on = QualityOn::kVertices);

// Writes thickness segments (SPEC v2 §5c) as a binary little-endian PLY
// line set: for each i with a finite values[i] and a finite to[i], two
// vertices from[i] and to[i] (double x y z, double quality = values[i], int
// sample = i) joined by an `edge`. Samples without a value are left out;
// double coordinates keep the points as computed. from, to and values have
// one entry per sample. Errors: InvalidArgument for sizes that differ;
// Internal when the file cannot be written.
absl::Status WriteSegmentsPly(const std::string& path,
                              absl::Span<const Vec3> from,
                              absl::Span<const Vec3> to,
                              absl::Span<const double> values);

}  // namespace meshgauge
