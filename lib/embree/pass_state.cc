#include "lib/embree/pass_state.h"

#include <cmath>
#include <limits>

#include "lib/core/normals.h"

namespace meshgauge::pass_state {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The largest power of two at or below x (> 0); 0 for x <= 0.
float PowerOfTwoBelow(float x) {
  if (!(x > 0)) return 0;
  int e;
  std::frexp(x, &e);
  return std::ldexp(1.0f, e - 1);
}

}  // namespace

absl::StatusOr<PassSetup> SetUpPass(const MeshGeometry& g,
                                    const SdfParams& params) {
  if (absl::Status s = ValidateParams(params); !s.ok()) return s;
  const int dimension = g.mesh().dimension;
  PassSetup setup;
  setup.resolved = ResolveParams(params, dimension);
  const ResolvedParams& resolved = setup.resolved;
  setup.sphere = params.method == SdfMethod::kSphere;
  setup.faces = params.samples == SampleSet::kFaces;
  if (params.method != SdfMethod::kCone) {
    setup.cone.push_back({Vec3(0, 0, 1), 0.0, 1.0});
  } else {
    auto made = MakeCone(dimension, resolved.aperture_radians, resolved.rays,
                         resolved.min_weight_angle);
    if (!made.ok()) return made.status();
    setup.cone = std::move(*made);
  }
  auto range = ResolveRange(g.mesh(), params);
  if (!range.ok()) return range.status();
  setup.range = *range;
  setup.samples = range->end - range->begin;
  setup.num_rays = static_cast<int>(setup.cone.size());
  setup.t_min = params.self_hit_epsilon * g.mean_edge_length();
  setup.t_max =
      params.max_distance > 0 ? params.max_distance : g.bounding_box_diagonal();
  RayScene::FanLimits& limits = setup.limits;
  limits.t_min = static_cast<float>(setup.t_min);
  limits.t_near = PowerOfTwoBelow(limits.t_min);
  limits.near_below = 2 * limits.t_near;
  // Beyond t_max by far more than a single-precision test errs (2^-16 of
  // the coordinates' magnitude, about twice the diagonal in the tracer's
  // coordinates, and of t_max, as HitCandidates' window), so that the
  // double-precision check decides: the cone walk's distance to a hit at
  // exactly t_max (a cube's corner seen from the opposite one) was 3 units
  // in the last place above it.
  limits.t_far = std::nextafter(
      static_cast<float>(setup.t_max +
                         (setup.t_max + 2 * g.bounding_box_diagonal()) *
                             0x1p-16),
      std::numeric_limits<float>::max());
  setup.cone_half_angle = params.method == SdfMethod::kNormalRay
                              ? 0
                              : resolved.aperture_radians / 2;
  setup.ball.cap = setup.t_max / 2;
  setup.ball.min_radius = setup.t_min / 2;
  setup.ball.cos_beta = resolved.contact_cosine;
  setup.ball.fan = limits;
  return setup;
}

PassOutput NewOutput(const PassSetup& setup, bool keep_hits) {
  const int64_t ns = setup.samples;
  PassOutput out;
  SdfResult& result = out.result;
  result.resolved = setup.resolved;
  result.values.assign(ns, kNaN);
  result.status.assign(ns, VertexStatus::kOk);
  result.hits.assign(ns, 0);
  result.kept.assign(ns, 0);
  if (setup.resolved.params.opposite_points) {
    result.opposite.assign(ns, Vec3(kNaN, kNaN, kNaN));
  }
  if (keep_hits) {
    out.table.resize(ns * setup.num_rays);
    out.kept_table.resize(ns * setup.num_rays);
    out.near.assign(ns, 0);
  }
  return out;
}

SampleScratch::SampleScratch(int num_rays)
    : t(num_rays),
      prims(num_rays),
      candidates(num_rays),
      dirs(num_rays),
      kept(num_rays) {
  estimator.reserve(num_rays);
}

VertexStatus MakePassSample(const MeshGeometry& g, const PassSetup& setup,
                            int64_t p, SampleCone* sample) {
  const Mesh& mesh = g.mesh();
  const MeshTopology& topo = g.topology();
  const SdfParams& params = setup.resolved.params;
  if (!setup.faces && topo.vertex_faces.Of(p).empty()) {
    return VertexStatus::kNoFaces;
  }
  *sample = MakeSampleCone(
      mesh, topo, params.samples, p,
      [&] {
        return UnnormalizedNormal(mesh, topo, p, params.normal_weighting);
      },
      /*frame=*/!setup.sphere);
  return sample->cone.valid ? VertexStatus::kOk
                            : VertexStatus::kDegenerateNormal;
}

}  // namespace meshgauge::pass_state
