// A mesh read from a file, with what the reader did to it.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <string>

#include "absl/status/status.h"
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

// Bounds a reader applies while it reads, for a server reading what a
// client sent (a file read by the CLI uses none). Errors stop the reader:
// ResourceExhausted for a limit, the callbacks' own otherwise.
struct ReadLimits {
  static constexpr int64_t kNone = std::numeric_limits<int64_t>::max();
  int64_t max_vertices = kNone;
  int64_t max_faces = kNone;  // after triangulating polygons.
  // The sum of corners³ over the polygons triangulated by the fallback
  // (O(n³) each: about 1 ns per unit).
  int64_t max_fallback_work = kNone;
  // Called, before the reader's arrays grow past what it reported last,
  // with the bytes they will hold (in steps of about 1 MiB with room for
  // the arrays to double; a binary triangle PLY, read at fixed strides,
  // reports exactly what it stores); an error stops the reader with it.
  std::function<absl::Status(int64_t bytes)> reserve = nullptr;
  // Polled between polygons; true stops the reader with Cancelled.
  std::function<bool()> cancelled = nullptr;
};

}  // namespace meshgauge::io
