// The library-side types of the replies of the meshgauge service: library
// results (SdfResult, PenaltyResult, ...) plus what the call reports about
// itself (generation, reuse of the cached ray pass, server time).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "lib/core/exact_sum.h"
#include "lib/core/gradcheck_types.h"
#include "lib/core/penalty.h"
#include "lib/core/sdf_types.h"
#include "lib/core/sensitivity.h"
#include "lib/core/thin_regions.h"

namespace meshgauge::wire {

// Every field of v1::SessionInfo.
struct SessionInfo {
  std::string session_id;
  int dimension = 3;
  int64_t num_vertices = 0, num_faces = 0;
  int64_t generation = 0;
  int64_t memory_bytes = 0;
  int64_t bvh_builds = 0, bvh_refits = 0;
  double idle_seconds = 0;   // since the last call that used the session.
  double signed_volume = 0;  // 3D; signed area in 2D.
  bool closed = false;
  std::vector<std::string> warnings;
};

// Every field of v1::GetServerInfoResponse: the release and the limits a
// caller meets (per-tenant ones for the caller's tenant).
struct ServerInfo {
  std::string version;   // the release (the repository's VERSION).
  std::string api;       // "meshgauge.v1".
  int32_t max_rays = 0;  // per vertex.
  int64_t max_vertices = 0, max_faces = 0;
  int64_t max_message_bytes = 0;         // per gRPC message, both ways.
  int64_t max_upload_message_bytes = 0;  // per CreateSession message.
  int64_t max_upload_file_bytes = 0;     // a CreateSession file upload.
  int64_t max_sessions = 0;              // for the caller's tenant.
  int64_t memory_budget_bytes = 0;       // for the caller's tenant.
};

struct UpdateResult {
  int64_t generation = 0;  // the new generation.
  bool refit = false;      // false: the BVH was rebuilt.
  double bvh_seconds = 0;
};

// What every computation reports about itself.
struct CallFacts {
  int64_t generation = 0;    // of the positions used.
  bool reused_hits = false;  // served from the session's cached ray pass.
  double seconds = 0;        // server-side compute time.
};

// A ComputeSdf stream reassembled. result.resolved holds the parameters
// sent and the resolved ray count; aperture and weight angle are not sent.
struct SdfReply {
  SdfResult result;
  std::optional<SparseJacobian> jacobian;  // with include_jacobian.
  double integral = 0;  // SdfSummary.integral (IntegrateNodal's value).
  CallFacts facts;
};

struct GradCheckReply {
  GradCheckReport report;
  CallFacts facts;  // reused_hits is always false.
};

struct VjpReply {
  std::vector<Vec3> gradient;  // g^T J per vertex (z = 0 in 2D).
  CallFacts facts;
  // A range call's exact partial sums, x, y, z per vertex (gradient holds
  // them rounded); empty for a whole call.
  ExactSums sums;
};

// ComputePenaltyRequest's thin-region fields.
struct ThinRequest {
  ThinRegionParams params;
  int max_regions = 1000;
};

struct PenaltyReply {
  PenaltyResult penalty;  // value, missing, gradient (dp_dt not sent).
  double sdf_min = 0;     // of the values used.
  int64_t world_frame_vertices = 0;
  CallFacts facts;
};

}  // namespace meshgauge::wire
