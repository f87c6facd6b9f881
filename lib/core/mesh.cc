#include "lib/core/mesh.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "lib/core/bucket_sort.h"

namespace meshgauge {
namespace {

constexpr int kMaxIdsInMessage = 5;

// |(b-a) x (c-a)| <= 1e-14 * longest edge^2, evaluated on the edges scaled
// by their largest component so that no product overflows or underflows.
bool TriangleIsDegenerate(const Vec3& a, const Vec3& b, const Vec3& c) {
  Vec3 u = b - a, v = c - a;
  const double scale = std::max({std::abs(u.x), std::abs(u.y), std::abs(u.z),
                                 std::abs(v.x), std::abs(v.y), std::abs(v.z)});
  if (!(scale > 0)) return true;
  u = u / scale;
  v = v / scale;
  const Vec3 w = v - u;
  const double area2 = Norm(Cross(u, v));
  const double longest = std::max({Dot(u, u), Dot(v, v), Dot(w, w)});
  return !(area2 > 1e-14 * longest);
}

// Products of two edges (face normals, areas) must not overflow: every
// edge component must stay below 1e150.
constexpr double kMaxEdgeComponent = 1e150;

bool EdgesOverflow(const Mesh& mesh, const Face& f) {
  for (int k = 0; k < f.size; ++k) {
    const Vec3 e =
        mesh.positions[f.v[(k + 1) % f.size]] - mesh.positions[f.v[k]];
    for (int c = 0; c < 3; ++c) {
      if (!(std::abs(e[c]) < kMaxEdgeComponent)) return true;
    }
  }
  return false;
}

// The offending ids of one defect class, for a precise message.
class DefectList {
 public:
  void Add(int64_t id) {
    if (count_ < kMaxIdsInMessage) first_.push_back(id);
    ++count_;
  }
  // Appends the ids of `later`, all above this list's.
  void Append(const DefectList& later) {
    for (int64_t id : later.first_) {
      if (std::ssize(first_) < kMaxIdsInMessage) first_.push_back(id);
    }
    count_ += later.count_;
  }
  bool empty() const { return count_ == 0; }
  // "<count> <what> (first <kind> ids: 1, 2, 3)".
  std::string Message(const std::string& what, const char* kind) const {
    return absl::StrCat(count_, " ", what, " (first ", kind,
                        " ids: ", absl::StrJoin(first_, ", "), ")");
  }

