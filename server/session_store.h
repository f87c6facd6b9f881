// All sessions of a server: creation with limits, lookup, listing, deletion,
// position updates, idle-TTL and memory-budget (LRU) eviction, and the
// reservations of uploads in flight. Sessions live in their tenant's
// namespace: one tenant cannot see, touch or squat another's ids (in open
// mode every caller is tenant "").
//
// Two backends behind this one interface:
// - in memory (no records): the sessions are this process's; eviction and
//   TTL remove them.
// - external records (SessionRecords, e.g. Redis): the records define the
//   sessions, for every replica alike; this store keeps only a cache
//   (evaluator, BVH, last ray pass) per session and generation, loaded on a
//   miss. Eviction drops cache entries, never a session; count and byte
//   limits are checked over all replicas when a record is created; delete,
//   TTL and listing are global. Every cached read checks the record's
//   generation and incarnation, so a session deleted and created again
//   elsewhere is never served from the old one's cache.
//
// Memory: an upload's header claims its declared size against the
// uploads' share (reservations alone never exceed the budget) and, per
// tenant, against the tenant's budget and session limit; a header evicts
// nothing. Eviction makes room only for bytes that have arrived (an
// upload's buffered data, a new session, a cached ray pass): its victim is
// the least recently used session of the tenant that holds the most bytes,
// so one tenant filling the budget evicts its own sessions first.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "server/clock.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/session.h"
#include "server/session_messages.h"

namespace meshgauge::server {

class SessionStore;

// An upload's claim on a session slot and memory, taken at its header
// before any data is buffered; released when destroyed or consumed by
// SessionStore::Create.
class UploadReservation {
 public:
  UploadReservation() = default;
  UploadReservation(UploadReservation&& o) noexcept { *this = std::move(o); }
  UploadReservation& operator=(UploadReservation&& o) noexcept;
  ~UploadReservation();
  int64_t bytes() const { return bytes_; }
  // The upload now buffers `bytes` in all: evicts (see SessionStore) to
  // make room for them. RESOURCE_EXHAUSTED when the budget cannot hold
  // them (other uploads' data fill it).
  absl::Status Arrived(int64_t bytes);  // also renews the claim.
  // Claims `bytes` in all (when more than now), under the same limits as
  // SessionStore::Reserve; RESOURCE_EXHAUSTED (nothing changed) when they
  // do not fit. For an upload whose size is known only once it is parsed.
  absl::Status GrowTo(int64_t bytes);

 private:
  friend class SessionStore;
  SessionStore* store_ = nullptr;
  std::string tenant_;
  std::string token_;      // the claim in the records, if any.
  double renewed_at_ = 0;  // when the claim was last made or renewed.
  int64_t bytes_ = 0;
  int64_t arrived_ = 0;
};

// A computation's memory beyond its session's (a gradcheck's private copy
// of the mesh and its passes), accounted to the session while it lives.
class ScratchClaim {
 public:
  ScratchClaim(SessionStore* store, std::shared_ptr<Session> session,
               int64_t bytes)
      : store_(store), session_(std::move(session)), bytes_(bytes) {}
  ScratchClaim(const ScratchClaim&) = delete;
  ScratchClaim& operator=(const ScratchClaim&) = delete;
  ~ScratchClaim();

 private:
  SessionStore* store_;
  std::shared_ptr<Session> session_;
  int64_t bytes_;
};

class SessionStore {
 public:
  // options, metrics, clock and records (null: in memory) must outlive the
  // store.
  SessionStore(const ServerOptions& options, Metrics* metrics,
               const Clock* clock, SessionRecords* records = nullptr);

  // Claims a slot and `bytes` for an upload of `tenant`; evicts nothing.
  // Errors: RESOURCE_EXHAUSTED when the sessions plus uploads would exceed
  // --max_sessions or the tenant's limit (with records: over all
  // replicas), when the tenant's sessions and uploads would exceed its
  // budget, or when the uploads in flight would exceed the server's budget.
  absl::StatusOr<UploadReservation> Reserve(const std::string& tenant,
                                            int64_t bytes);

  // Adds a session for a repaired and validated mesh under `tenant`,
  // consuming the upload's reservation. Empty id: a random one is chosen.
  // Errors: INVALID_ARGUMENT (bad id), ALREADY_EXISTS (in this tenant's
  // namespace).
  absl::StatusOr<std::shared_ptr<Session>> Create(const std::string& tenant,
                                                  std::string id,
                                                  RepairedMesh mesh,
                                                  UploadReservation ticket);

