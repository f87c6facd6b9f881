// Parameters and results of the shape diameter computation (SPEC §3-5).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/missing_values.h"
#include "lib/core/normals.h"
#include "lib/core/vec3.h"

namespace meshgauge {

enum class SdfMethod {
  kCone,       // Shapira et al.: cone of rays, median +- kappa sigma filter,
               // 1/angle weights (SPEC §5).
  kNormalRay,  // one ray along the cone axis: physical thickness.
  kSphere,     // the inscribed ball tangent at the vertex (SPEC v2 §5b).
};

// Where the values are computed (SPEC v2 §5c).
enum class SampleSet {
  kVertices,  // every vertex: axis from N_p (SPEC §2), one-ring excluded (§4).
  kFaces,     // every face's centroid (the mean of its corners): axis from
              // the face's own normal (the sum of its primitives' area
              // normals, whatever normal_weighting says), frame attached to
              // its lowest-index corner; rays ignore the face itself, the
              // inscribed ball every face sharing a vertex with it.
};

// "vertices" or "faces" (the CLI's --samples); SampleName: "vertex" or
// "face".
const char* SampleSetName(SampleSet set);
const char* SampleName(SampleSet set);

// The samples [begin, end) of a pass (vertex or face indices); the default,
// end == 0, is every sample. A range pass computes only its samples: its
// results are theirs, bit for bit the full pass's (values do not depend on
// other samples), and split a pass over replicas (docs/server.md, Fan-out).
struct SampleRange {
  int64_t begin = 0;
  int64_t end = 0;
  bool all() const { return end == 0; }
  bool operator==(const SampleRange&) const = default;
};

struct SdfParams {
  SdfMethod method = SdfMethod::kCone;
  // Full opening angle alpha in degrees, in (0, 180).
  double cone_angle_degrees = 30;
  // Ray count K in [1, 4096]; 0 selects the default (100 in 3D, 32 in 2D).
  // Ignored (always 1) for kNormalRay and kSphere.
  int rays = 0;
  // theta_min in radians, > 0; 0 selects alpha / (2 K).
  double min_weight_angle = 0;
  // Outlier filter width kappa >= 0 (SPEC §5).
  double kappa = 1.0;
  // Hits closer than self_hit_epsilon * (mean edge length) are ignored; >= 0.
  double self_hit_epsilon = 1e-6;
  // Rays with no hit closer than this are misses (mesh units); 0 selects the
  // bounding-box diagonal.
  double max_distance = 0;
  NormalWeighting normal_weighting = NormalWeighting::kArea;
  // Fill SdfResult::opposite (SPEC v2 §5c).
  bool opposite_points = false;
  // kSphere: the contact cone's half-angle beta in degrees, in (0, 90): a
  // touching point is seen from the vertex at most beta off the axis.
  double contact_angle_degrees = 60;
  SampleSet samples = SampleSet::kVertices;
  // Which samples; checked against the mesh by the pass (InvalidArgument
  // naming the range and the count unless 0 <= begin < end <= samples).
  SampleRange range = {};

