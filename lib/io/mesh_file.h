// A mesh read from a file, with what the reader did to it.
#pragma once

#include <cstdint>
#include <string>

#include "lib/core/mesh.h"

namespace meshgauge::io {

struct MeshFile {
  Mesh mesh;                          // not validated.
  std::string format;                 // e.g. "ply binary_little_endian".
  int64_t file_faces = 0;             // faces (polygons) in the file.
  int64_t polygons_triangulated = 0;  // faces with > 4 corners split.
  // Of those, polygons not simple in their best-fit plane, split by the
  // fallback triangulation, and the file face id of the first.
  int64_t polygons_fallback = 0;
  int64_t first_fallback_polygon = -1;
  int64_t welded_corners = 0;  // STL: facet corners merged by position.
};

}  // namespace meshgauge::io
