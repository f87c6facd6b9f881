#include "server/session_cache.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace meshgauge::server {

SessionCache::SessionCache(const ServerOptions& options, Metrics* metrics,
                           const Clock* clock, bool records_hold_limits)
    : options_(options),
      metrics_(metrics),
      clock_(clock),
      records_hold_limits_(records_hold_limits) {}

absl::Status SessionCache::CheckCountLimitsLocked(
    const std::string& tenant, int64_t tenant_uploads) const {
  if (records_hold_limits_) return absl::OkStatus();
  if (std::ssize(sessions_) + reserved_total_.uploads >=
      options_.max_sessions) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the server holds the maximum of ", options_.max_sessions,
        " sessions and uploads in flight (--max_sessions); delete one first"));
  }
  if (options_.max_sessions_per_tenant > 0 &&
      TenantSessionsLocked(tenant) + tenant_uploads >=
          options_.SessionsPerTenant()) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "this tenant holds its maximum of ", options_.SessionsPerTenant(),
        " sessions and uploads in flight (--max_sessions_per_tenant); delete "
        "one first"));
  }
  return absl::OkStatus();
}

absl::Status SessionCache::CheckBudgets(int64_t bytes) const {
  if (bytes <= options_.memory_budget_bytes &&
      bytes <= options_.BudgetPerTenant()) {
    return absl::OkStatus();
  }
  return absl::ResourceExhaustedError(absl::StrCat(
      "the mesh needs about ", bytes, " bytes, more than the memory budget of ",
      std::min(options_.memory_budget_bytes, options_.BudgetPerTenant()),
      " bytes (--memory_budget_bytes / --memory_budget_bytes_per_tenant)"));
}

absl::StatusOr<UploadReservation> SessionCache::Reserve(
    const std::string& tenant, int64_t bytes) {
  if (absl::Status s = CheckBudgets(bytes); !s.ok()) return s;
  UploadClaim claim;
  claim.tenant = tenant;
  claim.bytes = bytes;
  if (records_hold_limits_) {
    // The slot is claimed in the records, over all replicas, for a while
    // that every arriving message renews (ArriveUpload).
    claim.token = NewIncarnation();
    if (absl::Status s = UploadClaimed(tenant, claim.token, bytes); !s.ok()) {
      return s;
    }
    claim.renewed_at = clock_->NowSeconds();
  }
  if (absl::Status s = ClaimLocally(claim); !s.ok()) {
    if (!claim.token.empty()) {
      UploadReleased(tenant, claim.token);  // not under mu_.
    }
    return s;
  }
  return UploadReservation(this, std::move(claim));
}

double SessionCache::ClaimSeconds() const {
  return std::min(options_.upload_deadline_seconds,
                  2 * options_.upload_idle_seconds);
}

absl::Status SessionCache::CheckTenantBudgetLocked(const std::string& tenant,
                                                   int64_t bytes) const {
  if (records_hold_limits_ || options_.memory_budget_bytes_per_tenant == 0) {
    return absl::OkStatus();
  }
  auto reserved = reserved_.find(tenant);
  auto scratch = scratch_.find(tenant);
  const int64_t held =
      TenantBytesLocked(tenant) +
      (reserved == reserved_.end() ? 0 : reserved->second.bytes) +
      (scratch == scratch_.end() ? 0 : scratch->second);
  if (held + bytes <= options_.BudgetPerTenant()) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrCat(
      "this tenant's sessions, uploads and computations would exceed its "
      "memory budget of ",
      options_.BudgetPerTenant(),
      " bytes (--memory_budget_bytes_per_tenant); delete a session first or "
      "retry later"));
}

absl::Status SessionCache::CheckBytesLocked(const std::string& tenant,
                                            int64_t bytes) const {
  if (absl::Status s = CheckTenantBudgetLocked(tenant, bytes); !s.ok()) {
    return s;
  }
  // Against the server's budget: this tenant's reservations, and only the
  // bytes other tenants' uploads received (reserved but unsent bytes hold
  // no memory: a tenant that declares a large upload and sends nothing
  // blocks its own share, never another tenant's upload).
  auto mine = reserved_.find(tenant);
  const int64_t own =
      mine == reserved_.end() ? 0 : mine->second.bytes - mine->second.arrived;
  if (reserved_total_.arrived + own + bytes > options_.memory_budget_bytes) {
    return absl::ResourceExhaustedError(
        "uploads in flight hold the server's memory budget; retry later");
  }
  return absl::OkStatus();
}

