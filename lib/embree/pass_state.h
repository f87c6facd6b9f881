// What one ray pass (SdfEvaluator::Compute, sdf_evaluator.h) computes with
// and writes: its parameters resolved against the mesh, its output arrays,
// a worker's buffers, and a sample's point and cone. Shared by the pass and
// by its pilot (traversal_choice.h); not part of the library's interface.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/cone.h"
#include "lib/core/face_sample.h"
#include "lib/core/mesh_geometry.h"
#include "lib/core/sdf_types.h"
#include "lib/core/table_allocator.h"
#include "lib/embree/hit_candidates.h"
#include "lib/embree/inscribed_ball_query.h"
#include "lib/embree/ray_scene.h"

namespace meshgauge::pass_state {

// What a pass computes with, resolved from its parameters and the mesh
// (SPEC §3-5).
struct PassSetup {
  ResolvedParams resolved;    // resolved.params: the pass's parameters.
  std::vector<ConeRay> cone;  // one ray (the axis) but for kCone.
  bool sphere = false;        // kSphere: the inscribed ball, no rays.
  bool faces = false;         // face samples (SPEC v2 §5c), else vertices.
  SampleRange range;          // the pass's samples, resolved.
  int64_t samples = 0;        // in the range.
  int num_rays = 0;
  double t_min = 0, t_max = 0;  // hits count within [t_min, t_max].
  RayScene::FanLimits limits;   // the same in the tracer's precision.
  double cone_half_angle = 0;
  BallLimits ball;
};

// Errors: InvalidArgument for bad params.
absl::StatusOr<PassSetup> SetUpPass(const MeshGeometry& g,
                                    const SdfParams& params);

// What the workers write, an entry per sample (a row of K in the tables);
// the tables and `near` stay empty when no hit table is kept. The tables'
// rows are first written by the workers.
struct PassOutput {
  SdfResult result;
  TableVector<int32_t> table;  // the hit primitive per ray, -1 for none.
  TableVector<uint8_t> kept_table;
  std::vector<uint8_t> near;
};

PassOutput NewOutput(const PassSetup& setup, bool keep_hits);

// One worker's buffers, reused from sample to sample, and its counts.
struct SampleScratch {
  explicit SampleScratch(int num_rays);
  std::vector<double> t;       // per ray: the hit's distance, NaN for none.
  std::vector<int32_t> prims;  // per ray: the hit primitive, -1 for none.
  std::vector<HitCandidates> candidates;
  std::vector<int32_t> excluded, retrace, around, dropped, merged;
  std::vector<Vec3> dirs, retrace_dirs;
  std::vector<uint8_t> kept;
  std::vector<double> estimator;
  std::vector<float> starts;
  int64_t traced = 0, world_frames = 0, past_ball = 0, streamed = 0;
  int64_t walked = 0, fell_back = 0;
};

// A sample's rows of the hit tables; null when none are kept.
struct SampleRows {
  int32_t* prims = nullptr;
  uint8_t* kept = nullptr;
};

// Sample p's point and cone in a pass of `setup` (SPEC §2, v2 §3, §5c),
// with the rays' frame unless the pass is the inscribed ball's (which needs
// the axis only): kOk and *sample, else the sample's status, kNoFaces (a
// vertex on no face; *sample unset) or kDegenerateNormal (no axis;
// sample->cone not valid).
VertexStatus MakePassSample(const MeshGeometry& g, const PassSetup& setup,
                            int64_t p, SampleCone* sample);

}  // namespace meshgauge::pass_state
