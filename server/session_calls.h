// The computations and reads of the meshgauge service on its sessions,
// without gRPC: the server's twin of client/cli/backend.h. A gRPC handler
// converts its request (proto/wire), calls one method here with a
// CallControl made from its ServerContext, and converts the result back.
//
// Every compute call takes a computation slot (ComputeSlots) first, so a
// queued call holds no session lock, then the session, its reader (the
// session's lock, shared) and checks the expected generation; the ray pass
// for its parameters is the session's cached one or is traced now, its
// memory claimed from the store first, and cached.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/calibration_types.h"
#include "lib/core/gradcheck_types.h"
#include "lib/core/penalty.h"
#include "lib/core/sensitivity.h"
#include "lib/core/thin_regions.h"
#include "proto/wire/types.h"
#include "server/compute_slots.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/session.h"
#include "server/session_store.h"

namespace meshgauge::server {

// Where a call's ray passes are: vertices of the current pass, and the rays
// of the whole call.
struct CallProgress {
  int64_t vertices_done = 0;
  int64_t vertices_total = 0;
  int64_t rays_total = 0;
};

// How a call may stop, and whom it tells of its progress.
struct CallControl {
  // Polled while the call waits for a slot and between blocks of work:
  // true when the caller left.
  std::function<bool()> cancelled = [] { return false; };
  // Past it, a call waiting for a slot stops, and a stopped call fails
  // DEADLINE_EXCEEDED instead of CANCELLED.
  std::chrono::system_clock::time_point deadline =
      std::chrono::system_clock::time_point::max();
  // Optional; called from one thread at a time, at most about 100 times
  // per pass (Sdf and GradCheck only).
  std::function<void(const CallProgress&)> progress;

  // `s`, or for a CANCELLED one (the library's stop) the call's
  // DEADLINE_EXCEEDED or CANCELLED.
  absl::Status Interrupted(absl::Status s) const;
};

// The session and the positions and parameters a compute call is about.
struct SessionTarget {
  std::string session_id;
  SdfParams params;  // already checked (wire::FromWire).
  // ABORTED (GenerationMismatch) when the session is at another one.
  std::optional<int64_t> expected_generation;
};

// A ComputeSdf result, no longer holding the session's lock or a slot.
struct SdfOutcome {
  std::shared_ptr<const CachedPass> pass;  // its result is the values.
  std::optional<SparseJacobian> jacobian;  // when asked for.
  // The Jacobian's memory, accounted until the outcome is dropped.
  std::unique_ptr<ScratchClaim> jacobian_claim;
  int dimension = 3;
  double integral = 0;                // IntegrateSdf's value.
  std::vector<std::string> warnings;  // MissingValueWarnings.
  wire::CallFacts facts;
};

struct VjpOutcome {
  wire::VjpReply reply;
  int dimension = 3;  // of the gradient's vectors.
};

struct PenaltyOutcome {
  wire::PenaltyReply reply;
  int dimension = 3;                // of the gradient's vectors.
  std::optional<ThinSurface> thin;  // when a thin surface was asked for.
};

struct GradCheckOutcome {
  GradCheckReport report;
  wire::CallFacts facts;  // reused_hits is always false.
};

// A session's mesh, read under its lock (held while the view lives).
struct MeshView {
  std::shared_ptr<Session> session;
  Session::Reader reader;
  const Mesh& mesh() const { return reader.evaluator->mesh(); }
};

class SessionCalls {
 public:
  // All pointers must outlive the object. Every method works in `tenant`'s
  // namespace. Errors of every compute call: those of ComputeSlots::Take
  // (through control.Interrupted), of SessionStore::Get (NOT_FOUND), of
  // Session::Read, ABORTED for a generation other than the expected one,
  // RESOURCE_EXHAUSTED when the pass's memory cannot be claimed, and
  // CANCELLED or DEADLINE_EXCEEDED when `control` stops the call.
  SessionCalls(const ServerOptions& options, SessionStore* store,
               Metrics* metrics);

