// One uploaded mesh and its cached state.
//
// Concurrency: computations hold the session's lock shared (many at once);
// UpdatePositions holds it exclusively. The evaluator (and its BVH) is built
// lazily by the first call that needs it. The last ray pass (values + hit
// table) is cached per (parameters, generation), so a VJP or penalty call at
// the same generation and parameters does not trace again.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/types/span.h"
#include "lib/core/components.h"
#include "lib/core/mesh_repair.h"
#include "lib/embree/sdf_evaluator.h"
#include "proto/wire/types.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/session_records.h"
#include "server/writer_first_mutex.h"

namespace meshgauge::server {

// A ray pass kept for reuse.
struct CachedPass {
  SdfParams params;
  int64_t generation = -1;
  SdfResult result;
  HitTable hits;
  int64_t bytes = 0;
};

// Whether a position update is still wanted when its turn comes.
struct UpdateControl {
  std::chrono::system_clock::time_point deadline =
      std::chrono::system_clock::time_point::max();
  std::function<bool()> cancelled = nullptr;  // the caller left.
};

struct SessionSnapshot {
  // info.memory_bytes includes the cached ray pass; the BVH counts are this
  // replica's; warnings are those of the upload (RepairAndDiagnose's);
  // idle_seconds is filled by ToSessionInfo.
  wire::SessionInfo info;
  double last_used = 0;
};

class Session {
 public:
  // A new session of a repaired, validated and diagnosed mesh (its
  // warnings are the session's); metrics must outlive the session.
  Session(std::string id, RepairedMesh mesh, const ServerOptions& options,
          Metrics* metrics, double now);
  // A session restored from its record (another replica may have created
  // and updated it): the BVH is built at the record's base positions and
  // refitted to the current ones, as on the replica that made the updates.
  Session(SessionRecord record, const ServerOptions& options, Metrics* metrics,
          double now);

  const std::string& id() const { return id_; }
  // Made at creation (NewIncarnation), kept in the record.
  const std::string& incarnation() const { return incarnation_; }
  int dimension() const { return dimension_; }
  int64_t num_vertices() const { return num_vertices_; }

  // Shared access to the evaluator for computations (builds it on first
  // use). Hold the returned object for the whole computation.
  struct Reader {
    std::shared_lock<WriterFirstMutex> lock;
    const SdfEvaluator* evaluator = nullptr;
    int64_t generation() const { return evaluator->generation(); }
  };
  // (Not analysed for thread safety: it hands its shared lock of mu_ to the
  // caller in the Reader, which clang's analysis cannot follow.)
  absl::StatusOr<Reader> Read() ABSL_NO_THREAD_SAFETY_ANALYSIS;

  // Exclusive: moves vertices and refits the BVH, or rebuilds it when the
  // new generation is a BVH base (IsBvhBase). It waits for the computations
  // already running (WriterFirstMutex: later ones wait for it) until
  // control.deadline, and is not applied when the caller gave up meanwhile.
  // Errors: ABORTED on a generation mismatch, INVALID_ARGUMENT for bad
  // positions, DEADLINE_EXCEEDED (nothing changed) when the deadline passed
  // first, CANCELLED when the caller left.
  absl::StatusOr<wire::UpdateResult> UpdatePositions(
      int64_t expected_generation, absl::Span<const int32_t> indices,
      absl::Span<const Vec3> positions, const UpdateControl& control = {});

  // The cached pass for these parameters at this generation, or null.
  std::shared_ptr<const CachedPass> FindPass(const SdfParams& params,
                                             int64_t generation) const;
  // The cached pass for these parameters at any generation (an earlier one
  // after updates), or null: a new pass reuses its rays.
  std::shared_ptr<const CachedPass> LatestPass(const SdfParams& params) const;
  // The cached pass whatever its parameters and generation, or null (a
  // replica hands it to the session it restores from the record).
  std::shared_ptr<const CachedPass> CachedPassOfAnyGeneration() const;
  void StorePass(std::shared_ptr<const CachedPass> pass);

  SessionSnapshot Snapshot() const;
  int64_t generation() const { return generation_.load(); }
  // The record of the session's current state (for a new external record).
  wire::SessionInfo Info() const;
  // Held across an external commit and the local update that follows.
  std::mutex& update_mutex() { return update_mu_; }
  int64_t memory_bytes() const { return base_bytes_ + cache_bytes_.load(); }
  void Touch(double now) { last_used_ = now; }
  double last_used() const { return last_used_.load(); }

  // Estimated bytes of a mesh's session without a cached pass: mesh,
  // topology and the Embree BVH.
  static int64_t EstimateBaseBytes(const Mesh& mesh);
  // The same from counts (an upload's header: primitives <= 2 x faces).
  static int64_t EstimateBytes(int64_t vertices, int64_t faces,
                               int64_t primitives);

 private:
  absl::Status EnsureEvaluator() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const std::string id_;
  const std::string incarnation_;
  const ServerOptions& options_;
  Metrics* metrics_;
  const int dimension_;
  const int64_t num_vertices_, num_faces_;
  const double signed_volume_;
  // At upload (or from the record): closed and the warnings are used.
  const MeshDiagnostics diagnostics_;
  const int64_t base_bytes_;
  mutable WriterFirstMutex mu_;
  // Until the evaluator takes them: the mesh at the BVH base and, when they
  // differ, the current positions.
  Mesh pending_mesh_ ABSL_GUARDED_BY(mu_);
  std::vector<Vec3> pending_positions_ ABSL_GUARDED_BY(mu_);
  std::unique_ptr<SdfEvaluator> evaluator_ ABSL_GUARDED_BY(mu_);
  std::mutex update_mu_;
  // evaluator_ once it exists, for Snapshot (which never takes mu_) to read
  // its BVH counts.
  std::atomic<const SdfEvaluator*> published_{nullptr};
  // Mirrors the evaluator's generation so Snapshot never takes mu_ (a
  // reader must not lock it twice).
  std::atomic<int64_t> generation_{0};
  mutable absl::Mutex cache_mu_;
  std::shared_ptr<const CachedPass> cache_ ABSL_GUARDED_BY(cache_mu_);
  std::atomic<int64_t> cache_bytes_{0};
  std::atomic<double> last_used_;
};

// Every SessionInfo field of a snapshot taken at `now` (clock seconds).
wire::SessionInfo ToSessionInfo(const SessionSnapshot& s, double now);

// 32 random hex digits (128 bits from the system's random source): a
// session's incarnation, an upload's claim.
std::string NewIncarnation();

}  // namespace meshgauge::server
