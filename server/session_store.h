// All sessions of a server: creation with limits, lookup, listing, deletion,
// position updates, idle-TTL and memory-budget (LRU) eviction, and the
// reservations of uploads in flight. Sessions live in their tenant's
// namespace: one tenant cannot see, touch or squat another's ids (in open
// mode every caller is tenant "").
//
// Two implementations (MakeSessionStore in make_session_store.h picks one
// from the options), both on one SessionCache (session_cache.h: the map,
// memory accounting, eviction and TTL):
// - InMemorySessionStore: the sessions are this process's; eviction and TTL
//   remove them.
// - RecordedSessionStore (SessionRecords, e.g. Redis): the records define
//   the sessions, for every replica alike; the cache holds the evaluator,
//   BVH and last ray pass per session and generation, loaded on a miss.
//   Eviction drops cache entries, never a session; count and byte limits
//   are checked over all replicas when a record is created; delete, TTL and
//   listing are global. Every cached read checks the record's generation
//   and incarnation, so a session deleted and created again elsewhere is
//   never served from the old one's cache.
//
// Memory: an upload's header claims its declared size against the
// uploads' share (reservations alone never exceed the budget) and, per
// tenant, against the tenant's budget and session limit; a header evicts
// nothing. Eviction makes room only for bytes that have arrived (an
// upload's buffered data, a new session, a cached ray pass, a computation's
// scratch memory): its victim is the least recently used session of the
// tenant that holds the most bytes, so one tenant filling the budget evicts
// its own sessions first.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/session.h"
#include "server/session_messages.h"

namespace meshgauge::server {

class UploadReservation;

// An upload's claim as its store accounts it.
struct UploadClaim {
  std::string tenant;
  std::string token;      // the claim in the records, if any.
  double renewed_at = 0;  // when the claim was last made or renewed.
  int64_t bytes = 0;      // claimed.
  int64_t arrived = 0;    // buffered so far.
};

// Where upload reservations and scratch claims are accounted (the store
// that made them): they report here as they change and end.
class ClaimLedger {
 public:
  // UploadReservation::Arrived and GrowTo, on the reservation's claim.
  virtual absl::Status ArriveUpload(UploadClaim& claim, int64_t bytes) = 0;
  virtual absl::Status GrowUpload(UploadClaim& claim, int64_t bytes) = 0;
  // The reservation ended unconsumed: its claim is given back.
  virtual void ReleaseUpload(const UploadClaim& claim) = 0;
  // A ScratchClaim ended.
  virtual void ReleaseScratch(const std::string& tenant, int64_t bytes) = 0;

 protected:
  ~ClaimLedger() = default;
};

// An upload's claim on a session slot and memory, taken at its header
// before any data is buffered; released when destroyed or consumed by
// SessionStore::Create.
class UploadReservation {
 public:
  UploadReservation() = default;
  // A claim accounted in `ledger` (not null; outlives the reservation).
  UploadReservation(ClaimLedger* ledger, UploadClaim claim)
      : ledger_(ledger), claim_(std::move(claim)) {}
  UploadReservation(UploadReservation&& o) noexcept { *this = std::move(o); }
  UploadReservation& operator=(UploadReservation&& o) noexcept;
  ~UploadReservation();
  int64_t bytes() const { return claim_.bytes; }
  const UploadClaim& claim() const { return claim_; }
  // The ledger that accounts the claim; null once released or handed over.
  const ClaimLedger* ledger() const { return ledger_; }
  // The upload now buffers `bytes` in all: evicts (see above) to make room
  // for them. RESOURCE_EXHAUSTED when the budget cannot hold them (other
  // uploads' data fill it).
  absl::Status Arrived(int64_t bytes);  // also renews the claim.
  // Claims `bytes` in all (when more than now), under the same limits as
  // SessionStore::Reserve; RESOURCE_EXHAUSTED (nothing changed) when they
  // do not fit. For an upload whose size is known only once it is parsed.
  absl::Status GrowTo(int64_t bytes);
  // Hands the claim over (a session took its place): the ledger is no
  // longer told of it, and this reservation holds nothing.
  UploadClaim HandOver();

