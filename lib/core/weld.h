// Merging the duplicated vertices of unwelded exports (texture seams, STL,
// a vertex per face corner), so that faces meeting there share vertices:
// normals, the one-ring and closedness then see one surface.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"

namespace meshgauge {

// The largest relative weld tolerance, and the smallest positive one (the
// grid of cells stays within 64-bit integers).
inline constexpr double kMaxWeldTolerance = 0.01;
inline constexpr double kMinWeldTolerance = 1e-12;

struct Weld {
  // Vertices removed (merged into another).
  int64_t merged = 0;
  // The new index of every input vertex; empty when nothing merged.
  std::vector<int32_t> welded_vertex;
};

// Merges the vertices of `mesh` closer than relative_tolerance times its
// bounding box's diagonal (0: exactly equal coordinates only; -0 equals 0).
// Vertices are visited in index order; each joins the first kept vertex
// within the tolerance (in any of the 27 grid cells around it), else is
// kept. Kept vertices keep their position and their order, so the lowest
// input index of each merged group is its position. Faces are renumbered;
// nothing else changes (regions, directions, face order). Non-finite
// coordinates are never merged (validation names them). O(V) expected.
// Errors: InvalidArgument for a tolerance outside {0} U [1e-12, 0.01], or
// when a face's corners would merge (naming the face and the corners:
// a smaller tolerance keeps it).
absl::StatusOr<Weld> WeldVertices(Mesh& mesh, double relative_tolerance);

// Per-vertex data per input vertex from data per welded vertex (`weld`
// from WeldVertices): each input vertex takes its welded vertex's entry.
// An empty map returns `data`.
template <typename T>
std::vector<T> Unweld(const Weld& weld, const std::vector<T>& data) {
  if (weld.welded_vertex.empty() || data.empty()) return data;
  std::vector<T> out;
  out.reserve(weld.welded_vertex.size());
  for (int32_t w : weld.welded_vertex) out.push_back(data[w]);
  return out;
}

// Per-input-vertex weights (a VJP's g) onto the welded vertices: each
// welded vertex gets the sum of its input vertices' weights, in input
// order. Precondition: weights has an entry per input vertex.
std::vector<double> WeldWeights(const Weld& weld, std::vector<double> weights,
                                int64_t welded_vertices);

// The lowest input vertex of each welded vertex (whose position it has);
// empty when nothing merged.
std::vector<int32_t> KeptInputVertices(const Weld& weld);

// Per-vertex vectors (gradients) per input vertex: each welded vertex's
// goes to the lowest input vertex merged into it (whose position the mesh
// kept), the others get zero.
std::vector<Vec3> UnweldGradient(const Weld& weld,
                                 const std::vector<Vec3>& gradient);

}  // namespace meshgauge