 private:
  int64_t count_ = 0;
  std::vector<int64_t> first_;
};

// ValidateMesh's defect classes, in the order of its message.
enum Defect {
  kNonFinite,
  kNonzeroZ,
  kBadArity,
  kOutOfRange,
  kRepeated,
  kOverflow,
  kDegenerate,
  kNumDefects,
  kNone = kNumDefects,
};

std::string DefectText(Defect d, const Mesh& mesh) {
  const int dimension = mesh.dimension;
  switch (d) {
    case kNonFinite:
      return "vertices have non-finite coordinates";
    case kNonzeroZ:
      return "vertices of a 2D mesh have z != 0 (mixed dimensions)";
    case kBadArity:
      return dimension == 2 ? "faces are not segments in a 2D mesh (mixed "
                              "dimensions)"
                            : "faces are neither triangles nor quads in a 3D "
                              "mesh (mixed dimensions)";
    case kOutOfRange:
      return absl::StrCat("faces have vertex indices out of range [0, ",
                          mesh.num_vertices(), ")");
    case kRepeated:
      return "faces repeat a vertex index";
    case kOverflow:
      return "faces have edges too long for double precision (an edge "
             "component of 1e150 or more overflows the face normals; "
             "rescale the mesh)";
    case kDegenerate:
      return dimension == 2 ? "segments have zero length"
                            : "faces have zero area";
    case kNumDefects:
      break;
  }
  return "";
}

Defect VertexDefect(const Mesh& mesh, int64_t i) {
  if (!IsFinite(mesh.positions[i])) return kNonFinite;
  if (mesh.dimension == 2 && mesh.positions[i].z != 0) return kNonzeroZ;
  return kNone;
}

// The first defect of face `f` found in ValidateMesh's order; its geometry
// is looked at only when every vertex is finite (`finite`).
Defect FaceDefect(const Mesh& mesh, int64_t f, bool finite) {
  const Face& face = mesh.faces[f];
  const bool arity_ok =
      mesh.dimension == 2 ? face.size == 2 : (face.size == 3 || face.size == 4);
  if (!arity_ok) return kBadArity;
  for (int k = 0; k < face.size; ++k) {
    if (face.v[k] < 0 || face.v[k] >= mesh.num_vertices()) return kOutOfRange;
  }
  for (int a = 0; a < face.size; ++a) {
    for (int b = a + 1; b < face.size; ++b) {
      if (face.v[a] == face.v[b]) return kRepeated;
    }
  }
  if (!finite) return kNone;
  if (EdgesOverflow(mesh, face)) return kOverflow;
  if (FaceIsDegenerate(mesh, face)) return kDegenerate;
  return kNone;
}

using Defects = std::array<DefectList, kNumDefects>;

// The defects of elements [0, n) (`defect(i)`), found in blocks side by side
// and merged in id order: the same lists for any thread count.
template <typename DefectOf>
Defects FindDefects(int64_t n, DefectOf defect) {
  constexpr int64_t kBlock = 1 << 16;
  std::vector<Defects> blocks((n + kBlock - 1) / kBlock);
  tbb::parallel_for(int64_t{0}, std::ssize(blocks), [&](int64_t b) {
    for (int64_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) {
      if (const Defect d = defect(i); d != kNone) blocks[b][d].Add(i);
    }
  });
  Defects all;
  for (const Defects& block : blocks) {
    for (int d = 0; d < kNumDefects; ++d) all[d].Append(block[d]);
  }
  return all;
}

}  // namespace

bool FaceIsDegenerate(const Mesh& mesh, const Face& f) {
  const auto& p = mesh.positions;
  if (f.size == 2) return p[f.v[0]] == p[f.v[1]];
  if (TriangleIsDegenerate(p[f.v[0]], p[f.v[1]], p[f.v[2]])) return true;
  return f.size == 4 && TriangleIsDegenerate(p[f.v[0]], p[f.v[2]], p[f.v[3]]);
}

int64_t DropDegenerateFaces(Mesh& mesh) {
  int64_t kept = 0;
  const bool regions = !mesh.face_regions.empty();
  for (int64_t f = 0; f < mesh.num_faces(); ++f) {
    const Face& face = mesh.faces[f];
    bool in_range = face.size >= 2 && face.size <= 4;
    for (int k = 0; k < face.size && in_range; ++k) {
      in_range = face.v[k] >= 0 && face.v[k] < mesh.num_vertices();
    }
    if (in_range && FaceIsDegenerate(mesh, face)) continue;
    mesh.faces[kept] = face;
    if (regions) mesh.face_regions[kept] = mesh.face_regions[f];
    ++kept;
  }
  const int64_t dropped = mesh.num_faces() - kept;
  mesh.faces.resize(kept);
  if (regions) mesh.face_regions.resize(kept);
  return dropped;
}

absl::Status MoveVertices(absl::Span<const int32_t> indices,
                          absl::Span<const Vec3> moved,
                          std::vector<Vec3>* positions) {
  if (indices.size() != moved.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "got ", indices.size(), " indices but ", moved.size(), " positions"));
  }
  const int64_t n = std::ssize(*positions);
  std::vector<uint8_t> seen(positions->size(), 0);
  for (size_t i = 0; i < indices.size(); ++i) {
    const int32_t v = indices[i];
    if (v < 0 || v >= n) {
      return absl::InvalidArgumentError(
          absl::StrCat("vertex index ", v, " at position ", i,
                       " is out of range [0, ", n, ")"));
    }
    if (seen[v]++) {
      return absl::InvalidArgumentError(
          absl::StrCat("vertex index ", v, " is repeated in the update"));
    }
  }
  for (size_t i = 0; i < indices.size(); ++i)
    (*positions)[indices[i]] = moved[i];
  return absl::OkStatus();
}

