// Test helpers over RayScene.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "absl/functional/function_ref.h"
#include "lib/core/topology.h"
#include "lib/embree/ray_scene.h"

namespace meshgauge::testing {

// Whether a single ray from `from` towards `target` (a point on the
// surface, the first the ray meets) is lost: it meets nothing, or first
// meets the surface more than 1e-3 of the distance away from the target.
inline bool RayIsLost(const RayScene& scene, const Vec3& from,
                      const Vec3& target) {
  Vec3 d = target - from;
  const double distance = std::sqrt(Dot(d, d));
  d = d / distance;
  const Vec3 dirs[] = {d};
  HitCandidates hit;
  scene.IntersectFan(from, dirs, {1e-6f, 1e-6f, 0, 1e30f}, {},
                     absl::MakeSpan(&hit, 1));
  return hit.count() == 0 || std::abs(hit[0].t - distance) > 1e-3 * distance;
}

// `n` directions uniform on the sphere (the circle in 2D).
inline std::vector<Vec3> RandomDirections(int n, int dimension,
                                          std::mt19937& rng) {
  std::normal_distribution<double> gauss;
  std::vector<Vec3> dirs(n);
  for (Vec3& d : dirs) {
    d = Vec3(gauss(rng), gauss(rng), dimension == 3 ? gauss(rng) : 0);
    d = d / std::sqrt(Dot(d, d));
  }
  return dirs;
}

// Traces `n` random directions from every vertex of a 3D mesh, its
// one-ring excluded as in a pass, in scenes `a` and `b`; calls `check` with
// the vertex, its one-ring, the directions and both scenes' candidates.
inline void CompareFans(
    const Mesh& mesh, const MeshTopology& topo, const RayScene& a,
    const RayScene& b, int n, unsigned seed,
    absl::FunctionRef<void(
        int64_t, const std::vector<int32_t>&, const std::vector<Vec3>&,
        const std::vector<HitCandidates>&, const std::vector<HitCandidates>&)>
        check) {
  std::mt19937 rng(seed);
  const RayScene::FanLimits kLimits = {1e-6f, 1e-6f, 0, 1e30f};
  std::vector<HitCandidates> ca(n), cb(n);
  std::vector<int32_t> ring;
  for (int64_t v = 0; v < mesh.num_vertices(); ++v) {
    const std::vector<Vec3> dirs = RandomDirections(n, 3, rng);
    OneRingPrimitives(topo, v, &ring);
    a.IntersectFan(mesh.positions[v], dirs, kLimits, ring, absl::MakeSpan(ca));
    b.IntersectFan(mesh.positions[v], dirs, kLimits, ring, absl::MakeSpan(cb));
    check(v, ring, dirs, ca, cb);
  }
}

}  // namespace meshgauge::testing