  // Every field: a cached pass is reused only for equal parameters. How a
  // pass runs (ComputeControl) is not a parameter.
  bool operator==(const SdfParams&) const = default;
};

// Checks ranges; returns InvalidArgument naming the bad parameter.
absl::Status ValidateParams(const SdfParams& params);

// Defaults resolved for a mesh of the given dimension.
struct ResolvedParams {
  SdfParams params;
  int rays = 0;
  double aperture_radians = 0;
  double min_weight_angle = 0;
  double contact_cosine = 0;  // cos(contact_angle_degrees).
};
ResolvedParams ResolveParams(const SdfParams& params, int dimension);

enum class VertexStatus : uint8_t {
  kOk = 0,
  kNoHit = 1,             // no ray hit (or, rarely, none passed the filter;
                          // kSphere: no admissible point within the cap).
  kNoFaces = 2,           // the vertex is on no face.
  kDegenerateNormal = 3,  // N_p = 0 (e.g. a fold): no cone axis.
};
const char* VertexStatusName(VertexStatus status);

// Arrays hold one entry per sample: #V with SampleSet::kVertices, #F with
// kFaces (statuses are then kOk, kNoHit or kDegenerateNormal); with a
// sample range (resolved.params.range) one per sample of the range, entry
// i for sample range.begin + i, and `normalized` is over the range's values
// and `missing` is left empty (both need every value: a client that merged
// the ranges computes them, NormalizedSdf and CountMissing).
struct SdfResult {
  // Per sample: SDF in mesh units; NaN unless status is kOk.
  std::vector<double> values;
  // Shapira's normalised SDF in [0, 1] over the kOk values (SPEC §5); NaN
  // unless kOk; 0 everywhere when all values are equal.
  std::vector<double> normalized;
  std::vector<VertexStatus> status;
  std::vector<int32_t> hits;  // rays that hit, per vertex.
  std::vector<int32_t> kept;  // rays kept by the filter, per vertex.
  // With SdfParams::opposite_points, per vertex, what was measured against
  // (SPEC v2 §5c): kNormalRay's hit point, kCone's weighted mean of the kept
  // rays' hit points, kSphere's touching point; NaN unless kOk. Else empty.
  std::vector<Vec3> opposite;
  int64_t rays_traced = 0;
  // 3D vertices with a value whose one-ring gave no frame edge, so their
  // cone used the world frame (SPEC v2 §3 fallback); 0 in 2D, for kSphere
  // (no rays, no frame) and for face samples (a face's corners give one).
  int64_t world_frame_vertices = 0;
  // Samples whose rays started past an empty ball (lib/embree/ray_start.h);
  // the others traced from the surface: no ball was found, the pass did not
  // look for one (kSurface, 2D, kAuto's small passes, an incremental pass's
  // unmoved samples retracing fewer than 16 rays) or traced nothing.
  int64_t samples_past_ball = 0;
  // Samples whose rays went to Embree as one coherent stream
  // (FanTraversal::kStream); the others' in packets or the cone walk.
  int64_t samples_streamed = 0;
  // Samples whose rays the cone walk traced (FanTraversal::kCone), and
  // those it gave up on, which Embree traced: 0 in a pass, which walks all
  // of its samples or streams them all.
  int64_t samples_cone_walked = 0;
  int64_t samples_cone_fell_back = 0;
  // The pilot of a pass left to choose its traversal: the cone walk's
  // (triangle, group of 8 rays) tests per ray on a few fans (the pass walks
  // cones at 8 or fewer); 0 where no pilot ran, -1 where the walk gave up.
  double cone_walk_pilot = 0;
  // Samples without a value and the share of the surface they cover
  // (kFaces: MissingValues::vertices stays 0).
  MissingValues missing;
  // Wall time of the ray pass, its pilot (cone_walk_pilot) included.
  double trace_seconds = 0;
  ResolvedParams resolved;

  int64_t CountStatus(VertexStatus s) const;
  MissingCauses Causes() const {
    return {CountStatus(VertexStatus::kNoHit),
            CountStatus(VertexStatus::kDegenerateNormal)};
  }
};

// Statistics of the finite entries of a per-vertex array (NaN entries, the
// vertices without a value, are skipped). All fields but count are NaN when
// no entry is finite; the median of an even count is the mean of the two
// middle values.
struct ValueStats {
  int64_t count = 0;
  double min, max, mean, median;
};
ValueStats SummarizeValues(const std::vector<double>& values);

// How a long computation runs, not what it computes: results do not depend
// on it (bit for bit), so it is no part of a cached pass's key. The hooks
// may be called from worker threads, never concurrently with themselves.
struct ComputeControl {
  // Worker threads, in [0, 1024]; 0 = all cores.
  int threads = 0;
  // Polled between blocks of vertices; returning true aborts the call with
  // absl::CancelledError.
  std::function<bool()> cancelled = nullptr;
  // Progress in vertices, monotone, called at most about 100 times per pass.
  std::function<void(int64_t done, int64_t total)> progress = nullptr;
};

// Checks threads' range; returns InvalidArgument naming it.
absl::Status ValidateControl(const ComputeControl& control);

}  // namespace meshgauge