absl::Status ValidateMesh(const Mesh& mesh) {
  if (mesh.dimension != 2 && mesh.dimension != 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("dimension must be 2 or 3, got ", mesh.dimension));
  }
  if (mesh.positions.empty() || mesh.faces.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("empty mesh: ", mesh.positions.size(), " vertices and ",
                     mesh.faces.size(), " faces (need at least one of each)"));
  }
  if (mesh.positions.size() >
          static_cast<size_t>(std::numeric_limits<int32_t>::max()) ||
      mesh.faces.size() >
          static_cast<size_t>(std::numeric_limits<int32_t>::max() / 2)) {
    return absl::InvalidArgumentError("mesh too large for 32-bit indices");
  }
  if (!mesh.face_regions.empty() &&
      mesh.face_regions.size() != mesh.faces.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "face_regions has ", mesh.face_regions.size(),
        " entries but the mesh has ", mesh.faces.size(), " faces"));
  }
  const Defects vertices = FindDefects(mesh.num_vertices(), [&mesh](int64_t i) {
    return VertexDefect(mesh, i);
  });
  const bool finite = vertices[kNonFinite].empty();
  const Defects faces = FindDefects(
      mesh.num_faces(),
      [&mesh, finite](int64_t f) { return FaceDefect(mesh, f, finite); });
  std::vector<std::string> problems;
  for (int d = 0; d < kNumDefects; ++d) {
    const bool vertex = d == kNonFinite || d == kNonzeroZ;
    const DefectList& list = vertex ? vertices[d] : faces[d];
    if (list.empty()) continue;
    problems.push_back(list.Message(DefectText(static_cast<Defect>(d), mesh),
                                    vertex ? "vertex" : "face"));
  }
  // Direction conflicts (possible only when some region's cones point
  // outward): 0 = unseen, 1 = inward, 2 = outward, 3 = both.
  if (problems.empty() &&
      std::any_of(mesh.region_directions.begin(), mesh.region_directions.end(),
                  [](const auto& entry) {
                    return entry.second != ConeDirection::kInward;
                  })) {
    std::vector<uint8_t> seen(mesh.positions.size(), 0);
    for (int64_t f = 0; f < mesh.num_faces(); ++f) {
      const uint8_t bit =
          mesh.DirectionOfRegion(mesh.RegionOf(f)) == ConeDirection::kInward
              ? 1
              : 2;
      const Face& face = mesh.faces[f];
      for (int k = 0; k < face.size; ++k) seen[face.v[k]] |= bit;
    }
    DefectList conflict;
    for (int64_t i = 0; i < mesh.num_vertices(); ++i) {
      if (seen[i] == 3) conflict.Add(i);
    }
    if (!conflict.empty()) {
      problems.push_back(conflict.Message(
          "vertices touch faces of regions with different cone directions",
          "vertex"));
    }
  }
  if (problems.empty()) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat("invalid mesh: ", absl::StrJoin(problems, "; ")));
}

double SignedVolumeOfFaces(const Mesh& mesh, absl::Span<const int32_t> faces) {
  const auto& p = mesh.positions;
  if (faces.empty()) return 0;
  // Relative to one vertex of the faces: the same value in exact
  // arithmetic, without the cancellation of large coordinates.
  const Vec3 o = p[mesh.faces[faces[0]].v[0]];
  double sum = 0;
  for (int32_t id : faces) {
    const Face& f = mesh.faces[id];
    if (f.size == 2) {
      // Shoelace: counter-clockwise curves give positive area.
      const Vec3 a = p[f.v[0]] - o, b = p[f.v[1]] - o;
      sum += (a.x * b.y - b.x * a.y) / 2;
      continue;
    }
    for (int t = 0; t + 2 < f.size; ++t) {
      sum +=
          Dot(p[f.v[0]] - o, Cross(p[f.v[t + 1]] - o, p[f.v[t + 2]] - o)) / 6;
    }
  }
  return sum;
}

