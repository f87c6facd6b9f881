// What defines a session, kept outside a replica's memory so that any
// replica can serve it: the mesh (faces, regions, cone directions), the
// current positions and generation, the positions the BVH is built at, the
// owner (tenant) and sizes. A replica keeps only caches (session.h) built
// from a record. One implementation: RedisRecords (redis_records.h); a
// single server without --session_store keeps its sessions in memory only
// (SessionStore without records).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "proto/wire/types.h"

namespace meshgauge::server {

// info: the session's facts (memory_bytes: the accounted base size,
// Session::EstimateBaseBytes; signed_volume and warnings at upload;
// generation and idle_seconds filled by reads; the BVH counts are a
// replica's and not recorded).
struct SessionRecord {
  wire::SessionInfo info;
  // A random id made when the session is created (NewIncarnation). A
  // session deleted and created again under the same id has another one, so
  // a replica's cache of the old session is never taken for the new one.
  std::string incarnation;
  Mesh mesh;  // with the current positions (generation info.generation).
  // BVH base: the BVH of generation g is built at the positions of
  // generation base_generation = g - g % rebuild_every_updates and refitted
  // to the current ones, whichever replica serves it (values do not depend
  // on the BVH; this keeps its quality the same on every replica).
  int64_t base_generation = 0;
  std::vector<Vec3> base_positions;  // empty when base == current.
};

// What a replica checks its cached copy of a record against.
struct RecordVersion {
  int64_t generation = 0;
  std::string incarnation;
};

// A listed record: its facts and incarnation.
struct RecordSummary {
  wire::SessionInfo info;
  std::string incarnation;
};

// Limits enforced atomically at creation, over all replicas.
struct RecordLimits {
  int64_t max_sessions = 0;             // all tenants.
  int64_t max_sessions_per_tenant = 0;  // this tenant.
  int64_t max_bytes_per_tenant = 0;     // sum of memory_bytes, this tenant.
};

class SessionRecords {
 public:
  virtual ~SessionRecords() = default;
  // Where the records live, for messages (e.g. "redis://host:6379").
  virtual std::string Describe() const = 0;

  // Claims a session slot and `bytes` of the tenant's budget for an upload
  // in flight, under `token` (unique), for `ttl_seconds` unless renewed
  // (so a replica that dies mid-upload holds nothing for long). The limits
  // count records and live claims of every replica. Errors: RESOURCE_EXHAUSTED
  // naming the limit, UNAVAILABLE.
  virtual absl::Status Reserve(const std::string& tenant,
                               const std::string& token, int64_t bytes,
                               const RecordLimits& limits,
                               double ttl_seconds) = 0;
  // Extends a live claim to `ttl_seconds` from now (best effort).
  virtual void Renew(const std::string& tenant, const std::string& token,
                     double ttl_seconds) = 0;
  // Drops a claim (best effort: an unreachable store lets it expire).
  virtual void Unreserve(const std::string& tenant,
                         const std::string& token) = 0;
  // Stores a new record (generation 0), consuming the claim `token` (may
  // be empty): the limits count every other record and claim. Errors:
  // ALREADY_EXISTS, RESOURCE_EXHAUSTED naming the limit, UNAVAILABLE.
  virtual absl::Status Create(const std::string& tenant,
                              const SessionRecord& record,
                              const RecordLimits& limits,
                              const std::string& token) = 0;
  // The record's generation and incarnation; `touch` restarts its idle
  // clock (TTL). Errors: NOT_FOUND, UNAVAILABLE.
  virtual absl::StatusOr<RecordVersion> Version(const std::string& tenant,
                                                const std::string& id,
                                                bool touch) = 0;
  virtual absl::StatusOr<SessionRecord> Load(const std::string& tenant,
                                             const std::string& id) = 0;
  // Compare-and-set: when the record is the incarnation `expected.
  // incarnation` at expected.generation, stores `positions` (all vertices)
  // as generation expected + 1, and as the BVH base when `rebase`. The same
  // update retried after it was applied succeeds again (idempotent).
  // Errors: ABORTED (another generation, or the session was deleted and
  // created again since `expected` was read), NOT_FOUND, UNAVAILABLE.
  virtual absl::StatusOr<int64_t> CommitPositions(
      const std::string& tenant, const std::string& id,
      const RecordVersion& expected, const std::vector<Vec3>& positions,
      bool rebase) = 0;
  // Errors: NOT_FOUND, UNAVAILABLE.
  virtual absl::Status Delete(const std::string& tenant,
                              const std::string& id) = 0;
  // The tenant's records with id > after, in id order, at most limit;
  // *next is the last id when more follow, else empty.
  virtual absl::StatusOr<std::vector<RecordSummary>> List(
      const std::string& tenant, const std::string& after, int limit,
      std::string* next) = 0;
};

}  // namespace meshgauge::server
