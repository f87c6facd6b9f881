// Counts for a cone traversal (issue 52), before writing one: on a sample
// of each mesh's vertices, with the pass's cone (K rays within the cone
// angle around the inward normal), in one binary BVH of the mesh's
// triangles (leaves of up to 4, median splits; both walks use it):
//   per ray   the boxes and triangles a closest-hit walk (nearer child
//             first) tests, times K: today's work, a walk per ray;
//   per cone  the boxes a single walk for the whole cone tests (box against
//             the cone truncated at its rays' farthest hit, through the
//             box's bounding sphere: conservative) and the triangles in the
//             leaves it reaches: the candidates every ray would be tested
//             against, 8 rays at a time.
//   8 wide    a single walk for all K rays, each truncated at its own hit:
//             a box is entered when some ray meets it, tested against 8 rays
//             at a time, and a leaf's triangles against the rays that met
//             it, 8 at a time.
// The "work" columns count one box or one triangle test of one ray (or of 8
// rays at once) as 1 and a cone-box test as 2; a ratio is per-ray work over
// the other's: what sharing one walk could gain over per-ray walks of the
// same tree (Embree's 8-wide BVH tests 8 boxes of one ray at once, so the
// gain over Embree is smaller).
//   meshgauge_cone_count_bench [--rays K] [--cone_angle DEG] [--sample N]
//                              MESH...
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "bench/bench_mesh.h"
#include "lib/core/box.h"
#include "lib/core/mesh_geometry.h"
#include "lib/core/normals.h"
#include "lib/core/topology.h"
#include "server/flags_help.h"

ABSL_FLAG(int, rays, 100, "rays per vertex (K)");
ABSL_FLAG(double, cone_angle, 30, "full cone opening angle, degrees");
ABSL_FLAG(int, sample, 2000, "vertices measured per mesh (evenly spaced)");

namespace meshgauge {
namespace {

struct Tri {
  Vec3 p[3];
  int32_t prim;
};

struct Node {
  Box box;
  int32_t first = 0, count = 0;  // leaf: count > 0.
  int32_t right = 0;             // internal: left child is the next node.
};

class Bvh {
 public:
  explicit Bvh(std::vector<Tri> tris) : tris_(std::move(tris)) {
    nodes_.reserve(tris_.size());
    Build(0, static_cast<int32_t>(tris_.size()));
  }
  const std::vector<Node>& nodes() const { return nodes_; }
  const std::vector<Tri>& tris() const { return tris_; }

 private:
  int32_t Build(int32_t first, int32_t count) {
    const auto index = static_cast<int32_t>(nodes_.size());
    nodes_.emplace_back();
    Box box, centres;
    for (int32_t i = first; i < first + count; ++i) {
      const Tri& t = tris_[i];
      for (const Vec3& p : t.p) box.Extend(p, p);
      const Vec3 c = (t.p[0] + t.p[1] + t.p[2]) * (1.0 / 3);
      centres.Extend(c, c);
    }
    nodes_[index].box = box;
    if (count <= 4) {
      nodes_[index].first = first;
      nodes_[index].count = count;
      return index;
    }
    const Vec3 e = centres.hi - centres.lo;
    const int axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
    const int32_t half = count / 2;
    auto begin = tris_.begin() + first;
    std::nth_element(begin, begin + half, begin + count,
                     [axis](const Tri& a, const Tri& b) {
                       return a.p[0][axis] + a.p[1][axis] + a.p[2][axis] <
                              b.p[0][axis] + b.p[1][axis] + b.p[2][axis];
                     });
    Build(first, half);
    const int32_t right = Build(first + half, count - half);
    nodes_[index].right = right;
    return index;
  }

  std::vector<Tri> tris_;
  std::vector<Node> nodes_;
};

// The entry distance of the ray into `box` within [0, t_far], or -1.
double Enter(const Box& box, const Vec3& o, const Vec3& d, double t_far) {
  double lo = 0, hi = t_far;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) {
      if (o[k] < box.lo[k] || o[k] > box.hi[k]) return -1;
      continue;
    }
    const double a = (box.lo[k] - o[k]) / d[k], b = (box.hi[k] - o[k]) / d[k];
    lo = std::max(lo, std::min(a, b));
    hi = std::min(hi, std::max(a, b));
  }
  return lo <= hi ? lo : -1;
}

