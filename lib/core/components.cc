#include "lib/core/components.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <unordered_map>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace meshgauge {
namespace {

int32_t Find(std::vector<int32_t>& parent, int32_t v) {
  while (parent[v] != v) v = parent[v] = parent[parent[v]];
  return v;
}

uint64_t EdgeKey(int32_t a, int32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) |
         static_cast<uint32_t>(b);
}

// Uses of each undirected edge (3D) or vertex (2D) by the faces.
std::unordered_map<uint64_t, int> BoundaryUses(
    const Mesh& mesh, absl::Span<const int32_t> faces) {
  std::unordered_map<uint64_t, int> uses;
  for (int32_t id : faces) {
    const Face& f = mesh.faces[id];
    if (f.size == 2) {
      ++uses[static_cast<uint32_t>(f.v[0])];
      ++uses[static_cast<uint32_t>(f.v[1])];
      continue;
    }
    for (int k = 0; k < f.size; ++k)
      ++uses[EdgeKey(f.v[k], f.v[(k + 1) % f.size])];
  }
  return uses;
}

}  // namespace

std::vector<Component> ConnectedComponents(const Mesh& mesh) {
  std::vector<int32_t> parent(mesh.num_vertices());
  std::iota(parent.begin(), parent.end(), 0);
  for (const Face& f : mesh.faces) {
    for (int k = 1; k < f.size; ++k) {
      parent[Find(parent, f.v[k])] = Find(parent, f.v[0]);
    }
  }
  std::unordered_map<int32_t, size_t> index;
  std::vector<Component> out;
  for (int32_t id = 0; id < static_cast<int32_t>(mesh.num_faces()); ++id) {
    const int32_t root = Find(parent, mesh.faces[id].v[0]);
    auto [it, inserted] = index.try_emplace(root, out.size());
    if (inserted) out.emplace_back();
    out[it->second].faces.push_back(id);
  }
  for (Component& c : out) {
    const auto uses = BoundaryUses(mesh, c.faces);
    c.closed = std::all_of(uses.begin(), uses.end(),
                           [](const auto& e) { return e.second == 2; });
    c.signed_volume = SignedVolumeOfFaces(mesh, c.faces);
  }
  return out;
}

MeshDiagnostics DiagnoseMesh(const Mesh& mesh) {
  MeshDiagnostics d;
  const std::vector<Component> components = ConnectedComponents(mesh);
  d.components = std::ssize(components);
  for (size_t i = 0; i < components.size(); ++i) {
    const Component& c = components[i];
    if (c.closed && c.signed_volume < 0) {
      d.inward_components.push_back(static_cast<int64_t>(i));
      d.inward_component_faces.push_back(std::ssize(c.faces));
    }
  }
  // Double-sided: a face whose sorted corners match another face's, with
  // the opposite cyclic order.
  std::map<std::vector<int32_t>, std::vector<int32_t>> by_corners;
  for (int32_t id = 0; id < static_cast<int32_t>(mesh.num_faces()); ++id) {
    const Face& f = mesh.faces[id];
    if (f.size == 2) continue;
    std::vector<int32_t> key(f.v.begin(), f.v.begin() + f.size);
    std::sort(key.begin(), key.end());
    by_corners[key].push_back(id);
  }
  for (const auto& [key, ids] : by_corners) {
    if (ids.size() < 2) continue;
    for (int32_t a : ids) {
      Face reversed = mesh.faces[a];
      ReverseFace(reversed);
      bool opposite = false;
      for (int32_t b : ids) {
        if (b == a) continue;
        const Face& g = mesh.faces[b];
        // Same cyclic sequence as `reversed`, up to rotation.
        for (int r = 0; r < g.size && !opposite; ++r) {
          bool same = true;
          for (int k = 0; k < g.size && same; ++k) {
            same = g.v[(k + r) % g.size] == reversed.v[k];
          }
          opposite = same;
        }
      }
      d.double_sided_faces += opposite;
    }
  }
  std::vector<int32_t> all(mesh.faces.size());
  std::iota(all.begin(), all.end(), 0);
  for (const auto& [key, uses] : BoundaryUses(mesh, all)) {
    d.boundary_edges += uses == 1;
  }
  if (!d.inward_components.empty()) {
    d.warnings.push_back(absl::StrCat(
        d.inward_components.size(), " of ", d.components,
        " components are closed with negative signed volume (faces point "
        "into the solid, so INWARD cones look outside): components ",
        absl::StrJoin(d.inward_components, ", "), " with ",
        absl::StrJoin(d.inward_component_faces, ", "),
        " faces; --reorient flips exactly those"));
  }
  if (d.double_sided_faces > 0) {
    d.warnings.push_back(
        absl::StrCat(d.double_sided_faces,
                     " faces have a coincident face of opposite orientation (a "
                     "double-sided surface): their vertex normals cancel "
                     "(DEGENERATE_NORMAL)"));
  }
  // Below this bounding-box extent, squared lengths and cross products
  // underflow double precision (subnormal or zero). The extent is the
  // largest side, not the diagonal, whose squares would underflow too.
  constexpr double kTinyExtent = 1e-150;
  Vec3 lo = mesh.positions.empty() ? Vec3() : mesh.positions[0], hi = lo;
  for (const Vec3& p : mesh.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  if (const double extent =
          std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
      extent > 0 && extent < kTinyExtent) {
    d.warnings.push_back(absl::StrCat(
        "the coordinates are tiny (bounding box ", extent,
        " across): squared lengths underflow double precision, so normals "
        "and areas degenerate (DEGENERATE_NORMAL); scale the mesh up"));
  }
  if (d.boundary_edges > 0) {
    d.warnings.push_back(
        absl::StrCat("the mesh is open: ", d.boundary_edges,
                     mesh.dimension == 2 ? " curve ends" : " boundary edges",
                     "; rays may escape through the holes (NO_HIT)"));
  }
  return d;
}

int64_t ReorientInwardComponents(Mesh& mesh) {
  int64_t flipped = 0;
  for (const Component& c : ConnectedComponents(mesh)) {
    if (!c.closed || !(c.signed_volume < 0)) continue;
    for (int32_t id : c.faces) ReverseFace(mesh.faces[id]);
    ++flipped;
  }
  return flipped;
}

}  // namespace meshgauge