 private:
  ClaimLedger* ledger_ = nullptr;
  UploadClaim claim_;
};

// A computation's memory beyond its session's (a ray pass being traced, a
// gradcheck's private copy of the mesh and its passes), accounted to its
// tenant while it lives (SessionStore::ClaimScratch).
class ScratchClaim {
 public:
  // `bytes` of `tenant` accounted in `ledger` (not null; outlives the
  // claim).
  ScratchClaim(ClaimLedger* ledger, std::string tenant, int64_t bytes)
      : ledger_(ledger), tenant_(std::move(tenant)), bytes_(bytes) {}
  ScratchClaim(const ScratchClaim&) = delete;
  ScratchClaim& operator=(const ScratchClaim&) = delete;
  ~ScratchClaim() { ledger_->ReleaseScratch(tenant_, bytes_); }

 private:
  ClaimLedger* const ledger_;
  const std::string tenant_;
  const int64_t bytes_;
};

class SessionStore {
 public:
  virtual ~SessionStore() = default;

  // Claims a slot and `bytes` for an upload of `tenant`; evicts nothing.
  // Errors: RESOURCE_EXHAUSTED when the sessions plus uploads would exceed
  // --max_sessions or the tenant's limit (with records: over all
  // replicas), when the tenant's sessions and uploads would exceed its
  // budget, or when the uploads in flight would exceed the server's budget.
  virtual absl::StatusOr<UploadReservation> Reserve(const std::string& tenant,
                                                    int64_t bytes) = 0;

  // Adds a session for a repaired and validated mesh under `tenant`,
  // consuming the upload's reservation. Empty id: a random one is chosen.
  // Errors: INVALID_ARGUMENT (bad id), ALREADY_EXISTS (in this tenant's
  // namespace).
  virtual absl::StatusOr<std::shared_ptr<Session>> Create(
      const std::string& tenant, std::string id, RepairedMesh mesh,
      UploadReservation ticket) = 0;

  // NOT_FOUND (SessionNotFound) for an unknown id and alike for another
  // tenant's, so ids do not leak. `touch`: the call uses the session
  // (resets its idle clock); GetSession only looks.
  virtual absl::StatusOr<std::shared_ptr<Session>> Get(
      const std::string& tenant, const std::string& id, bool touch) = 0;
  absl::StatusOr<std::shared_ptr<Session>> Get(const std::string& tenant,
                                               const std::string& id) {
    return Get(tenant, id, true);
  }
  virtual absl::Status Delete(const std::string& tenant,
                              const std::string& id) = 0;

  // Moves the vertices (all when indices is empty) of `session`, which Get
  // returned for `tenant` (one lookup per call); with records, the
  // generation and incarnation compare-and-set happens in the record first.
  // Errors: ABORTED (generation, incarnation), INVALID_ARGUMENT (positions,
  // indices), NOT_FOUND.
  virtual absl::StatusOr<wire::UpdateResult> UpdatePositions(
      const std::string& tenant, const std::shared_ptr<Session>& session,
      int64_t expected_generation, const std::vector<int32_t>& indices,
      const std::vector<Vec3>& positions, const UpdateControl& control) = 0;

  // The tenant's sessions with id > page_token, in id order, at most
  // page_size. Errors: only from records (UNAVAILABLE).
  virtual absl::StatusOr<std::vector<SessionSnapshot>> List(
      const std::string& tenant, const std::string& page_token, int page_size,
      std::string* next_token) = 0;

  // Accounts `bytes` of a computation's scratch memory on `session` to
  // `tenant` until the claim is destroyed (evicting the session meanwhile
  // frees none of them). Evicts by the upload rule (only from the tenant
  // holding the most bytes, never `session`). `what` names the memory in
  // errors ("this ray pass's hit table and values"). Errors:
  // RESOURCE_EXHAUSTED, nothing claimed, when the bytes exceed the tenant's
  // budget or the server's even after eviction.
  virtual absl::StatusOr<std::unique_ptr<ScratchClaim>> ClaimScratch(
      const std::string& tenant, std::shared_ptr<Session> session,
      int64_t bytes, absl::string_view what) = 0;

  // Evicts sessions (cache entries with records) idle longer than the TTL.
  virtual void Sweep() = 0;
  // Evicts (never `keep`) while the accounted memory (sessions and uploads'
  // arrived bytes) exceeds the budget; call after a session's cache grew.
  virtual void EnforceBudget(const Session* keep) = 0;
  // Sessions held here (cached ones with records).
  virtual int64_t size() const = 0;
  // Reservations of uploads in flight (server-wide).
  virtual int64_t reserved_uploads() const = 0;
};

}  // namespace meshgauge::server