double BoundingExtent(const Mesh& mesh) {
  if (mesh.positions.empty()) return 0;
  Vec3 lo = mesh.positions[0], hi = lo;
  for (const Vec3& p : mesh.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
}

double SignedVolume(const Mesh& mesh) {
  std::vector<int32_t> all(mesh.faces.size());
  for (size_t f = 0; f < all.size(); ++f) all[f] = static_cast<int32_t>(f);
  return SignedVolumeOfFaces(mesh, all);
}

std::vector<EdgeUse> SortedEdgeUses(const Mesh& mesh) {
  const int64_t nv = mesh.num_vertices();
  // Calls emit(smaller vertex, use) for every use, in face order.
  auto for_each_use = [&mesh](auto&& emit) {
    for (int32_t id = 0; id < static_cast<int32_t>(mesh.faces.size()); ++id) {
      const Face& f = mesh.faces[id];
      if (f.size == 2) {
        emit(f.v[0], EdgeUse{static_cast<uint32_t>(f.v[0]), id, true});
        emit(f.v[1], EdgeUse{static_cast<uint32_t>(f.v[1]), id, false});
        continue;
      }
      for (int k = 0; k < f.size; ++k) {
        const int32_t a = f.v[k], b = f.v[(k + 1) % f.size];
        emit(std::min(a, b), EdgeUse{EdgeKey(a, b), id, a < b});
      }
    }
  };
  // Each vertex's uses by key; stable, so one edge's uses stay in face order.
  return BucketSorted<EdgeUse>(
      nv, for_each_use,
      [](const EdgeUse& a, const EdgeUse& b) { return a.key < b.key; });
}

bool IsClosed(const Mesh& mesh) {
  const std::vector<EdgeUse> uses = SortedEdgeUses(mesh);
  for (size_t i = 0; i < uses.size(); i += 2) {
    // Every run has length exactly 2.
    if (i + 1 >= uses.size() || uses[i + 1].key != uses[i].key ||
        (i + 2 < uses.size() && uses[i + 2].key == uses[i].key)) {
      return false;
    }
  }
  return true;
}

void ReverseFace(Face& f) {
  if (f.size == 2) {
    std::swap(f.v[0], f.v[1]);
  } else {
    std::reverse(f.v.begin() + 1, f.v.begin() + f.size);
  }
}

void ReverseFaces(Mesh& mesh) {
  for (Face& f : mesh.faces) ReverseFace(f);
}

double MeanEdgeLength(const Mesh& mesh) {
  double sum = 0;
  int64_t count = 0;
  for (const Face& f : mesh.faces) {
    const int edges = f.size == 2 ? 1 : f.size;
    for (int k = 0; k < edges; ++k) {
      sum +=
          Norm(mesh.positions[f.v[(k + 1) % f.size]] - mesh.positions[f.v[k]]);
      ++count;
    }
  }
  return count == 0 ? 0.0 : sum / static_cast<double>(count);
}

double BoundingBoxDiagonal(const Mesh& mesh) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Vec3 lo(kInf, kInf, kInf), hi(-kInf, -kInf, -kInf);
  for (const Face& f : mesh.faces) {
    for (int k = 0; k < f.size; ++k) {
      const Vec3& p = mesh.positions[f.v[k]];
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], p[c]);
        hi[c] = std::max(hi[c], p[c]);
      }
    }
  }
  return mesh.faces.empty() ? 0.0 : Norm(hi - lo);
}

}  // namespace meshgauge