  // NOT_FOUND names the id (and says it may have been evicted); the same
  // for another tenant's session, so ids do not leak. `touch`: the call uses
  // the session (resets its idle clock); GetSession only looks.
  absl::StatusOr<std::shared_ptr<Session>> Get(const std::string& tenant,
                                               const std::string& id,
                                               bool touch = true);
  absl::Status Delete(const std::string& tenant, const std::string& id);

  // Moves the vertices (all when indices is empty) of `session`, which Get
  // returned for `tenant` (one lookup per call); with records, the
  // generation and incarnation compare-and-set happens in the record first.
  // Errors: ABORTED (generation, incarnation), INVALID_ARGUMENT (positions,
  // indices), NOT_FOUND.
  absl::StatusOr<wire::UpdateResult> UpdatePositions(
      const std::string& tenant, const std::shared_ptr<Session>& session,
      int64_t expected_generation, const std::vector<int32_t>& indices,
      const std::vector<Vec3>& positions);

  // The tenant's sessions with id > page_token, in id order, at most
  // page_size. Errors: only from records (UNAVAILABLE).
  absl::StatusOr<std::vector<SessionSnapshot>> List(
      const std::string& tenant, const std::string& page_token, int page_size,
      std::string* next_token);

  // Accounts `bytes` of a computation's scratch memory to `session` (of
  // `tenant`) until the claim is destroyed. Evicts by the upload rule (only
  // from the tenant holding the most bytes, never `session`). Errors:
  // RESOURCE_EXHAUSTED, nothing claimed, when the bytes exceed the tenant's
  // budget or the server's even after eviction.
  absl::StatusOr<std::unique_ptr<ScratchClaim>> ClaimScratch(
      const std::string& tenant, std::shared_ptr<Session> session,
      int64_t bytes);

  // Evicts sessions idle longer than the TTL.
  void Sweep();
  // Evicts (never `keep`; see the top of this file) while the accounted
  // memory (sessions and uploads' arrived bytes) exceeds the budget; call
  // after a session's cache grew.
  void EnforceBudget(const Session* keep);
  int64_t size() const;
  // Reservations of uploads in flight (server-wide).
  int64_t reserved_uploads() const;

 private:
  friend class UploadReservation;
  friend class ScratchClaim;
  void ReleaseScratch(Session* session, int64_t bytes);
  using Key = std::pair<std::string, std::string>;  // (tenant, id).
  using Map = std::map<Key, std::shared_ptr<Session>>;
  void Release(UploadReservation* r);
  void ReleaseLocked(UploadReservation* r);
  absl::Status Arrive(UploadReservation* r, int64_t bytes);
  absl::Status Grow(UploadReservation* r, int64_t bytes);
  // RESOURCE_EXHAUSTED when `bytes` exceed a budget by themselves.
  absl::Status CheckBudgets(int64_t bytes) const;
  // RESOURCE_EXHAUSTED when `bytes` more for uploads of `tenant` would
  // exceed its budget or the server's (held reservations counted).
  absl::Status CheckBytesLocked(const std::string& tenant, int64_t bytes) const;
  // Evicts while sessions plus arrived bytes exceed the budget; false when
  // nothing may be evicted. For an upload of `for_tenant` (not null), only
  // the tenant holding the most bytes gives up sessions: an upload never
  // pushes out a tenant that holds less than its own tenant.
  bool MakeRoomLocked(const Session* keep,
                      const std::string* for_tenant = nullptr);
  // With records: the cached session at the record's generation, loading
  // the record on a miss.
  absl::StatusOr<std::shared_ptr<Session>> GetRecorded(
      const std::string& tenant, const std::string& id, bool touch);
  RecordLimits Limits() const;
  // How long a claim in the records lives unless renewed.
  double ClaimSeconds() const;
  // The local half of Reserve (counts, budgets) under mu_; sets r->store_.
  absl::Status ClaimLocally(UploadReservation* r);
  absl::Status CheckCountLimitsLocked(const std::string& tenant,
                                      int64_t tenant_uploads) const;
  void EvictLocked(Map::iterator it, const std::string& reason);
  int64_t TotalBytesLocked() const;
  int64_t TenantBytesLocked(const std::string& tenant) const;
  int64_t TenantSessionsLocked(const std::string& tenant) const;
  void PublishLocked();

  const ServerOptions& options_;
  Metrics* metrics_;
  const Clock* clock_;
  SessionRecords* const records_;
  mutable std::mutex mu_;
  Map sessions_;
  struct Reserved {
    int64_t uploads = 0, bytes = 0, arrived = 0;
  };
  std::map<std::string, Reserved> reserved_;  // by tenant.
  Reserved reserved_total_;
};

}  // namespace meshgauge::server
