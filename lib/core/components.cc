#include "lib/core/components.h"

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <numeric>
#include <tuple>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "lib/core/bucket_sort.h"
#include "lib/core/disjoint_sets.h"
#include "lib/core/missing_values.h"
#include "lib/core/nesting.h"

namespace meshgauge {
namespace {

// Components with closedness and signed volume, and the count of edges (2D:
// vertices) used once, from one sort of the edge uses. Every face of an
// edge is in the edge's vertex's component, so the edge's run decides that
// component's closedness.
struct Topology {
  std::vector<Component> components;
  int64_t boundary_edges = 0;
  int64_t shared_edges = 0;  // used by more than two faces.
  bool closed = true;
  // The ends of the boundary edges (2D: the curve ends), with repeats.
  std::vector<int32_t> boundary_vertices;
};

Topology AnalyzeTopology(const Mesh& mesh, const std::vector<EdgeUse>& uses) {
  const int32_t nv = static_cast<int32_t>(mesh.num_vertices());
  std::vector<int32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  for (const Face& f : mesh.faces) {
    for (int k = 1; k < f.size; ++k) {
      parent[FindRoot(parent, f.v[k])] = FindRoot(parent, f.v[0]);
    }
  }
  // Component index by root, in the order of each component's first face.
  std::vector<int32_t> index(nv, -1);
  Topology t;
  for (int32_t id = 0; id < static_cast<int32_t>(mesh.num_faces()); ++id) {
    int32_t& c = index[FindRoot(parent, mesh.faces[id].v[0])];
    if (c < 0) {
      c = static_cast<int32_t>(t.components.size());
      t.components.emplace_back().closed = true;
    }
    t.components[c].faces.push_back(id);
  }
  for (size_t i = 0, j = 0; i < uses.size(); i = j) {
    while (j < uses.size() && uses[j].key == uses[i].key) ++j;
    if (j - i == 2) continue;
    t.closed = false;
    t.boundary_edges += j - i == 1;
    t.shared_edges += j - i > 2;
    if (j - i == 1) {
      t.boundary_vertices.push_back(EdgeKeyVertex(uses[i].key, mesh.dimension));
      if (mesh.dimension == 3) {
        t.boundary_vertices.push_back(
            static_cast<int32_t>(uses[i].key & 0xffffffffu));
      }
    }
    const int32_t v = EdgeKeyVertex(uses[i].key, mesh.dimension);
    Component& c = t.components[index[FindRoot(parent, v)]];
    c.closed = false;
    c.boundary_edges += j - i == 1;
  }
  for (Component& c : t.components) {
    c.signed_volume = SignedVolumeOfFaces(mesh, c.faces);
  }
  const std::vector<int32_t> depths = NestingDepths(mesh, t.components);
  for (size_t i = 0; i < depths.size(); ++i) {
    t.components[i].nesting_depth = depths[i];
  }
  return t;
}

// A polygon's corners in cyclic order starting at its smallest index
// (padded with -1): equal for two faces exactly when they are the same
// polygon with the same orientation.
using CyclicKey = std::array<int32_t, 4>;

CyclicKey Cyclic(const Face& f) {
  const int start = static_cast<int>(
      std::min_element(f.v.begin(), f.v.begin() + f.size) - f.v.begin());
  CyclicKey key = {-1, -1, -1, -1};
  for (int k = 0; k < f.size; ++k) key[k] = f.v[(start + k) % f.size];
  return key;
}

// Faces that have another face with the same corners in the opposite
// cyclic order (double-sided), by one sort: each face's key and its
// reverse's share the smaller of the two (`canonical`), so a face's
// opposites are the other orientation in its run of equal canonical keys.
// Precondition: no face repeats a vertex (ValidateMesh), so a face's key
// and its reverse's differ.
int64_t CountDoubleSidedFaces(const Mesh& mesh) {
  enum Orientation : int8_t { kForward, kBackward };
  struct Keyed {
    CyclicKey canonical;
    Orientation orientation;
  };
  // Grouped by the canonical key's first (smallest) corner, then sorted.
  const std::vector<Keyed> keys = BucketSorted<Keyed>(
      mesh.num_vertices(),
      [&mesh](auto&& emit) {
        for (const Face& f : mesh.faces) {
          if (f.size == 2) continue;
          Face reversed = f;
          ReverseFace(reversed);
          const CyclicKey k = Cyclic(f), r = Cyclic(reversed);
          const Keyed keyed = k < r ? Keyed{k, kForward} : Keyed{r, kBackward};
          emit(keyed.canonical[0], keyed);
        }
      },
      [](const Keyed& a, const Keyed& b) { return a.canonical < b.canonical; });
  int64_t count = 0;
  for (size_t i = 0, j = 0; i < keys.size(); i = j) {
    int64_t n[2] = {0, 0};
    for (; j < keys.size() && keys[j].canonical == keys[i].canonical; ++j) {
      ++n[keys[j].orientation];
    }
    count += (n[kBackward] > 0 ? n[kForward] : 0) +
             (n[kForward] > 0 ? n[kBackward] : 0);
  }
  return count;
}

// Pairs of faces sharing an edge (2D: a vertex) used by exactly these two,
// and whether they traverse it in the same direction (then they disagree).
struct FacePair {
  int32_t a, b;
  bool same_direction;
};

std::vector<FacePair> ManifoldNeighbours(const std::vector<EdgeUse>& uses) {
  std::vector<FacePair> pairs;
  for (size_t i = 0, j = 0; i < uses.size(); i = j) {
    while (j < uses.size() && uses[j].key == uses[i].key) ++j;
    if (j - i != 2 || uses[i].face == uses[i + 1].face) continue;
    pairs.push_back({uses[i].face, uses[i + 1].face,
                     uses[i].forward == uses[i + 1].forward});
  }
  return pairs;
}

}  // namespace

std::vector<Component> ConnectedComponents(const Mesh& mesh) {
  return AnalyzeTopology(mesh, SortedEdgeUses(mesh)).components;
}

namespace {

// How many of `vertices` (repeats counted once) share their exact position
// with another of them. O(n log n).
int64_t CountCoincident(const std::vector<Vec3>& positions,
                        std::vector<int32_t> vertices) {
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  auto less = [&](int32_t a, int32_t b) {
    const Vec3 &p = positions[a], &q = positions[b];
    return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z);
  };
  std::sort(vertices.begin(), vertices.end(), less);
  int64_t count = 0;
  for (size_t i = 0, j = 0; i < vertices.size(); i = j) {
    while (j < vertices.size() &&
           positions[vertices[j]] == positions[vertices[i]]) {
      ++j;
    }
    if (j - i > 1) count += static_cast<int64_t>(j - i);
  }
  return count;
}

void AddOrientationWarnings(const Mesh& mesh, MeshDiagnostics& d);
void AddShapeWarnings(const Mesh& mesh, MeshDiagnostics& d);

// DiagnoseMesh from the mesh's topology, manifold neighbours and count of
// double-sided faces.
MeshDiagnostics Diagnose(const Mesh& mesh, const Topology& t,
                         const std::vector<FacePair>& pairs,
                         int64_t double_sided_faces) {
  MeshDiagnostics d;
  d.components = std::ssize(t.components);
  d.closed = t.closed;
  for (size_t i = 0; i < t.components.size(); ++i) {
    const Component& c = t.components[i];
    if (c.inverted()) {
      d.inward_components.push_back(static_cast<int64_t>(i));
      d.inward_component_faces.push_back(std::ssize(c.faces));
    }
  }
  d.double_sided_faces = double_sided_faces;
  d.boundary_edges = t.boundary_edges;
  d.shared_edges = t.shared_edges;
  d.coincident_boundary_vertices =
      CountCoincident(mesh.positions, t.boundary_vertices);
  std::vector<int32_t> component_of(mesh.faces.size());
  for (size_t i = 0; i < t.components.size(); ++i) {
    for (int32_t f : t.components[i].faces)
      component_of[f] = static_cast<int32_t>(i);
  }
  std::vector<char> inconsistent(t.components.size(), 0);
  for (const FacePair& p : pairs) {
    if (!p.same_direction) continue;
    ++d.inconsistent_edges;
    inconsistent[component_of[p.a]] = 1;
  }
  for (size_t i = 0; i < inconsistent.size(); ++i) {
    if (inconsistent[i])
      d.inconsistent_components.push_back(static_cast<int64_t>(i));
  }
  AddOrientationWarnings(mesh, d);
  AddShapeWarnings(mesh, d);
  return d;
}

// d's warnings about the faces' orientation: inward components,
// inconsistent edges, double-sided faces.
void AddOrientationWarnings(const Mesh& mesh, MeshDiagnostics& d) {
  if (!d.inward_components.empty()) {
    d.warnings.push_back(absl::StrCat(
        d.inward_components.size(), " of ", d.components,
        " components are closed and turned inside out (faces point into "
        "the solid: an outer shell with negative signed volume, or a "
        "cavity's shell facing out of its cavity; INWARD cones look out of "
        "the material): components ",
        absl::StrJoin(d.inward_components, ", "), " with ",
        absl::StrJoin(d.inward_component_faces, ", "),
        " faces; reorienting (--reorient, reorient=True) flips exactly those"));
  }
  if (d.inconsistent_edges > 0) {
    d.warnings.push_back(absl::StrCat(
        d.inconsistent_edges,
        mesh.dimension == 2 ? " vertices join" : " edges join",
        " faces of disagreeing orientation (used twice in the same "
        "direction) in components ",
        absl::StrJoin(d.inconsistent_components, ", "),
        ": normals there are wrong or cancel; reorienting (--reorient, "
        "reorient=True) makes each "
        "component consistent"));
  }
  if (d.double_sided_faces > 0) {
    d.warnings.push_back(
        absl::StrCat(d.double_sided_faces,
                     " faces have a coincident face of opposite orientation (a "
                     "double-sided surface): their vertex normals cancel "
                     "(DEGENERATE_NORMAL)"));
  }
}

// d's warnings about the mesh's size and connectivity: tiny coordinates,
// holes, unwelded seams, non-manifold edges.
void AddShapeWarnings(const Mesh& mesh, MeshDiagnostics& d) {
  // Below this bounding-box extent, squared lengths and cross products
  // underflow double precision (subnormal or zero). The extent is the
  // largest side, not the diagonal, whose squares would underflow too.
  constexpr double kTinyExtent = 1e-150;
  if (const double extent = BoundingExtent(mesh);
      extent > 0 && extent < kTinyExtent) {
    d.warnings.push_back(absl::StrCat(
        "the coordinates are tiny (bounding box ", extent,
        " across): squared lengths underflow double precision, so normals "
        "and areas degenerate (DEGENERATE_NORMAL); scale the mesh up"));
  } else if (extent > 0 && extent < kMinTracedExtent) {
    d.warnings.push_back(
        absl::StrCat("the mesh is tiny: ", TooSmallToTrace(extent)));
  }
  if (d.boundary_edges > 0) {
    d.warnings.push_back(
        absl::StrCat("the mesh is open: ", d.boundary_edges,
                     mesh.dimension == 2 ? " curve ends" : " boundary edges",
                     "; rays may escape through the holes (NO_HIT)"));
  }
  if (d.coincident_boundary_vertices > 0) {
    d.warnings.push_back(absl::StrCat(
        d.coincident_boundary_vertices,
        " boundary vertices have exactly the position of another (unwelded "
        "seams, as texture seams leave them): welded, those boundaries would "
        "join; weld the duplicates before measuring (e.g. trimesh's "
        "merge_vertices, MeshLab's Merge Close Vertices)"));
  }
  if (d.shared_edges > 0) {
    d.warnings.push_back(absl::StrCat(
        d.shared_edges,
        mesh.dimension == 2 ? " vertices are shared by more than two segments"
                            : " edges are shared by more than two faces",
        " (non-manifold: duplicated, double-sided or touching faces): normals "
        "there may cancel or point astray"));
  }
}

// Makes each patch of faces joined by manifold edges agree with the larger
// side (ties: with its lowest face), counting in `r`; keeps the pairs'
// directions up to date. Returns, per component, whether a face in it was
// reversed.
std::vector<char> MakeConsistent(Mesh& mesh, const Topology& t,
                                 std::vector<FacePair>& pairs,
                                 Reorientation& r) {
  const int32_t nf = static_cast<int32_t>(mesh.num_faces());
  // Neighbours of each face (CSR) with the parity between them.
  std::vector<int32_t> offsets(nf + 1, 0);
  for (const FacePair& p : pairs) {
    ++offsets[p.a + 1];
    ++offsets[p.b + 1];
  }
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  std::vector<std::pair<int32_t, bool>> adjacent(offsets[nf]);
  {
    std::vector<int32_t> next(offsets.begin(), offsets.end() - 1);
    for (const FacePair& p : pairs) {
      adjacent[next[p.a]++] = {p.b, p.same_direction};
      adjacent[next[p.b]++] = {p.a, p.same_direction};
    }
  }
  // Each patch: faces reached through manifold edges from its lowest face,
  // with their parity (1: reverse to agree with that face).
  std::vector<int8_t> parity(nf, -1);
  std::vector<int32_t> patch;
  std::vector<int32_t> component_of(nf);
  std::vector<char> reversed(nf, 0);
  for (size_t i = 0; i < t.components.size(); ++i) {
    for (int32_t f : t.components[i].faces)
      component_of[f] = static_cast<int32_t>(i);
  }
  std::vector<char> changed(t.components.size(), 0),
      conflict(t.components.size(), 0);
  for (int32_t seed = 0; seed < nf; ++seed) {
    if (parity[seed] >= 0) continue;
    patch.assign(1, seed);
    parity[seed] = 0;
    int64_t ones = 0;
    for (size_t head = 0; head < patch.size(); ++head) {
      const int32_t f = patch[head];
      for (int32_t k = offsets[f]; k < offsets[f + 1]; ++k) {
        const auto [g, same] = adjacent[k];
        const int8_t want = parity[f] ^ (same ? 1 : 0);
        if (parity[g] < 0) {
          parity[g] = want;
          ones += want;
          patch.push_back(g);
        } else if (parity[g] != want) {
          conflict[component_of[f]] = 1;
        }
      }
    }
    // Reverse the smaller side (ties: keep the seed's orientation).
    const int8_t flip = 2 * ones > std::ssize(patch) ? 0 : 1;
    for (int32_t f : patch) {
      if (parity[f] != flip) continue;
      ReverseFace(mesh.faces[f]);
      reversed[f] = 1;
      ++r.faces_made_consistent;
      changed[component_of[f]] = 1;
    }
  }
  for (size_t i = 0; i < changed.size(); ++i) {
    r.components_made_consistent += changed[i];
    r.non_orientable_components += conflict[i];
  }
  // Reversing faces keeps the components; it changes their volumes and the
  // direction of pairs with one reversed face.
  for (FacePair& p : pairs) p.same_direction ^= reversed[p.a] != reversed[p.b];
  return changed;
}

// ReorientComponents from the mesh's topology and manifold neighbours,
// which it keeps up to date (signed volumes, pair directions).
Reorientation Reorient(Mesh& mesh, Topology& t, std::vector<FacePair>& pairs) {
  Reorientation r;
  // With every manifold edge joining agreeing faces, each patch keeps its
  // lowest face's orientation and nothing conflicts: the propagation (a
  // neighbour list and a walk over every face) would change nothing.
  const std::vector<char> changed =
      std::any_of(pairs.begin(), pairs.end(),
                  [](const FacePair& p) { return p.same_direction; })
          ? MakeConsistent(mesh, t, pairs, r)
          : std::vector<char>(t.components.size(), 0);
  for (size_t i = 0; i < changed.size(); ++i) {
    Component& c = t.components[i];
    if (changed[i]) c.signed_volume = SignedVolumeOfFaces(mesh, c.faces);
    if (!c.inverted()) continue;
    for (int32_t id : c.faces) ReverseFace(mesh.faces[id]);
    c.signed_volume = SignedVolumeOfFaces(mesh, c.faces);
    ++r.components_turned_outward;
  }
  return r;
}

// The mesh's topology and manifold neighbours (AnalyzeEdges), and its count
// of double-sided faces (Analyze: beside them, as both sorts read the mesh
// only; a third of the checks' time on a million vertices).
struct Analysis {
  Topology topology;
  std::vector<FacePair> pairs;
  int64_t double_sided_faces = 0;
};
Analysis AnalyzeEdges(const Mesh& mesh) {
  const std::vector<EdgeUse> uses = SortedEdgeUses(mesh);
  Analysis a;
  a.topology = AnalyzeTopology(mesh, uses);
  a.pairs = ManifoldNeighbours(uses);
  return a;
}
Analysis Analyze(const Mesh& mesh) {
  Analysis a;
  int64_t double_sided = 0;
  tbb::parallel_invoke([&] { double_sided = CountDoubleSidedFaces(mesh); },
                       [&] { a = AnalyzeEdges(mesh); });
  a.double_sided_faces = double_sided;
  return a;
}

}  // namespace

MeshDiagnostics DiagnoseMesh(const Mesh& mesh) {
  const Analysis a = Analyze(mesh);
  return Diagnose(mesh, a.topology, a.pairs, a.double_sided_faces);
}

Reorientation ReorientComponents(Mesh& mesh) {
  Analysis a = AnalyzeEdges(mesh);
  return Reorient(mesh, a.topology, a.pairs);
}

MeshDiagnostics ReorientAndDiagnose(Mesh& mesh, Reorientation* reorientation) {
  Analysis a = Analyze(mesh);
  *reorientation = Reorient(mesh, a.topology, a.pairs);
  // Faces turned within a component may make or unmake double-sided pairs:
  // counted again. (A pair's faces share their corners, so a component
  // turned outward turns both.)
  if (reorientation->faces_made_consistent > 0) {
    a.double_sided_faces = CountDoubleSidedFaces(mesh);
  }
  return Diagnose(mesh, a.topology, a.pairs, a.double_sided_faces);
}

}  // namespace meshgauge
