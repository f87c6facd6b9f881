// What both session stores share (session_store.h): the sessions this
// process holds by (tenant, id), the uploads' reservations and the
// computations' scratch claims, eviction under the memory budget (the rule
// at the top of session_store.h), the idle TTL and the session gauges.
// InMemorySessionStore and RecordedSessionStore add the sessions' life
// (create, get, delete, update, list); the records' claims on upload slots
// come in through the Upload* hooks.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <utility>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "server/clock.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/session_store.h"

namespace meshgauge::server {

// The ledger of its own reservations and scratch claims.
class SessionCache : public SessionStore, private ClaimLedger {
 public:
  // `records_hold_limits`: the session counts and per-tenant budgets are
  // the records' to check (over all replicas); evictions then drop cache
  // entries (metric reason "cache_..."). options, metrics and clock must
  // outlive the cache.
  SessionCache(const ServerOptions& options, Metrics* metrics,
               const Clock* clock, bool records_hold_limits);

  absl::StatusOr<UploadReservation> Reserve(const std::string& tenant,
                                            int64_t bytes) override;
  absl::StatusOr<std::unique_ptr<ScratchClaim>> ClaimScratch(
      const std::string& tenant, std::shared_ptr<Session> session,
      int64_t bytes, absl::string_view what) override;
  void Sweep() override;
  void EnforceBudget(const Session* keep) override;
  int64_t size() const override;
  int64_t reserved_uploads() const override;

 protected:
  using Key = std::pair<std::string, std::string>;  // (tenant, id).
  using Map = std::map<Key, std::shared_ptr<Session>>;

  // The records' claim on an upload slot (token: the claim's id), made
  // when the upload reserves, again when it grows, renewed as its data
  // arrive, dropped when it ends; only when records hold the limits.
  virtual absl::Status UploadClaimed(const std::string& /*tenant*/,
                                     const std::string& /*token*/,
                                     int64_t /*bytes*/) {
    return absl::OkStatus();
  }
  virtual void UploadRenewed(const std::string& /*tenant*/,
                             const std::string& /*token*/) {}
  virtual void UploadReleased(const std::string& /*tenant*/,
                              const std::string& /*token*/) {}

  // Consumes the upload's reservation (under mu_): it becomes a session.
  void ConsumeLocked(UploadReservation& ticket) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Evicts while sessions, uploads' arrived bytes and scratch exceed the
  // budget; false when nothing may be evicted. For an upload or scratch of
  // `for_tenant` (not null), only the tenant holding the most bytes gives up
  // sessions: it never pushes out a tenant that holds less than its own tenant.
  bool MakeRoomLocked(const Session* keep,
                      const std::string* for_tenant = nullptr) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void PublishLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // How long a claim in the records lives unless renewed.
  double ClaimSeconds() const;

  const ServerOptions& options_;
  Metrics* metrics_;
  const Clock* clock_;
  mutable absl::Mutex mu_;
  Map sessions_ ABSL_GUARDED_BY(mu_);

 private:
  // ClaimLedger.
  absl::Status ArriveUpload(UploadClaim& claim, int64_t bytes) override;
  absl::Status GrowUpload(UploadClaim& claim, int64_t bytes) override;
  void ReleaseUpload(const UploadClaim& claim) override;
  void ReleaseScratch(const std::string& tenant, int64_t bytes) override;

  void ReleaseLocked(const UploadClaim& claim) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // RESOURCE_EXHAUSTED when `bytes` exceed a budget by themselves.
  absl::Status CheckBudgets(int64_t bytes) const;
  // RESOURCE_EXHAUSTED when `bytes` more for `tenant` would exceed its
  // budget: its sessions, upload reservations and scratch counted (unless
  // records hold the limits).
  absl::Status CheckTenantBudgetLocked(const std::string& tenant,
                                       int64_t bytes) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // The same for an upload, and the uploads' share of the server's budget.
  absl::Status CheckBytesLocked(const std::string& tenant, int64_t bytes) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void ReduceScratchLocked(const std::string& tenant, int64_t bytes) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // The local half of Reserve (counts, budgets) under mu_.
  absl::Status ClaimLocally(const UploadClaim& claim);
  absl::Status CheckCountLimitsLocked(const std::string& tenant,
                                      int64_t tenant_uploads) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void EvictLocked(Map::iterator it, const std::string& reason) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  int64_t TotalBytesLocked() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  int64_t TenantBytesLocked(const std::string& tenant) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  int64_t TenantSessionsLocked(const std::string& tenant) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const bool records_hold_limits_;
  struct Reserved {
    int64_t uploads = 0, bytes = 0, arrived = 0;
  };
  std::map<std::string, Reserved> reserved_ ABSL_GUARDED_BY(mu_);  // by tenant.
  Reserved reserved_total_ ABSL_GUARDED_BY(mu_);
  // Claimed, by tenant.
  std::map<std::string, int64_t> scratch_ ABSL_GUARDED_BY(mu_);
  int64_t scratch_total_ ABSL_GUARDED_BY(mu_) = 0;
};

}  // namespace meshgauge::server
