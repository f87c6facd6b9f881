// Mesh files.
//
// 3D: OBJ, OFF, PLY (ASCII and binary), STL (ASCII and binary) through
// OpenMesh's readers. Faces go to our own importer, not to OpenMesh's
// halfedge kernel, so non-manifold faces ("complex edges") are kept, and no
// face is lost: a file whose face count differs from what was imported is an
// error. STL facets are welded by exactly equal coordinates.
// 2D: OBJ files whose elements are `l` polylines (split into segments) and
// whose vertices have z = 0.
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/mesh.h"

namespace meshgauge {

// Reads a mesh by file extension (.obj .off .ply .stl, case-insensitive).
// The result is not validated (call ValidateMesh). Errors: NotFound
// (missing file), InvalidArgument (unknown extension, parse error, face
// count mismatch, polygon with more than 4 vertices, OBJ mixing `f` and `l`).
absl::StatusOr<Mesh> ReadMesh(const std::string& path);

// Writes a binary little-endian PLY with float x y z and a per-vertex float
// `quality` property (MeshLab's colour source) holding values[i] (#V; NaN is
// written as NaN). 3D faces as `face` lists; 2D segments as an `edge`
// element. Errors: Internal when the file cannot be written.
absl::Status WriteQualityPly(const std::string& path, const Mesh& mesh,
                             const std::vector<double>& values);

}  // namespace meshgauge