absl::Status SessionCache::GrowUpload(UploadClaim& claim, int64_t bytes) {
  if (bytes <= claim.bytes) return absl::OkStatus();
  if (absl::Status s = CheckBudgets(bytes); !s.ok()) return s;
  const int64_t delta = bytes - claim.bytes;
  {
    absl::MutexLock lock(&mu_);
    if (absl::Status s = CheckBytesLocked(claim.tenant, delta); !s.ok()) {
      return s;
    }
    reserved_[claim.tenant].bytes += delta;
    reserved_total_.bytes += delta;
    claim.bytes = bytes;
    PublishLocked();
  }
  if (!claim.token.empty()) {
    // The claim is made again with its new size (its own old size is not
    // counted against the limits); refused, the local claim shrinks back.
    absl::Status s = UploadClaimed(claim.tenant, claim.token, bytes);
    if (!s.ok()) {
      absl::MutexLock lock(&mu_);
      reserved_[claim.tenant].bytes -= delta;
      reserved_total_.bytes -= delta;
      claim.bytes -= delta;
      PublishLocked();
      return s;
    }
    claim.renewed_at = clock_->NowSeconds();
  }
  return absl::OkStatus();
}

absl::Status SessionCache::ClaimLocally(const UploadClaim& claim) {
  const std::string& tenant = claim.tenant;
  const int64_t bytes = claim.bytes;
  absl::MutexLock lock(&mu_);
  Reserved& mine = reserved_[tenant];
  absl::Status refused = CheckCountLimitsLocked(tenant, mine.uploads);
  if (refused.ok()) refused = CheckBytesLocked(tenant, bytes);
  if (!refused.ok()) {
    if (mine.uploads == 0) reserved_.erase(tenant);
    return refused;
  }
  ++mine.uploads;
  mine.bytes += bytes;
  ++reserved_total_.uploads;
  reserved_total_.bytes += bytes;
  PublishLocked();
  return absl::OkStatus();
}

void SessionCache::ReleaseUpload(const UploadClaim& claim) {
  if (!claim.token.empty()) UploadReleased(claim.tenant, claim.token);
  absl::MutexLock lock(&mu_);
  ReleaseLocked(claim);
  PublishLocked();
}

void SessionCache::ConsumeLocked(UploadReservation& ticket) {
  // The records took the claim over, if any: it is only released here.
  if (ticket.ledger() == this) ReleaseLocked(ticket.HandOver());
}

void SessionCache::ReleaseLocked(const UploadClaim& claim) {
  auto it = reserved_.find(claim.tenant);
  if (it == reserved_.end()) return;
  --it->second.uploads;
  it->second.bytes -= claim.bytes;
  it->second.arrived -= claim.arrived;
  --reserved_total_.uploads;
  reserved_total_.bytes -= claim.bytes;
  reserved_total_.arrived -= claim.arrived;
  if (it->second.uploads == 0) reserved_.erase(it);
}

absl::Status SessionCache::ArriveUpload(UploadClaim& claim, int64_t bytes) {
  if (!claim.token.empty()) {
    const double now = clock_->NowSeconds();
    if (now - claim.renewed_at > options_.upload_idle_seconds / 2) {
      UploadRenewed(claim.tenant, claim.token);
      claim.renewed_at = now;
    }
  }
  // What was reserved bounds what may evict (the estimate covers the data).
  bytes = std::min(bytes, claim.bytes);
  if (bytes <= claim.arrived) return absl::OkStatus();
  absl::MutexLock lock(&mu_);
  const int64_t delta = bytes - claim.arrived;
  claim.arrived = bytes;
  reserved_[claim.tenant].arrived += delta;
  reserved_total_.arrived += delta;
  const bool fits = MakeRoomLocked(nullptr, &claim.tenant);
  PublishLocked();
  if (fits) return absl::OkStatus();
  return absl::ResourceExhaustedError(
      "the data of uploads in flight fill the server's memory budget "
      "(--memory_budget_bytes); retry later");
}

void SessionCache::Sweep() {
  absl::MutexLock lock(&mu_);
  const double now = clock_->NowSeconds();
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    auto next = std::next(it);
    if (now - it->second->last_used() > options_.session_ttl_seconds) {
      EvictLocked(it, "ttl");
    }
    it = next;
  }
  PublishLocked();
}

absl::StatusOr<std::unique_ptr<ScratchClaim>> SessionCache::ClaimScratch(
    const std::string& tenant, std::shared_ptr<Session> session, int64_t bytes,
    absl::string_view what) {
  const int64_t budget =
      std::min(options_.memory_budget_bytes, options_.BudgetPerTenant());
  if (session->memory_bytes() + bytes > budget) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the session (", session->memory_bytes(), " bytes) and ", what, " (",
        bytes, " bytes of scratch memory) need more than the memory budget of ",
        budget,
        " bytes (--memory_budget_bytes / --memory_budget_bytes_per_tenant); "
        "use fewer rays"));
  }
  absl::MutexLock lock(&mu_);
  if (absl::Status s = CheckTenantBudgetLocked(tenant, bytes); !s.ok()) {
    return s;
  }
  scratch_[tenant] += bytes;
  scratch_total_ += bytes;
  const bool fits = MakeRoomLocked(session.get(), &tenant);
  if (!fits) ReduceScratchLocked(tenant, bytes);
  PublishLocked();
  if (!fits) {
    return absl::ResourceExhaustedError(absl::StrCat(
        what, " (", bytes,
        " bytes of scratch memory) cannot be held in the server's memory "
        "budget now (other tenants' sessions fill it); retry later or use "
        "fewer rays"));
  }
  return std::make_unique<ScratchClaim>(static_cast<ClaimLedger*>(this), tenant,
                                        bytes);
}

