#include "lib/core/weld.h"

#include <bit>
#include <cmath>
#include <tuple>

#include "absl/container/flat_hash_map.h"
#include "absl/strings/str_cat.h"
#include "lib/core/box.h"

namespace meshgauge {
namespace {

using Cell = std::tuple<int64_t, int64_t, int64_t>;

// -0 and +0 are the same coordinate.
Vec3 Canonical(const Vec3& p) { return {p.x + 0.0, p.y + 0.0, p.z + 0.0}; }

bool Finite(const Vec3& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

// new_index[v] for every vertex, merging exact duplicates.
std::vector<int32_t> ExactGroups(const std::vector<Vec3>& positions) {
  absl::flat_hash_map<Cell, int32_t> first;  // the coordinates' bits.
  first.reserve(positions.size());
  std::vector<int32_t> target(positions.size());
  for (size_t v = 0; v < positions.size(); ++v) {
    const Vec3 p = Canonical(positions[v]);
    target[v] = static_cast<int32_t>(v);
    if (!Finite(p)) continue;
    const Cell key{std::bit_cast<int64_t>(p.x), std::bit_cast<int64_t>(p.y),
                   std::bit_cast<int64_t>(p.z)};
    target[v] = first.try_emplace(key, static_cast<int32_t>(v)).first->second;
  }
  return target;
}

// The same within `distance`, on a grid of cells of that size.
std::vector<int32_t> NearGroups(const std::vector<Vec3>& positions,
                                const Vec3& origin, double distance) {
  absl::flat_hash_map<Cell, std::vector<int32_t>> kept;
  std::vector<int32_t> target(positions.size());
  auto cell_of = [&](const Vec3& p) {
    return Cell{static_cast<int64_t>(std::floor((p.x - origin.x) / distance)),
                static_cast<int64_t>(std::floor((p.y - origin.y) / distance)),
                static_cast<int64_t>(std::floor((p.z - origin.z) / distance))};
  };
  const double d2 = distance * distance;
  for (size_t v = 0; v < positions.size(); ++v) {
    const Vec3& p = positions[v];
    target[v] = static_cast<int32_t>(v);
    if (!Finite(p)) continue;
    const auto [cx, cy, cz] = cell_of(p);
    int32_t best = -1;
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        for (int64_t dz = -1; dz <= 1; ++dz) {
          auto it = kept.find(Cell{cx + dx, cy + dy, cz + dz});
          if (it == kept.end()) continue;
          for (int32_t k : it->second) {
            if ((best < 0 || k < best) && Dot(positions[k] - p, positions[k] - p) <= d2) {
              best = k;
            }
          }
        }
      }
    }
    if (best >= 0) {
      target[v] = best;
    } else {
      kept[Cell{cx, cy, cz}].push_back(static_cast<int32_t>(v));
    }
  }
  return target;
}

}  // namespace

absl::StatusOr<Weld> WeldVertices(Mesh& mesh, double relative_tolerance) {
  if (!(relative_tolerance == 0 ||
        (relative_tolerance >= kMinWeldTolerance &&
         relative_tolerance <= kMaxWeldTolerance))) {
    return absl::InvalidArgumentError(absl::StrCat(
        "weld tolerance must be 0 (exact duplicates) or in [",
        kMinWeldTolerance, ", ", kMaxWeldTolerance,
        "] (relative to the bounding box's diagonal), got ",
        relative_tolerance));
  }
  Box box;
  for (const Vec3& p : mesh.positions) {
    if (Finite(p)) box.Extend(p, p);
  }
  const double diagonal = mesh.positions.empty() ? 0 : Norm(box.hi - box.lo);
  const std::vector<int32_t> target =
      relative_tolerance == 0 || !(diagonal > 0)
          ? ExactGroups(mesh.positions)
          : NearGroups(mesh.positions, box.lo, relative_tolerance * diagonal);
  Weld weld;
  std::vector<int32_t> index(mesh.positions.size());
  std::vector<Vec3> kept;
  for (size_t v = 0; v < target.size(); ++v) {
    if (target[v] == static_cast<int32_t>(v)) {
      index[v] = static_cast<int32_t>(kept.size());
      kept.push_back(mesh.positions[v]);
    } else {
      index[v] = index[target[v]];  // target[v] < v: already numbered.
      ++weld.merged;
    }
  }
  if (weld.merged == 0) return weld;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    Face& face = mesh.faces[f];
    for (int k = 0; k < face.size; ++k) {
      for (int j = 0; j < k; ++j) {
        if (index[face.v[j]] == index[face.v[k]]) {
          return absl::InvalidArgumentError(absl::StrCat(
              "welding merges corners ", face.v[j], " and ", face.v[k],
              " of face ", f,
              " (they are within the weld tolerance of each other): weld "
              "with a smaller tolerance"));
        }
      }
    }
  }
  for (Face& face : mesh.faces) {
    for (int k = 0; k < face.size; ++k) face.v[k] = index[face.v[k]];
  }
  mesh.positions = std::move(kept);
  weld.welded_vertex = std::move(index);
  return weld;
}

std::vector<double> WeldWeights(const Weld& weld, std::vector<double> weights,
                                int64_t welded_vertices) {
  if (weld.welded_vertex.empty()) return weights;
  std::vector<double> out(welded_vertices, 0.0);
  for (size_t v = 0; v < weights.size(); ++v) {
    out[weld.welded_vertex[v]] += weights[v];
  }
  return out;
}

std::vector<int32_t> KeptInputVertices(const Weld& weld) {
  std::vector<int32_t> kept;
  for (size_t v = 0; v < weld.welded_vertex.size(); ++v) {
    if (weld.welded_vertex[v] == std::ssize(kept)) {
      kept.push_back(static_cast<int32_t>(v));
    }
  }
  return kept;
}

std::vector<Vec3> UnweldGradient(const Weld& weld,
                                 const std::vector<Vec3>& gradient) {
  if (weld.welded_vertex.empty()) return gradient;
  std::vector<Vec3> out(weld.welded_vertex.size());
  std::vector<char> given(gradient.size(), 0);
  for (size_t v = 0; v < out.size(); ++v) {
    const int32_t w = weld.welded_vertex[v];
    if (given[w]) continue;
    given[w] = 1;
    out[v] = gradient[w];
  }
  return out;
}

}  // namespace meshgauge
