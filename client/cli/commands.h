// The meshgauge CLI verbs. Each takes its parsed options (cli_flags.h) and
// returns OK or the error to print (exit status 1). The verbs on a mesh file
// take the backend that computes (backend.h: here, or a server for
// `meshgauge remote VERB`) and write the same outputs from either.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "client/cli/backend.h"
#include "client/cli/cli_flags.h"

namespace meshgauge::cli {

// Options every verb that reads a mesh file takes.
struct MeshInput {
  std::string mesh;
  SdfFlags sdf;
  MeshFlags mesh_flags;
  OutputFlags out;
};

// A verb's mesh, its backend and its parameters; the mesh's warnings go to
// stderr with print_warnings (sdf puts them in its summary instead).
struct Opened {
  LoadedMesh loaded;  // its mesh moved into the backend: use mesh().
  std::unique_ptr<Backend> backend;
  SdfParams params;
  double setup_seconds = 0;  // making the backend: topology and BVH, or upload
  const Mesh& mesh() const { return backend->mesh(); }
};
absl::StatusOr<Opened> Open(const MeshInput& in, const BackendFactory& make,
                            bool print_warnings);

// Each warning on stderr as "meshgauge: warning: ...".
void PrintWarnings(const std::vector<std::string>& warnings);

// meshgauge sdf MESH: SDF per vertex, summary on stdout.
absl::Status RunSdf(const MeshInput& in, const BackendFactory& make);

// meshgauge grad MESH: sensitivities of the SDF (SPEC §6).
absl::Status RunGrad(const MeshInput& in, const GradFlags& grad,
                     const BackendFactory& make);

// meshgauge penalty MESH --t-min T: minimum-thickness penalty or aggregated
// constraint and its gradient (SPEC §7).
absl::Status RunPenalty(const MeshInput& in, const PenaltyFlags& penalty,
                        const BackendFactory& make);

// meshgauge calibrate MESH --t-min T: SDF vs physical thickness (SPEC §8).
absl::Status RunCalibrate(const MeshInput& in, const CalibrateFlags& cal,
                          const BackendFactory& make);

// meshgauge report MESH --t-min T --out DIR: views.png, histogram.png,
// report.json, index.html and colored.ply in DIR, and the one-line answer
// on stdout.
absl::Status RunReport(const MeshInput& in, const ReportFlags& report,
                       const BackendFactory& make);

// meshgauge gradcheck MESH: central differences against the analytic
// derivatives (SPEC §6), and of the penalty with --t-min, computed by the
// backend (here or, remote, by the server); FailedPrecondition (exit 1) on
// FAIL or INCONCLUSIVE.
absl::Status RunGradcheck(const MeshInput& in, const GradcheckFlags& check,
                          const PenaltyFlags& penalty,
                          const BackendFactory& make);

// meshgauge shape KIND --out FILE: writes an analytic test shape (OBJ; 2D
// shapes as `l` polylines).
struct ShapeInput {
  std::string kind, out;
  double size = 0.05, radius = 1.0;
};
absl::Status RunShape(const ShapeInput& in);

// meshgauge remote upload|list|health|info|delete|update: the sessions of
// a meshgauge-server (the computing verbs are the ones above with
// RemoteBackend).
struct RemoteInput {
  RemoteFlags remote;
  std::string verb;
  std::string target;  // the mesh file (upload) or the session id.
  std::string session_id;
  std::string positions;
  int64_t generation = -1;
  MeshFlags mesh_flags;  // upload.
  int threads = 0;       // upload: the local checks' threads (0: all cores).
  bool json = false;
};
absl::Status RunRemote(const RemoteInput& in);

}  // namespace meshgauge::cli
