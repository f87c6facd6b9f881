// The baseline of the benchmarks: plain Embree passes over exactly the rays
// meshgauge traces (same origins, same cone directions), with no one-ring
// skip, no double-precision recomputation and no estimator, in several
// Embree configurations (scene flags, build quality, single rays, packets,
// streams), so meshgauge's ray pass is compared with the fastest of them.
#pragma once

#include <embree3/rtcore.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/cone.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"
#include "lib/core/topology.h"
#include "lib/core/vec3.h"

namespace meshgauge::bench {

// How the raw pass hands a vertex's rays to Embree.
enum class RawTrace {
  kSingle,    // rtcIntersect1, one ray at a time
  kPacket4,   // rtcIntersect4 over consecutive rays of one vertex
  kPacket8,   // rtcIntersect8
  kPacket16,  // rtcIntersect16
  kStream,    // rtcIntersect1M over all rays of one vertex, COHERENT context
              // (rtcIntersect1 where a ray has StreamMayLoseHits; the pass
              // traces such a vertex in packets)
};

struct RawConfig {
  bool robust = true;  // RTC_SCENE_FLAG_ROBUST (watertight), as meshgauge
  bool high_quality = false;  // RTC_BUILD_QUALITY_HIGH instead of MEDIUM
  RawTrace trace = RawTrace::kSingle;
  // A context filter that accepts every hit (RTC_SCENE_FLAG_CONTEXT_FILTER_
  // FUNCTION): what Embree's traversal costs with a filter in place, as
  // meshgauge's history-independent hit rule needs one (RayScene::
  // IntersectFan), before the filter does any work. Not a candidate for the
  // fastest raw configuration.
  bool noop_filter = false;

  // e.g. "MEDIUM ROBUST rtcIntersect8", "MEDIUM ROBUST rtcIntersect16
  // no-op filter".
  std::string Name() const;
  // Whether it may be the SPEC ceiling (SpecCeiling): ROBUST, with the
  // no-op filter.
  bool CeilingCandidate() const { return robust && noop_filter; }
};

// The configurations the benchmark tries, with and without ROBUST: MEDIUM
// quality with single rays, packets of 4, 8 and 16 and streams; HIGH
// quality with single rays and packets of 16; and last, MEDIUM ROBUST with
// a no-op filter and each way of tracing (the candidates for the SPEC
// ceiling: meshgauge's own is packets of 16).
std::vector<RawConfig> RawConfigs();

// The SPEC ceiling among `configs`, measured at rate[c] rays per second
// with hits[c] rays hit (the fewest over the rounds): the fastest ROBUST
// configuration with the no-op filter whose hits are the most of any such
// configuration (one that hits fewer rays misses hits, as Embree's coherent
// streams did on spot before StreamMayLoseHits, and is no ceiling); the
// first of equally fast ones.
// nullopt when no configuration is ROBUST with the filter or the three
// spans differ in size.
std::optional<size_t> SpecCeiling(absl::Span<const RawConfig> configs,
                                  absl::Span<const double> rate,
                                  absl::Span<const int64_t> hits);

struct RawPassResult {
  int64_t rays = 0;
  int64_t hits = 0;
  double seconds = 0;        // the ray pass alone
  double build_seconds = 0;  // the scene's BVH build
};

// The rays the raw pass traces: from every vertex with faces and a valid
// cone, the resolved cone of `params` (one ray along the normal for
// kNormalRay) around its area-weighted normal, over [t_near, t_far] with
// t_near = eps * h and t_far = the bounding-box diagonal. Keeps references
// to `mesh` and `topo`. 3D only.
class RawRays {
 public:
  static absl::StatusOr<RawRays> Create(const Mesh& mesh,
                                        const MeshTopology& topo,
                                        const SdfParams& params);
  // Vertex p's directions into `dirs` (resized to the cone); false, leaving
  // them, where p traces no ray.
  bool Directions(int64_t p, std::vector<Vec3>& dirs) const;
  size_t rays_per_vertex() const { return cone_.size(); }
  float t_near() const { return t_near_; }
  float t_far() const { return t_far_; }

 private:
  RawRays(const Mesh& mesh, const MeshTopology& topo)
      : mesh_(mesh), topo_(topo) {}
  const Mesh& mesh_;
  const MeshTopology& topo_;
  std::vector<ConeRay> cone_;
  std::vector<Vec3> normals_;
  float t_near_ = 0, t_far_ = 0;
};

// An Embree scene of the mesh's triangles (3D only; `topo` is the mesh's)
// with `config`'s scene flags and build quality, not yet committed; the
// caller commits and releases it.
RTCScene NewRawScene(RTCDevice device, const Mesh& mesh,
                     const MeshTopology& topo, const RawConfig& config);

// Builds an Embree scene of the mesh's triangles (3D only) as `config` says
// (NewRawScene) and traces RawRays in the mesh's vertex order, over
// vertices in a oneTBB parallel_for with `threads` threads (0: all cores).
// The ray pass and the build are timed separately.
absl::StatusOr<RawPassResult> RunRawPass(const Mesh& mesh,
                                         const SdfParams& params, int threads,
                                         const RawConfig& config = {});

}  // namespace meshgauge::bench