void SessionCache::ReleaseScratch(const std::string& tenant, int64_t bytes) {
  absl::MutexLock lock(&mu_);
  ReduceScratchLocked(tenant, bytes);
  PublishLocked();
}

void SessionCache::ReduceScratchLocked(const std::string& tenant,
                                       int64_t bytes) {
  auto it = scratch_.find(tenant);
  if ((it->second -= bytes) == 0) scratch_.erase(it);
  scratch_total_ -= bytes;
}

void SessionCache::EnforceBudget(const Session* keep) {
  absl::MutexLock lock(&mu_);
  MakeRoomLocked(keep);
  PublishLocked();
}

bool SessionCache::MakeRoomLocked(const Session* keep,
                                  const std::string* for_tenant) {
  while (TotalBytesLocked() + reserved_total_.arrived + scratch_total_ >
         options_.memory_budget_bytes) {
    // What each tenant holds: its sessions, its uploads' arrived data and
    // its computations' scratch memory.
    std::map<std::string, int64_t> held;
    for (const auto& [key, s] : sessions_) held[key.first] += s->memory_bytes();
    for (const auto& [tenant, r] : reserved_) held[tenant] += r.arrived;
    for (const auto& [tenant, b] : scratch_) held[tenant] += b;
    // The tenant holding the most gives up its least recently used session
    // (never `keep`). When that is the tenant asking for room and it has
    // nothing left to give but its own upload, nobody else is evicted.
    auto most = held.begin();
    for (auto it = held.begin(); it != held.end(); ++it) {
      if (it->second > most->second) most = it;
    }
    auto victim = sessions_.end();
    for (auto it = sessions_.lower_bound({most->first, ""});
         it != sessions_.end() && it->first.first == most->first; ++it) {
      if (it->second.get() == keep) continue;
      if (victim == sessions_.end() ||
          it->second->last_used() < victim->second->last_used()) {
        victim = it;
      }
    }
    if (victim == sessions_.end() && for_tenant == nullptr) {
      // The largest holder has nothing evictable (only `keep` or uploads):
      // the next session by the same rule, from anyone.
      for (auto it = sessions_.begin(); it != sessions_.end(); ++it) {
        if (it->second.get() == keep) continue;
        if (victim == sessions_.end() ||
            held[it->first.first] > held[victim->first.first] ||
            (held[it->first.first] == held[victim->first.first] &&
             it->second->last_used() < victim->second->last_used())) {
          victim = it;
        }
      }
    }
    if (victim == sessions_.end()) return false;
    EvictLocked(victim, "memory");
  }
  return true;
}

int64_t SessionCache::size() const {
  absl::MutexLock lock(&mu_);
  return std::ssize(sessions_);
}

int64_t SessionCache::reserved_uploads() const {
  absl::MutexLock lock(&mu_);
  return reserved_total_.uploads;
}

void SessionCache::EvictLocked(Map::iterator it, const std::string& reason) {
  sessions_.erase(it);
  // With records only the cache entry goes; the session stays.
  metrics_->RecordEviction(records_hold_limits_ ? "cache_" + reason : reason);
}

int64_t SessionCache::TotalBytesLocked() const {
  int64_t total = 0;
  for (const auto& [key, s] : sessions_) total += s->memory_bytes();
  return total;
}

int64_t SessionCache::TenantBytesLocked(const std::string& tenant) const {
  int64_t total = 0;
  for (auto it = sessions_.lower_bound({tenant, ""});
       it != sessions_.end() && it->first.first == tenant; ++it) {
    total += it->second->memory_bytes();
  }
  return total;
}

int64_t SessionCache::TenantSessionsLocked(const std::string& tenant) const {
  int64_t n = 0;
  for (auto it = sessions_.lower_bound({tenant, ""});
       it != sessions_.end() && it->first.first == tenant; ++it) {
    ++n;
  }
  return n;
}

void SessionCache::PublishLocked() {
  metrics_->SetSessions(
      static_cast<double>(sessions_.size()),
      static_cast<double>(TotalBytesLocked() + reserved_total_.arrived +
                          scratch_total_));
}

}  // namespace meshgauge::server
