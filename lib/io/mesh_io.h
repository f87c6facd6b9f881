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

// Writes a binary little-endian PLY with float x y z and a per-vertex float
// `quality` property (MeshLab's colour source) holding values[i] (#V; NaN is
// written as NaN) and, when `colors` is not empty (#V), uchar red green
// blue. 3D faces as `face` lists; 2D segments as an `edge` element. Errors:
// InvalidArgument for a colour count other than #V; Internal when the file
// cannot be written.
absl::Status WriteQualityPly(const std::string& path, const Mesh& mesh,
                             const std::vector<double>& values,
                             const std::vector<Rgb>& colors = {});

}  // namespace meshgauge