  // The target's ray pass and, when `with_jacobian`, its Jacobian (its
  // memory claimed first: RESOURCE_EXHAUSTED).
  absl::StatusOr<SdfOutcome> Sdf(const std::string& tenant,
                                 const SessionTarget& target,
                                 bool with_jacobian,
                                 const CallControl& control);
  // g^T J of the target's pass. Errors: RESOURCE_EXHAUSTED when the reply
  // would exceed --max_message_bytes, INVALID_ARGUMENT unless `weights`
  // holds one value per sample (both before any ray is traced).
  absl::StatusOr<VjpOutcome> Vjp(const std::string& tenant,
                                 const SessionTarget& target,
                                 absl::Span<const double> weights,
                                 const CallControl& control);
  // The penalty `penalty` of the target's pass (its gradient when
  // `with_gradient`) and, with `thin`, the thin regions. Errors:
  // RESOURCE_EXHAUSTED when the reply would exceed --max_message_bytes
  // (before tracing); the thin-region search's INVALID_ARGUMENT.
  // A range target (a part of a fanned-out penalty) needs `values`, every
  // sample's value, whose range must be its pass's bit for bit
  // (INVALID_ARGUMENT otherwise, and for values without a range): the
  // penalty is computed from them, the gradient is the range's part
  // (PenaltyResult::vjp_sums), and the measure part and thin regions come
  // with the range that begins at 0 only.
  absl::StatusOr<PenaltyOutcome> Penalty(
      const std::string& tenant, const SessionTarget& target,
      const PenaltyParams& penalty,
      const std::optional<wire::ThinRequest>& thin, bool with_gradient,
      const CallControl& control, absl::Span<const double> values = {});
  // The calibration of `params` on the session (params.sdf is the target's
  // parameters; no expected generation).
  absl::StatusOr<CalibrationReport> Calibrate(const std::string& tenant,
                                              const std::string& session_id,
                                              const CalibrationParams& params,
                                              const CallControl& control);
  // A finite-difference check on a private copy of the session's mesh (its
  // memory claimed first; the session's lock is let go once it is copied).
  // Errors: ValidateGradCheck's, before the copy.
  absl::StatusOr<GradCheckOutcome> GradCheck(const std::string& tenant,
                                             const SessionTarget& target,
                                             const GradCheckOptions& options,
                                             const CallControl& control);
  // The session's mesh (no slot taken). Errors: NOT_FOUND,
  // RESOURCE_EXHAUSTED when the reply would exceed --max_message_bytes.
  absl::StatusOr<MeshView> GetMesh(const std::string& tenant,
                                   const std::string& session_id);

  // The computation slots (for tests and diagnostics).
  const ComputeSlots& slots() const { return slots_; }

 private:
  // The front half of every compute call.
  struct Prepared {
    ComputeSlots::Slot slot;  // released last, after the session's lock.
    std::shared_ptr<Session> session;
    Session::Reader reader;
    SdfParams params;
    const SdfEvaluator& evaluator() const { return *reader.evaluator; }
  };
  struct Pass {
    std::shared_ptr<const CachedPass> pass;
    bool reused = false;
  };
  absl::StatusOr<Prepared> Prepare(const std::string& tenant,
                                   const SessionTarget& target,
                                   const CallControl& control);
  // The prepared session's pass for its parameters at the reader's
  // generation: cached, or traced now under `control` (its progress when
  // `with_progress`) and cached; a new pass's memory is claimed for
  // `tenant` before it is traced.
  absl::StatusOr<Pass> EnsurePass(const std::string& tenant,
                                  const Prepared& prep,
                                  const CallControl& control,
                                  bool with_progress);

  const ServerOptions& options_;
  SessionStore* store_;
  Metrics* metrics_;
  ComputeSlots slots_;
};

}  // namespace meshgauge::server
