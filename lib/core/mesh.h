// Surface mesh model of SPEC §1 and its validation.
//
// A Mesh is either
//  * 3D: vertices x_i in R^3, faces that are triangles or quads, oriented so
//    that the counter-clockwise normal points out of the solid; or
//  * 2D: vertices in R^2 (stored with z = 0), faces that are segments (a, b);
//    a closed counter-clockwise curve has its outward normal on the right,
//    perp(b - a) = ((b-a)_y, -(b-a)_x).
// Every face carries a region id (default 0); each region has a cone
// direction (INWARD by default). Units are whatever the file uses; every
// length the library reports is in those units.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/types/span.h"
#include "lib/core/vec3.h"

namespace meshgauge {

enum class ConeDirection {
  kInward,   // cone axis = -n (into the solid); the default.
  kOutward,  // cone axis = +n (interfaces inside a computational domain).
};

// One face: `size` is 2 (segment, 2D), 3 (triangle) or 4 (quad); the unused
// trailing entries of `v` are -1.
struct Face {
  std::array<int32_t, 4> v = {-1, -1, -1, -1};
  int32_t size = 0;

  static Face Segment(int32_t a, int32_t b) { return {{a, b, -1, -1}, 2}; }
  static Face Triangle(int32_t a, int32_t b, int32_t c) {
    return {{a, b, c, -1}, 3};
  }
  static Face Quad(int32_t a, int32_t b, int32_t c, int32_t d) {
    return {{a, b, c, d}, 4};
  }
};

struct Mesh {
  int dimension = 3;            // 2 or 3.
  std::vector<Vec3> positions;  // #V; z must be 0 when dimension == 2.
  std::vector<Face> faces;      // #F.
  // Region id per face: empty (all faces in region 0) or exactly #F entries.
  std::vector<int32_t> face_regions;
  // Cone direction per region id; a region not listed is kInward.
  std::map<int32_t, ConeDirection> region_directions;

  int64_t num_vertices() const { return std::ssize(positions); }
  int64_t num_faces() const { return std::ssize(faces); }
  int32_t RegionOf(int64_t face) const {
    return face_regions.empty() ? 0 : face_regions[face];
  }
  ConeDirection DirectionOfRegion(int32_t region) const {
    auto it = region_directions.find(region);
    return it == region_directions.end() ? ConeDirection::kInward : it->second;
  }
};

// Checks every rule of SPEC §1 and returns InvalidArgument naming each defect
// found, with its count and up to five offending ids, e.g.
//   "2 faces have zero area (first face ids: 7, 12)".
// Rules: dimension is 2 or 3; at least one vertex and one face; finite
// coordinates; z == 0 in 2D; face arity 2 in 2D and 3 or 4 in 3D (otherwise
// "mixed dimensions"); indices in range; no index repeated inside a face;
// no zero-area (zero-length) face; face_regions empty or #F long; no vertex
// whose incident faces belong to regions of different cone directions.
// A face has zero area when |cross| <= 1e-14 * (longest edge)^2 (for quads:
// either triangle of the split (0,1,2), (0,2,3)); a segment when its length
// is exactly 0. Unreferenced vertices and open or non-manifold meshes are
// valid. Runs in the caller's TBB arena (a tbb::task_arena bounds its
// threads); the result does not depend on their number.
absl::Status ValidateMesh(const Mesh& mesh);

// Sets (*positions)[indices[i]] = moved[i]. Every index must be in range
// and appear once, and the spans must have equal sizes; on error (Invalid
// Argument naming the index) nothing changes.
absl::Status MoveVertices(absl::Span<const int32_t> indices,
                          absl::Span<const Vec3> moved,
                          std::vector<Vec3>* positions);

// True when the face has zero area (zero length), by ValidateMesh's rule.
// Precondition: the face's indices are in range.
bool FaceIsDegenerate(const Mesh& mesh, const Face& face);

// The opt-in repair --drop-degenerate-faces: removes every face with zero
// area (including repeated indices) and its region entry; returns how many.
// Faces with indices out of range are kept for ValidateMesh to report.
int64_t DropDegenerateFaces(Mesh& mesh);

// Signed volume sum a.(b x c)/6 over triangles (quads split); positive when
// faces point outward. Meaningful only for closed 3D meshes; 2D: the signed
// area enclosed by the segments (positive for counter-clockwise curves).
double SignedVolume(const Mesh& mesh);

// The largest side of the vertices' axis-aligned bounding box (0 for no
// vertex; non-finite coordinates make it non-finite).
double BoundingExtent(const Mesh& mesh);
// The same over a subset of faces (a connected component).
double SignedVolumeOfFaces(const Mesh& mesh, absl::Span<const int32_t> faces);

// True when every undirected edge (3D) is used by exactly two faces, or every
// vertex (2D) by exactly two segments: the "closed" of data/meshes/README.md.
bool IsClosed(const Mesh& mesh);

// One use of an undirected edge by a face (3D: key = the two corners,
// smaller first, packed in 64 bits) or of a vertex by a segment (2D: key =
// the vertex).
struct EdgeUse {
  uint64_t key = 0;
  int32_t face = -1;
  bool forward = false;  // 3D: the face runs from the smaller corner; 2D: the
                         // segment starts at the vertex.
};
// Every edge use, sorted by key (a run of equal keys is one edge's uses, in
// face order), in O(V + F) time on flat arrays: a counting sort by the
// edge's smaller vertex, then a sort of each vertex's few uses.
// Precondition: indices in range.
std::vector<EdgeUse> SortedEdgeUses(const Mesh& mesh);
// The key of the edge a-b in either direction: the smaller vertex id in the
// high 32 bits, the larger in the low ones.
inline uint64_t EdgeKey(int32_t a, int32_t b) {
  if (a > b) std::swap(a, b);
  return (uint64_t{static_cast<uint32_t>(a)} << 32) | static_cast<uint32_t>(b);
}
// The (smaller) vertex of an EdgeUse key.
inline int32_t EdgeKeyVertex(uint64_t key, int dimension) {
  return static_cast<int32_t>(dimension == 2 ? key : key >> 32);
}

// Reverses the orientation of every face: (a, b, c) -> (a, c, b) and
// (a, b, c, d) -> (a, d, c, b), so a quad keeps its split diagonal a-c.
void ReverseFaces(Mesh& mesh);
// The same for one face.
void ReverseFace(Face& face);

// Mean length of all face edges (each face's edges counted once per face);
// h of SPEC §4. Precondition: mesh validated.
double MeanEdgeLength(const Mesh& mesh);

// Diagonal of the axis-aligned bounding box of the referenced vertices.
double BoundingBoxDiagonal(const Mesh& mesh);

}  // namespace meshgauge
