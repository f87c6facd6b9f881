// Helpers shared by the tests.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "lib/core/shapes.h"
#include "lib/io/mesh_io.h"

namespace meshgauge::testing {

inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// True when both hold the same doubles, bit for bit (NaNs and signed zeros
// included).
// (memcmp is not called on empty vectors: their data() may be null.)
inline bool SameBits(const std::vector<double>& a,
                     const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() ||
          std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

// A double's bits (EXPECT_EQ on them tells NaNs and signed zeros apart).
inline uint64_t Bits(double v) { return std::bit_cast<uint64_t>(v); }

inline bool SameBits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  return a.size() == b.size() &&
         (a.empty() ||
          std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0);
}

inline absl::StatusCode Code(const absl::Status& s) { return s.code(); }
template <typename T>
absl::StatusCode Code(const absl::StatusOr<T>& s) {
  return s.status().code();
}

// A file's bytes ("" when it cannot be read).
inline std::string Slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Moves every vertex radially by a deterministic pseudo-random fraction of
// up to `amount`: on a symmetric mesh a ray or ball meets several faces at
// once, or a face exactly at a corner or edge (a true non-differentiable
// event), and any perturbation resolves it.
inline Mesh Jitter(Mesh m, double amount) {
  for (size_t i = 0; i < m.positions.size(); ++i) {
    m.positions[i] *= 1 + amount * std::sin(12.9898 * i + 78.233 * i * i);
  }
  return m;
}

// `mesh` (triangles) with every face a second time, the copy's corners
// rotated: every hit ties with the copy's, at a double-precision distance
// that may differ in its last bit.
inline Mesh WithEveryFaceTwice(Mesh mesh) {
  const size_t nf = mesh.faces.size();
  for (size_t f = 0; f < nf; ++f) {
    Face copy = mesh.faces[f];
    std::rotate(copy.v.begin(), copy.v.begin() + 1, copy.v.begin() + 3);
    mesh.faces.push_back(copy);
  }
  return mesh;
}

// The vertices of `mesh` within `radius` of vertex `centre` (a connected
// patch on a smooth part), ascending.
inline std::vector<int32_t> Patch(const Mesh& mesh, int64_t centre,
                                  double radius) {
  std::vector<int32_t> patch;
  const Vec3 c = mesh.positions[centre];
  for (int64_t v = 0; v < mesh.num_vertices(); ++v) {
    const Vec3 d = mesh.positions[v] - c;
    if (Dot(d, d) < radius * radius) patch.push_back(static_cast<int32_t>(v));
  }
  return patch;
}

// A cube of six grids, each with vertices of its own (an unwelded export:
// every edge of the cube is a seam).
inline Mesh SixGridCube() {
  const Mesh box = MakeBox(1, 1, 1, 0.25, /*quads=*/true);
  Mesh out;
  // Faces of one side share a normal: group by it, copy each group's
  // vertices.
  std::map<std::tuple<double, double, double>, std::map<int32_t, int32_t>>
      sides;
  for (const Face& f : box.faces) {
    const Vec3 n = Cross(box.positions[f.v[1]] - box.positions[f.v[0]],
                         box.positions[f.v[2]] - box.positions[f.v[0]]);
    auto& copy = sides[{std::round(n.x / Norm(n)), std::round(n.y / Norm(n)),
                        std::round(n.z / Norm(n))}];
    Face g = f;
    for (int k = 0; k < f.size; ++k) {
      auto [it, added] = copy.try_emplace(f.v[k], 0);
      if (added) {
        it->second = static_cast<int32_t>(out.positions.size());
        out.positions.push_back(box.positions[f.v[k]]);
      }
      g.v[k] = it->second;
    }
    out.faces.push_back(g);
  }
  return out;
}

// data/meshes/NAME (MESHGAUGE_MESH_DIR as configured at build time): one of
// the public test meshes the repository holds (data/meshes/README.md).
inline std::string SharedMesh(const std::string& name) {
  // Appended rather than std::string(...) + "/" + name: GCC 12 warns of the
  // latter (-Warray-bounds, a false positive) where it is inlined.
  std::string path = MESHGAUGE_MESH_DIR "/";
  path += name;
  return path;
}

// The decimated knight (502 vertices) of the test meshes.
inline Mesh Knight() { return *ReadMesh(SharedMesh("decimated-knight.off")); }

// Closed form D_est(alpha, K) of SPEC §9 for diameter 1, computed here
// independently of lib/: every ray at angle theta has the chord cos(theta);
// the chords go through the median +- kappa sigma filter and the
// 1/max(theta, theta_min) weights.
inline double ClosedFormEstimate(int dimension, double alpha_degrees, int rays,
                                 double kappa = 1.0) {
  const double a = alpha_degrees * std::numbers::pi / 180;
  std::vector<double> theta(rays), chord(rays);
  for (int k = 0; k < rays; ++k) {
    theta[k] = dimension == 2
                   ? std::abs(-a / 2 + a * (k + 0.5) / rays)
                   : std::acos(1 - (k + 0.5) * (1 - std::cos(a / 2)) / rays);
    chord[k] = std::cos(theta[k]);
  }
  std::vector<double> sorted = chord;
  std::sort(sorted.begin(), sorted.end());
  const double median = rays % 2
                            ? sorted[rays / 2]
                            : (sorted[rays / 2 - 1] + sorted[rays / 2]) / 2;
  double mean = 0;
  for (double c : chord) mean += c / rays;
  double var = 0;
  for (double c : chord) var += (c - mean) * (c - mean) / rays;
  const double sigma = std::sqrt(var);
  const double theta_min = a / (2.0 * rays);
  double num = 0, den = 0;
  for (int k = 0; k < rays; ++k) {
    if (std::abs(chord[k] - median) > kappa * sigma + 1e-12 * median) continue;
    const double w = 1 / std::max(theta[k], theta_min);
    num += w * chord[k];
    den += w;
  }
  return num / den;
}

}  // namespace meshgauge::testing
