#include "lib/core/shapes.h"

#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <tuple>

namespace meshgauge {
namespace {

constexpr double kPi = std::numbers::pi;

// Appends the polygon through `points` (closed) as segments.
void AppendLoop(Mesh& mesh, const std::vector<Vec3>& points, int32_t region) {
  const int32_t base = static_cast<int32_t>(mesh.positions.size());
  const int32_t n = static_cast<int32_t>(points.size());
  for (const Vec3& p : points) mesh.positions.push_back(p);
  for (int32_t i = 0; i < n; ++i) {
    mesh.faces.push_back(Face::Segment(base + i, base + (i + 1) % n));
    mesh.face_regions.push_back(region);
  }
}

}  // namespace

Mesh MakeCircle(double radius, int segments) {
  Mesh mesh;
  mesh.dimension = 2;
  std::vector<Vec3> pts;
  for (int i = 0; i < segments; ++i) {
    const double a = 2 * kPi * i / segments;
    pts.push_back({radius * std::cos(a), radius * std::sin(a), 0});
  }
  AppendLoop(mesh, pts, 0);
  mesh.face_regions.clear();
  return mesh;
}

Mesh MakeIcosphere(double radius, int frequency) {
  const double g = (1 + std::sqrt(5.0)) / 2;
  const std::array<Vec3, 12> ico = {{{-1, g, 0},
                                     {1, g, 0},
                                     {-1, -g, 0},
                                     {1, -g, 0},
                                     {0, -1, g},
                                     {0, 1, g},
                                     {0, -1, -g},
                                     {0, 1, -g},
                                     {g, 0, -1},
                                     {g, 0, 1},
                                     {-g, 0, -1},
                                     {-g, 0, 1}}};
  const int tris[20][3] = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10},
                           {0, 10, 11}, {1, 5, 9},  {5, 11, 4}, {11, 10, 2},
                           {10, 7, 6},  {7, 1, 8},  {3, 9, 4},  {3, 4, 2},
                           {3, 2, 6},   {3, 6, 8},  {3, 8, 9},  {4, 9, 5},
                           {2, 4, 11},  {6, 2, 10}, {8, 6, 7},  {9, 8, 1}};
  Mesh mesh;
  // Points are identified by their integer barycentric lattice position on
  // an icosahedron edge or face so shared points are shared vertices.
  std::map<std::array<int, 6>, int32_t> index;
  auto vertex = [&](int a, int b, int c, int i, int j) -> int32_t {
    const int k = frequency - i - j;
    // Canonical key: sort (corner, weight) pairs by corner id.
    std::array<std::pair<int, int>, 3> w = {
        {{i == 0 ? -1 : a, i}, {j == 0 ? -1 : b, j}, {k == 0 ? -1 : c, k}}};
    std::sort(w.begin(), w.end());
    std::array<int, 6> key{};
    int n = 0;
    for (auto [corner, weight] : w) {
      key[n++] = corner;
      key[n++] = weight;
    }
    auto it = index.find(key);
    if (it != index.end()) return it->second;
    const Vec3 p = (ico[a] * i + ico[b] * j + ico[c] * k) / frequency;
    mesh.positions.push_back(p * (radius / Norm(p)));
    const int32_t id = static_cast<int32_t>(mesh.positions.size() - 1);
    index[key] = id;
    return id;
  };
  for (const auto& t : tris) {
    for (int i = 0; i < frequency; ++i) {
      for (int j = 0; j + i < frequency; ++j) {
        // Lattice point (i, j): weights f-i-j on t[0], i on t[1], j on t[2].
        const int32_t p0 = vertex(t[0], t[1], t[2], frequency - i - j, i);
        const int32_t p1 =
            vertex(t[0], t[1], t[2], frequency - i - j - 1, i + 1);
        const int32_t p2 = vertex(t[0], t[1], t[2], frequency - i - j - 1, i);
        mesh.faces.push_back(Face::Triangle(p0, p1, p2));
        if (i + j + 1 < frequency) {
          const int32_t p3 =
              vertex(t[0], t[1], t[2], frequency - i - j - 2, i + 1);
          mesh.faces.push_back(Face::Triangle(p2, p1, p3));
        }
      }
    }
  }
  // Orient outward.
  for (Face& f : mesh.faces) {
    const Vec3& a = mesh.positions[f.v[0]];
    const Vec3 n =
        Cross(mesh.positions[f.v[1]] - a, mesh.positions[f.v[2]] - a);
    if (Dot(n, a) < 0) std::swap(f.v[1], f.v[2]);
  }
  return mesh;
}

Mesh MakeFanCone(int rim) {
  Mesh m;
  m.positions = {{0, 0, 1}, {0, 0, 0}};
  for (int i = 0; i < rim; ++i) {
    const double a = 2 * M_PI * i / rim;
    m.positions.push_back({std::cos(a), std::sin(a), 0});
  }
  for (int i = 0; i < rim; ++i) {
    const int32_t r = 2 + i, s = 2 + (i + 1) % rim;
    m.faces.push_back(Face::Triangle(0, r, s));
    m.faces.push_back(Face::Triangle(1, s, r));
  }
  return m;
}