// Möller-Trumbore in double: t or -1.
double HitTriangle(const Tri& t, const Vec3& o, const Vec3& d) {
  const Vec3 e1 = t.p[1] - t.p[0], e2 = t.p[2] - t.p[0];
  const Vec3 p = Cross(d, e2);
  const double det = Dot(e1, p);
  if (det == 0) return -1;
  const Vec3 s = o - t.p[0];
  const double u = Dot(s, p) / det;
  if (u < 0 || u > 1) return -1;
  const Vec3 q = Cross(s, e1);
  const double v = Dot(d, q) / det;
  if (v < 0 || u + v > 1) return -1;
  return Dot(e2, q) / det;
}

struct Counts {
  int64_t nodes = 0, triangles = 0;
};

// Closest hit beyond t_min of primitives not in `ring` (sorted), or
// t_far; counts the tests.
double Trace(const Bvh& bvh, const Vec3& o, const Vec3& d, double t_min,
             double t_far, const std::vector<int32_t>& ring, Counts* c) {
  struct Pending {
    int32_t node;
    double entry;
  };
  std::vector<Pending> stack;
  double best = t_far;
  ++c->nodes;
  if (Enter(bvh.nodes()[0].box, o, d, best) < 0) return best;
  int32_t i = 0;
  while (true) {
    const Node& n = bvh.nodes()[i];
    if (n.count > 0) {
      for (int32_t j = n.first; j < n.first + n.count; ++j) {
        ++c->triangles;
        const Tri& t = bvh.tris()[j];
        if (std::binary_search(ring.begin(), ring.end(), t.prim)) continue;
        const double h = HitTriangle(t, o, d);
        if (h > t_min && h < best) best = h;
      }
    } else {
      c->nodes += 2;
      const double el = Enter(bvh.nodes()[i + 1].box, o, d, best);
      const double er = Enter(bvh.nodes()[n.right].box, o, d, best);
      if (el >= 0 && er >= 0) {
        const bool left_first = el <= er;
        stack.push_back(left_first ? Pending{n.right, er} : Pending{i + 1, el});
        i = left_first ? i + 1 : n.right;
        continue;
      }
      if (el >= 0 || er >= 0) {
        i = el >= 0 ? i + 1 : n.right;
        continue;
      }
    }
    while (!stack.empty() && stack.back().entry > best) stack.pop_back();
    if (stack.empty()) return best;
    i = stack.back().node;
    stack.pop_back();
  }
}

// Boxes and triangles of a single walk for the cone (apex x, unit axis a,
// half-angle `half`, length `length`).
void WalkCone(const Bvh& bvh, const Vec3& x, const Vec3& a, double half,
              double length, Counts* c) {
  const double sin_h = std::sin(half), cos_h = std::cos(half);
  auto meets = [&](const Box& b) {
    ++c->nodes;
    const Vec3 centre = (b.lo + b.hi) * 0.5;
    const double r = Norm(b.hi - b.lo) * 0.5;
    const Vec3 v = centre - x;
    const double along = Dot(v, a);
    if (along < -r || along > length + r) return false;
    const double perp = Norm(v - a * along);
    return perp * cos_h - along * sin_h <= r;
  };
  std::vector<int32_t> stack = {0};
  while (!stack.empty()) {
    const int32_t i = stack.back();
    stack.pop_back();
    const Node& n = bvh.nodes()[i];
    if (!meets(n.box)) continue;
    if (n.count > 0) {
      c->triangles += n.count;
      continue;
    }
    stack.push_back(n.right);
    stack.push_back(i + 1);
  }
}

// One walk for all the cone's rays, each truncated at its own hit `t[r]`:
// a node is entered when some ray meets its box (its box tested against the
// rays 8 at a time), a leaf's triangles are tested against the rays that
// met it (8 at a time). Counts those 8-wide tests.
void WalkPacket(const Bvh& bvh, const Vec3& x, const std::vector<Vec3>& dirs,
                const std::vector<double>& t, Counts* c) {
  const size_t k = dirs.size();
  const int64_t groups = static_cast<int64_t>((k + 7) / 8);
  std::vector<int32_t> stack = {0};
  std::vector<uint8_t> active(k);
  while (!stack.empty()) {
    const int32_t i = stack.back();
    stack.pop_back();
    const Node& n = bvh.nodes()[i];
    c->nodes += groups;
    size_t count = 0;
    for (size_t r = 0; r < k; ++r) {
      active[r] = Enter(n.box, x, dirs[r], t[r]) >= 0;
      count += active[r];
    }
    if (count == 0) continue;
    if (n.count > 0) {
      c->triangles += n.count * static_cast<int64_t>((count + 7) / 8);
      continue;
    }
    stack.push_back(n.right);
    stack.push_back(i + 1);
  }
}

