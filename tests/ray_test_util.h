// Test helpers over RayScene.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "absl/functional/function_ref.h"
#include "lib/core/cone.h"
#include "lib/core/normals.h"
#include "lib/core/sdf_types.h"
#include "lib/core/topology.h"
#include "lib/core/vertex_cone.h"
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

// The fans of a 3D mesh's vertices as a pass of `params` traces them: the
// mesh's scene (kRebuild), each vertex's cone about its area-weighted
// normal and its one-ring, over limits of 1e-4 mean edge lengths to 1e30.
// Keeps a reference to `mesh`; not copied or moved (the scene keeps one to
// the topology).
class VertexFans {
 public:
  explicit VertexFans(const Mesh& mesh, const SdfParams& params = {})
      : mesh_(mesh), topo_(MeshTopology::Build(mesh)) {
    auto scene = RayScene::Create(mesh, topo_, BvhUpdatePolicy::kRebuild);
    EXPECT_TRUE(scene.ok()) << scene.status();
    if (scene.ok()) scene_ = std::move(*scene);
    const ResolvedParams resolved = ResolveParams(params, 3);
    cone_ = *MakeCone(3, resolved.aperture_radians, resolved.rays,
                      resolved.min_weight_angle);
    normals_ = UnnormalizedNormals(mesh, topo_, NormalWeighting::kArea);
    const auto h = static_cast<float>(MeanEdgeLength(mesh));
    limits_ = {1e-4f * h, 1e-4f * h, 2e-4f * h, 1e30f};
  }
  VertexFans(const VertexFans&) = delete;
  VertexFans& operator=(const VertexFans&) = delete;

  const RayScene& scene() const { return *scene_; }
  const RayScene::FanLimits& limits() const { return limits_; }
  size_t rays() const { return cone_.size(); }
  // Vertex p's rays into `dirs` (resized), its cone's axis into `axis` and
  // its one-ring into `ring`; false where p has no valid cone.
  bool Fan(int64_t p, std::vector<Vec3>* dirs, Vec3* axis,
           std::vector<int32_t>* ring) const {
    const VertexCone vc = MakeVertexCone(mesh_, topo_, p, normals_[p]);
    if (!vc.valid) return false;
    dirs->resize(cone_.size());
    RayDirections(vc.frame, cone_, absl::MakeSpan(*dirs));
    *axis = vc.frame.axis;
    OneRingPrimitives(topo_, p, ring);
    return true;
  }

 private:
  const Mesh& mesh_;
  MeshTopology topo_;
  std::unique_ptr<RayScene> scene_;
  std::vector<ConeRay> cone_;
  std::vector<Vec3> normals_;
  RayScene::FanLimits limits_;
};

}  // namespace meshgauge::testing