Mesh MakeFanCylinder(int rim) {
  Mesh m;
  m.positions = {{0, 0, 0}, {0, 0, 1}};
  for (int level = 0; level < 2; ++level) {
    for (int i = 0; i < rim; ++i) {
      const double a = 2 * M_PI * i / rim;
      m.positions.push_back({std::cos(a), std::sin(a), double(level)});
    }
  }
  for (int i = 0; i < rim; ++i) {
    const int32_t r = 2 + i, s = 2 + (i + 1) % rim;
    const int32_t rt = r + rim, st = s + rim;
    m.faces.push_back(Face::Triangle(0, s, r));
    m.faces.push_back(Face::Triangle(1, rt, st));
    m.faces.push_back(Face::Triangle(r, s, st));
    m.faces.push_back(Face::Triangle(r, st, rt));
  }
  return m;
}

Mesh MakeTorus(double major_radius, double minor_radius, int nu, int nv) {
  Mesh mesh;
  for (int i = 0; i < nu; ++i) {
    const double u = 2 * kPi * i / nu;
    for (int j = 0; j < nv; ++j) {
      const double v = 2 * kPi * j / nv;
      const double rr = major_radius + minor_radius * std::cos(v);
      mesh.positions.push_back(
          {rr * std::cos(u), rr * std::sin(u), minor_radius * std::sin(v)});
    }
  }
  auto id = [&](int i, int j) { return ((i % nu) * nv) + (j % nv); };
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const int32_t a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1),
                    d = id(i, j + 1);
      mesh.faces.push_back(Face::Triangle(a, b, c));
      mesh.faces.push_back(Face::Triangle(a, c, d));
    }
  }
  return mesh;
}

Mesh MakeVoxelSolid(const std::array<int, 3>& cells,
                    const std::array<double, 3>& spacing,
                    const std::function<bool(int, int, int)>& filled,
                    bool quads) {
  Mesh mesh;
  std::map<std::tuple<int, int, int>, int32_t> index;
  auto vertex = [&](const int g[3]) {
    auto key = std::make_tuple(g[0], g[1], g[2]);
    auto [it, inserted] = index.try_emplace(key, 0);
    if (inserted) {
      mesh.positions.push_back(
          {spacing[0] * g[0], spacing[1] * g[1], spacing[2] * g[2]});
      it->second = static_cast<int32_t>(mesh.positions.size() - 1);
    }
    return it->second;
  };
  auto solid = [&](int i, int j, int k) {
    return i >= 0 && j >= 0 && k >= 0 && i < cells[0] && j < cells[1] &&
           k < cells[2] && filled(i, j, k);
  };
  for (int a = 0; a < 3; ++a) {
    // (b, c) with b x c = +a; the low side is flipped so normals point out.
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      for (int i = 0; i < cells[0]; ++i) {
        for (int j = 0; j < cells[1]; ++j) {
          for (int k = 0; k < cells[2]; ++k) {
            int cell[3] = {i, j, k};
            int next[3] = {i, j, k};
            next[a] += side == 0 ? -1 : 1;
            if (!solid(i, j, k) || solid(next[0], next[1], next[2])) continue;
            int32_t q[4];
            const int db[4] = {0, 1, 1, 0}, dc[4] = {0, 0, 1, 1};
            for (int n = 0; n < 4; ++n) {
              int g[3];
              g[a] = cell[a] + side;
              g[b] = cell[b] + db[n];
              g[c] = cell[c] + dc[n];
              q[n] = vertex(g);
            }
            if (quads) {
              mesh.faces.push_back(side == 0
                                       ? Face::Quad(q[0], q[3], q[2], q[1])
                                       : Face::Quad(q[0], q[1], q[2], q[3]));
            } else if (side == 0) {
              mesh.faces.push_back(Face::Triangle(q[0], q[2], q[1]));
              mesh.faces.push_back(Face::Triangle(q[0], q[3], q[2]));
            } else {
              mesh.faces.push_back(Face::Triangle(q[0], q[1], q[2]));
              mesh.faces.push_back(Face::Triangle(q[0], q[2], q[3]));
            }
          }
        }
      }
    }
  }
  return mesh;
}

Mesh MakeBox(double sx, double sy, double sz, double cell, bool quads) {
  const double size[3] = {sx, sy, sz};
  std::array<int, 3> n;
  std::array<double, 3> spacing;
  for (int a = 0; a < 3; ++a) {
    n[a] = std::max(1, static_cast<int>(std::ceil(size[a] / cell)));
    spacing[a] = size[a] / n[a];
  }
  return MakeVoxelSolid(
      n, spacing, [](int, int, int) { return true; }, quads);
}

Mesh MakeHollowSquare(double side, double hole_radius, double h) {
  Mesh mesh;
  mesh.dimension = 2;
  const int per_side = std::max(2, static_cast<int>(std::ceil(side / h)));
  std::vector<Vec3> outer;
  const double half = side / 2;
  const Vec3 corners[4] = {
      {-half, -half, 0}, {half, -half, 0}, {half, half, 0}, {-half, half, 0}};
  for (int s = 0; s < 4; ++s) {
    for (int i = 0; i < per_side; ++i) {
      outer.push_back(corners[s] + (corners[(s + 1) % 4] - corners[s]) *
                                       (static_cast<double>(i) / per_side));
    }
  }
  AppendLoop(mesh, outer, 0);
  // An odd count puts a segment, not a vertex, opposite every hole vertex.
  const int around =
      std::max(8, static_cast<int>(std::ceil(2 * kPi * hole_radius / h))) | 1;
  std::vector<Vec3> hole;
  for (int i = 0; i < around; ++i) {
    const double a = -2 * kPi * i / around;  // clockwise.
    hole.push_back({hole_radius * std::cos(a), hole_radius * std::sin(a), 0});
  }
  AppendLoop(mesh, hole, 1);
  mesh.region_directions[1] = ConeDirection::kOutward;
  return mesh;
}

}  // namespace meshgauge