int Bench(const std::string& name, const Mesh& mesh) {
  const MeshTopology topo = MeshTopology::Build(mesh);
  std::vector<Tri> tris(topo.primitives.size());
  for (size_t i = 0; i < tris.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      tris[i].p[k] = mesh.positions[topo.primitives[i].v[k]];
    }
    tris[i].prim = static_cast<int32_t>(i);
  }
  const Bvh bvh(std::move(tris));
  const double diagonal = BoundingBoxDiagonal(mesh);
  const double t_min = 1e-6 * diagonal;
  const int k_rays = absl::GetFlag(FLAGS_rays);
  const double half = absl::GetFlag(FLAGS_cone_angle) * M_PI / 360;
  const int64_t nv = mesh.num_vertices();
  const int64_t sample = std::min<int64_t>(absl::GetFlag(FLAGS_sample), nv);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> unit(0, 1);
  Counts per_ray, per_cone, per_packet;
  std::vector<Vec3> dirs;
  std::vector<double> hits;
  int64_t vertices = 0;
  std::vector<int32_t> ring;
  for (int64_t s = 0; s < sample; ++s) {
    const int64_t v = s * nv / sample;
    if (topo.PrimitivesOf(v).empty()) continue;
    Vec3 axis = -UnnormalizedNormal(mesh, topo, v, NormalWeighting::kArea);
    if (Norm(axis) == 0) continue;
    axis = axis / Norm(axis);
    ring.assign(topo.PrimitivesOf(v).begin(), topo.PrimitivesOf(v).end());
    // A frame around the axis; directions uniform in the cone's cap.
    const Vec3 helper = std::abs(axis.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    const Vec3 u = Cross(axis, helper) / Norm(Cross(axis, helper));
    const Vec3 w = Cross(axis, u);
    double farthest = 0;
    dirs.clear();
    hits.clear();
    for (int r = 0; r < k_rays; ++r) {
      const double cos_t = 1 - unit(rng) * (1 - std::cos(half));
      const double sin_t = std::sqrt(1 - cos_t * cos_t);
      const double phi = 2 * M_PI * unit(rng);
      const Vec3 d =
          axis * cos_t + (u * std::cos(phi) + w * std::sin(phi)) * sin_t;
      const double t =
          Trace(bvh, mesh.positions[v], d, t_min, diagonal, ring, &per_ray);
      farthest = std::max(farthest, t);
      dirs.push_back(d);
      hits.push_back(t);
    }
    WalkCone(bvh, mesh.positions[v], axis, half, farthest, &per_cone);
    WalkPacket(bvh, mesh.positions[v], dirs, hits, &per_packet);
    ++vertices;
  }
  const double n = std::max<int64_t>(vertices, 1);
  const double ray_nodes = per_ray.nodes / n, ray_tris = per_ray.triangles / n;
  const double cone_nodes = per_cone.nodes / n, cands = per_cone.triangles / n;
  const double ray_work = ray_nodes + ray_tris;
  const double cone_work = 2 * cone_nodes + cands * std::ceil(k_rays / 8.0);
  const double packet_work = (per_packet.nodes + per_packet.triangles) / n;
  std::printf(
      "| %s | %lld | %.0f | %.0f | %.0f | %.0f | %.0f | %.0f | %.2f | %.0f | "
      "%.2f |\n",
      name.c_str(), static_cast<long long>(nv), ray_nodes / k_rays,
      ray_tris / k_rays, cone_nodes, cands, ray_work, cone_work,
      ray_work / cone_work, packet_work, ray_work / packet_work);
  std::fflush(stdout);
  return 0;
}

}  // namespace
}  // namespace meshgauge

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "counts for a cone traversal (issue 52): meshgauge_cone_count_bench "
      "[--rays K] [--cone_angle DEG] [--sample N] MESH...");
  meshgauge::ListOwnFlagsInHelp(argc, argv, "bench/cone_count_bench.cc");
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  std::printf(
      "| mesh | vertices | boxes per ray | triangles per ray | cone: boxes | "
      "cone: candidates | work, per-ray walks | work, cone walk | ratio | "
      "work, one walk 8 rays wide | ratio |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n");
  int rc = 0;
  for (size_t i = 1; i < args.size(); ++i) {
    auto mesh = meshgauge::bench::ReadOutwardMesh(args[i]);
    if (!mesh.ok() || mesh->dimension != 3) {
      std::fprintf(stderr, "%s: %s\n", args[i],
                   mesh.ok() ? "not a 3D mesh"
                             : std::string(mesh.status().message()).c_str());
      rc = 1;
      continue;
    }
    rc |= meshgauge::Bench(meshgauge::bench::BaseName(args[i]), *mesh);
  }
  return rc;
}
