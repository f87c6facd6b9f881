// Where a CLI verb's numbers come from: an SdfEvaluator in this process, or
// a session of a meshgauge-server (`meshgauge remote VERB`). Verbs write
// every output from these library results and the mesh file alone, so a
// remote verb's outputs are the local verb's.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/cli/cli_flags.h"
#include "lib/core/calibration_types.h"
#include "lib/core/gradcheck_types.h"
#include "lib/core/mesh.h"
#include "lib/core/penalty.h"
#include "lib/core/sdf_types.h"
#include "lib/core/sensitivity.h"

namespace meshgauge::client {
class RemoteClient;
}  // namespace meshgauge::client

namespace meshgauge::cli {

// Which derivatives of a pass will be asked for: a pass without them keeps
// no hit table (its memory is #V x rays x 5 bytes).
enum class Derivatives {
  kNone,      // values (and a penalty without its gradient)
  kVjp,       // Vjp() and Penalty(..., true)
  kJacobian,  // those and Jacobian()
};

// Bytes a local backend holds (a remote one's are the server's).
struct MemoryBytes {
  int64_t mesh = 0;       // positions, faces, regions
  int64_t derived = 0;    // topology
  int64_t bvh = 0;        // Embree: BVH and geometry buffers
  int64_t hit_table = 0;  // kept for derivatives only: 5 bytes per ray
};

class Backend {
 public:
  virtual ~Backend() = default;
  // The mesh the backend was made from (the CLI keeps no other copy).
  virtual const Mesh& mesh() const = 0;
  // What this process holds for the session; nullopt for a remote one.
  virtual std::optional<MemoryBytes> Memory() const { return std::nullopt; }
  // The ray pass at the mesh's positions, kept for the calls below.
  virtual absl::StatusOr<SdfResult> Sdf(const SdfParams& params,
                                        Derivatives derivatives) = 0;
  // After Sdf(params, kJacobian): dSDF/dx of that pass.
  virtual absl::StatusOr<SparseJacobian> Jacobian() = 0;
  // After Sdf(params, kVjp or kJacobian): g^T J for per-vertex weights (#V).
  virtual absl::StatusOr<std::vector<Vec3>> Vjp(
      const std::vector<double>& weights) = 0;
  // After Sdf: the penalty (or KS constraint) of that pass (`pass`, the
  // result Sdf returned), its gradient when asked (after kVjp or kJacobian;
  // PenaltyResult::dp_dt is not filled remotely).
  virtual absl::StatusOr<PenaltyResult> Penalty(const SdfResult& pass,
                                                const PenaltyParams& params,
                                                bool with_gradient) = 0;
  // Both passes of SPEC §8 (the report's per-vertex arrays may be empty).
  virtual absl::StatusOr<CalibrationReport> Calibrate(
      const CalibrationParams& params) = 0;
  // The SPEC §6 finite-difference check at the mesh's positions (remotely
  // run by the server); control.progress, if set, follows all its passes.
  virtual absl::StatusOr<GradCheckReport> GradCheck(
      const SdfParams& params, const GradCheckOptions& options,
      const ComputeControl& control) = 0;
};

// Makes the backend of a loaded, validated mesh.
using BackendFactory =
    std::function<absl::StatusOr<std::unique_ptr<Backend>>(Mesh mesh)>;

// An SdfEvaluator here (with progress bars as `progress` says), computing
// with `threads` worker threads (ComputeControl::threads; 0: all cores).
BackendFactory LocalBackend(ProgressMode progress, int threads);

// A session of the server of `remote`: with an empty `session_id` the mesh
// is uploaded as a new session that is deleted afterwards; otherwise the
// session of that id is used (and kept) when it exists, its vertex and face
// counts matching the mesh's, and is created from the mesh when it does not.
// Errors: the server's, NotFound for an unreadable TLS or token file.
// The server streams the ray pass's progress when `progress` draws a bar.
// `fan_out` > 1 splits the values pass and the VJP into that many sample
// ranges sent at once (client::SdfCall::fan_out; the same bits).
absl::StatusOr<BackendFactory> RemoteBackend(const RemoteFlags& remote,
                                             const std::string& session_id,
                                             ProgressMode progress,
                                             int fan_out = 1);

// A client of the server of `remote` (--server, TLS and token files).
// Errors: NotFound for an unreadable file, InvalidArgument for a client
// certificate without --tls-ca-file.
absl::StatusOr<std::unique_ptr<client::RemoteClient>> Connect(
    const RemoteFlags& remote);

}  // namespace meshgauge::cli
