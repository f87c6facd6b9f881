// The meshgauge CLI verbs. Each takes its parsed options (cli_flags.h) and
// returns OK or the error to print (exit status 1).
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "client/cli/cli_flags.h"

namespace meshgauge::cli {

// Options every verb that reads a mesh file takes.
struct MeshInput {
  std::string mesh;
  SdfFlags sdf;
  MeshFlags mesh_flags;
  OutputFlags out;
};

// meshgauge sdf MESH: SDF per vertex, summary on stdout.
absl::Status RunSdf(const MeshInput& in);

// meshgauge grad MESH: sensitivities of the SDF (SPEC §6).
absl::Status RunGrad(const MeshInput& in, const GradFlags& grad);

// meshgauge penalty MESH --t-min T: minimum-thickness penalty or aggregated
// constraint and its gradient (SPEC §7).
absl::Status RunPenalty(const MeshInput& in, const PenaltyFlags& penalty);

// meshgauge calibrate MESH --t-min T: SDF vs physical thickness (SPEC §8).
absl::Status RunCalibrate(const MeshInput& in, const CalibrateFlags& cal);

// meshgauge gradcheck MESH: central differences against the analytic
// derivatives (SPEC §6), and of the penalty with --t-min; FailedPrecondition
// (exit 1) on FAIL.
absl::Status RunGradcheck(const MeshInput& in, const GradcheckFlags& check,
                          const PenaltyFlags& penalty);

// meshgauge shape KIND --out FILE: writes an analytic test shape (OBJ; 2D
// shapes as `l` polylines).
struct ShapeInput {
  std::string kind, out;
  double size = 0.05, radius = 1.0;
};
absl::Status RunShape(const ShapeInput& in);

// meshgauge remote VERB ...: the same work through a meshgauge-server.
struct RemoteInput {
  RemoteFlags remote;
  std::string verb;
  std::string target;  // the mesh file (upload) or the session id.
  std::string session_id;
  std::string positions;
  int64_t generation = -1;
  MeshInput in;  // in.mesh unused; in.sdf, in.mesh_flags, in.out used.
  GradFlags grad;
  PenaltyFlags penalty;
  CalibrateFlags calibrate;
};
absl::Status RunRemote(const RemoteInput& in);

}  // namespace meshgauge::cli
