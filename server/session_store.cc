#include "server/session_store.h"

#include <chrono>
#include <random>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace meshgauge::server {

UploadReservation& UploadReservation::operator=(
    UploadReservation&& o) noexcept {
  if (this != &o) {
    if (store_) store_->Release(this);
    store_ = std::exchange(o.store_, nullptr);
    tenant_ = std::move(o.tenant_);
    token_ = std::move(o.token_);
    renewed_at_ = o.renewed_at_;
    bytes_ = std::exchange(o.bytes_, 0);
    arrived_ = std::exchange(o.arrived_, 0);
  }
  return *this;
}

UploadReservation::~UploadReservation() {
  if (store_) store_->Release(this);
}

absl::Status UploadReservation::Arrived(int64_t bytes) {
  return store_ ? store_->Arrive(this, bytes) : absl::OkStatus();
}

absl::Status UploadReservation::GrowTo(int64_t bytes) {
  return store_ ? store_->Grow(this, bytes) : absl::OkStatus();
}

SessionStore::SessionStore(const ServerOptions& options, Metrics* metrics,
                           const Clock* clock, SessionRecords* records)
    : options_(options), metrics_(metrics), clock_(clock), records_(records) {}

absl::Status SessionStore::CheckCountLimitsLocked(
    const std::string& tenant, int64_t tenant_uploads) const {
  if (records_) return absl::OkStatus();  // checked by the records.
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

RecordLimits SessionStore::Limits() const {
  return {options_.max_sessions, options_.SessionsPerTenant(),
          options_.BudgetPerTenant()};
}

absl::Status SessionStore::CheckBudgets(int64_t bytes) const {
  if (bytes <= options_.memory_budget_bytes &&
      bytes <= options_.BudgetPerTenant()) {
    return absl::OkStatus();
  }
  return absl::ResourceExhaustedError(absl::StrCat(
      "the mesh needs about ", bytes, " bytes, more than the memory budget of ",
      std::min(options_.memory_budget_bytes, options_.BudgetPerTenant()),
      " bytes (--memory_budget_bytes / --memory_budget_bytes_per_tenant)"));
}

absl::StatusOr<UploadReservation> SessionStore::Reserve(
    const std::string& tenant, int64_t bytes) {
  if (absl::Status s = CheckBudgets(bytes); !s.ok()) return s;
  UploadReservation r;
  r.tenant_ = tenant;
  r.bytes_ = bytes;
  if (records_) {
    // The slot is claimed in the records, over all replicas, for a while
    // that every arriving message renews (Arrive).
    r.token_ = NewIncarnation();
    if (absl::Status s = records_->Reserve(tenant, r.token_, bytes, Limits(),
                                           ClaimSeconds());
        !s.ok()) {
      return s;
    }
    r.renewed_at_ = clock_->NowSeconds();
  }
  if (absl::Status s = ClaimLocally(&r); !s.ok()) {
    if (records_) records_->Unreserve(tenant, r.token_);  // not under mu_.
    return s;
  }
  return r;
}

double SessionStore::ClaimSeconds() const {
  return std::min(options_.upload_deadline_seconds,
                  2 * options_.upload_idle_seconds);
}

absl::Status SessionStore::CheckBytesLocked(const std::string& tenant,
                                            int64_t bytes) const {
  auto mine = reserved_.find(tenant);
  const int64_t held = mine == reserved_.end() ? 0 : mine->second.bytes;
  if (!records_ && options_.memory_budget_bytes_per_tenant > 0 &&
      TenantBytesLocked(tenant) + held + bytes > options_.BudgetPerTenant()) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "this tenant's sessions and uploads would exceed its memory budget "
        "of ",
        options_.BudgetPerTenant(),
        " bytes (--memory_budget_bytes_per_tenant); delete a session first"));
  }
  if (reserved_total_.bytes + bytes > options_.memory_budget_bytes) {
    return absl::ResourceExhaustedError(
        "uploads in flight hold the server's memory budget; retry later");
  }
  return absl::OkStatus();
}

absl::Status SessionStore::Grow(UploadReservation* r, int64_t bytes) {
  if (bytes <= r->bytes_) return absl::OkStatus();
  if (absl::Status s = CheckBudgets(bytes); !s.ok()) return s;
  const int64_t delta = bytes - r->bytes_;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (absl::Status s = CheckBytesLocked(r->tenant_, delta); !s.ok()) {
      return s;
    }
    reserved_[r->tenant_].bytes += delta;
    reserved_total_.bytes += delta;
    r->bytes_ = bytes;
    PublishLocked();
  }
  if (records_ && !r->token_.empty()) {
    // The claim is made again with its new size (its own old size is not
    // counted against the limits); refused, the local claim shrinks back.
    absl::Status s = records_->Reserve(r->tenant_, r->token_, bytes, Limits(),
                                       ClaimSeconds());
    if (!s.ok()) {
      std::lock_guard<std::mutex> lock(mu_);
      reserved_[r->tenant_].bytes -= delta;
      reserved_total_.bytes -= delta;
      r->bytes_ -= delta;
      PublishLocked();
      return s;
    }
    r->renewed_at_ = clock_->NowSeconds();
  }
  return absl::OkStatus();
}

absl::Status SessionStore::ClaimLocally(UploadReservation* r) {
  const std::string& tenant = r->tenant_;
  const int64_t bytes = r->bytes_;
  std::lock_guard<std::mutex> lock(mu_);
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
  r->store_ = this;
  PublishLocked();
  return absl::OkStatus();
}

void SessionStore::Release(UploadReservation* r) {
  if (records_ && !r->token_.empty())
    records_->Unreserve(r->tenant_, r->token_);
  std::lock_guard<std::mutex> lock(mu_);
  ReleaseLocked(r);
  PublishLocked();
}

void SessionStore::ReleaseLocked(UploadReservation* r) {
  r->store_ = nullptr;
  auto it = reserved_.find(r->tenant_);
  if (it == reserved_.end()) return;
  --it->second.uploads;
  it->second.bytes -= r->bytes_;
  it->second.arrived -= r->arrived_;
  --reserved_total_.uploads;
  reserved_total_.bytes -= r->bytes_;
  reserved_total_.arrived -= r->arrived_;
  if (it->second.uploads == 0) reserved_.erase(it);
}

absl::Status SessionStore::Arrive(UploadReservation* r, int64_t bytes) {
  if (records_ && !r->token_.empty()) {
    const double now = clock_->NowSeconds();
    if (now - r->renewed_at_ > options_.upload_idle_seconds / 2) {
      records_->Renew(r->tenant_, r->token_, ClaimSeconds());
      r->renewed_at_ = now;
    }
  }
  // What was reserved bounds what may evict (the estimate covers the data).
  bytes = std::min(bytes, r->bytes_);
  if (bytes <= r->arrived_) return absl::OkStatus();
  std::lock_guard<std::mutex> lock(mu_);
  const int64_t delta = bytes - r->arrived_;
  r->arrived_ = bytes;
  reserved_[r->tenant_].arrived += delta;
  reserved_total_.arrived += delta;
  const bool fits = MakeRoomLocked(nullptr, &r->tenant_);
  PublishLocked();
  if (fits) return absl::OkStatus();
  return absl::ResourceExhaustedError(
      "the data of uploads in flight fill the server's memory budget "
      "(--memory_budget_bytes); retry later");
}

absl::StatusOr<std::shared_ptr<Session>> SessionStore::Create(
    const std::string& tenant, std::string id, RepairedMesh mesh,
    UploadReservation ticket) {
  const bool chosen = id.empty();
  if (!chosen && !ValidSessionId(id)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "session id ", QuoteId(id),
        " is invalid: use 1 to 64 characters from [A-Za-z0-9._-]"));
  }
  static thread_local std::mt19937_64 rng(std::random_device{}());
  auto random_id = [] { return absl::StrFormat("s-%016x", rng()); };
  if (records_) {
    // The record first: it decides existence and the limits, for all
    // replicas at once.
    if (chosen) id = random_id();
    SessionRecord record;
    record.mesh = mesh.mesh;
    // The BVH is built on first use, after the record was accepted.
    auto session = std::make_shared<Session>(id, std::move(mesh), options_,
                                             metrics_, clock_->NowSeconds());
    record.info = session->Info();
    record.incarnation = session->incarnation();
    absl::Status s = records_->Create(tenant, record, Limits(), ticket.token_);
    for (int retry = 0; chosen && retry < 3 && absl::IsAlreadyExists(s);
         ++retry) {
      record.info.session_id = random_id();
      s = records_->Create(tenant, record, Limits(), ticket.token_);
    }
    if (!s.ok()) return s;
    ticket.token_.clear();  // consumed by the record.
    if (record.info.session_id != id) {
      session = std::make_shared<Session>(record, options_, metrics_,
                                          clock_->NowSeconds());
    }
    std::lock_guard<std::mutex> lock(mu_);
    if (ticket.store_ == this) ReleaseLocked(&ticket);
    sessions_[Key{tenant, record.info.session_id}] = session;
    MakeRoomLocked(session.get());
    PublishLocked();
    return session;
  }
  std::lock_guard<std::mutex> lock(mu_);
  // The reservation becomes the session, under the same lock.
  if (ticket.store_ == this) ReleaseLocked(&ticket);
  if (chosen) {
    do {
      id = random_id();
    } while (sessions_.count({tenant, id}));
  } else if (sessions_.count({tenant, id})) {
    return absl::AlreadyExistsError(
        absl::StrCat("session ", QuoteId(id), " already exists"));
  }
  auto session = std::make_shared<Session>(id, std::move(mesh), options_,
                                           metrics_, clock_->NowSeconds());
  sessions_.emplace(Key{tenant, id}, session);
  MakeRoomLocked(session.get());
  PublishLocked();
  return session;
}

absl::StatusOr<std::shared_ptr<Session>> SessionStore::Get(
    const std::string& tenant, const std::string& id, bool touch) {
  if (records_) return GetRecorded(tenant, id, touch);
  std::lock_guard<std::mutex> lock(mu_);
  auto it = sessions_.find({tenant, id});
  if (it == sessions_.end()) {
    return SessionNotFound(id);
  }
  if (touch) it->second->Touch(clock_->NowSeconds());
  return it->second;
}

absl::StatusOr<std::shared_ptr<Session>> SessionStore::GetRecorded(
    const std::string& tenant, const std::string& id, bool touch) {
  if (!ValidSessionId(id)) return SessionNotFound(id);
  auto version = records_->Version(tenant, id, touch);
  if (!version.ok()) {
    if (absl::IsNotFound(version.status())) {
      std::lock_guard<std::mutex> lock(mu_);
      sessions_.erase({tenant, id});  // deleted or expired elsewhere.
    }
    return version.status();
  }
  // This replica's ray pass of the session at an earlier generation, which
  // the restored session's next pass reuses (the pass records its
  // positions; docs/numerics.md, "Incremental passes").
  std::shared_ptr<const CachedPass> earlier_pass;
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = sessions_.find({tenant, id});
    if (it != sessions_.end() &&
        it->second->incarnation() == version->incarnation) {
      if (it->second->generation() == version->generation) {
        if (touch) it->second->Touch(clock_->NowSeconds());
        metrics_->RecordSessionCache(true, 0);
        return it->second;
      }
      earlier_pass = it->second->CachedPassOfAnyGeneration();
    }
  }
  // A miss: first use on this replica, evicted, updated elsewhere, or
  // deleted and created again elsewhere.
  const double start = clock_->NowSeconds();
  const auto wall = std::chrono::steady_clock::now();
  auto record = records_->Load(tenant, id);
  if (!record.ok()) return record.status();
  auto session =
      std::make_shared<Session>(std::move(*record), options_, metrics_, start);
  if (auto reader = session->Read(); !reader.ok()) return reader.status();
  if (earlier_pass) session->StorePass(std::move(earlier_pass));
  metrics_->RecordSessionCache(
      false,
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall)
          .count());
  {
    std::lock_guard<std::mutex> lock(mu_);
    sessions_[Key{tenant, id}] = session;
    PublishLocked();
  }
  EnforceBudget(session.get());
  return session;
}

absl::Status SessionStore::Delete(const std::string& tenant,
                                  const std::string& id) {
  if (records_) {
    absl::Status s =
        ValidSessionId(id) ? records_->Delete(tenant, id) : SessionNotFound(id);
    std::lock_guard<std::mutex> lock(mu_);
    if (s.ok() || absl::IsNotFound(s)) sessions_.erase({tenant, id});
    PublishLocked();
    return s;
  }
  std::lock_guard<std::mutex> lock(mu_);
  auto it = sessions_.find({tenant, id});
  if (it == sessions_.end()) return SessionNotFound(id);
  sessions_.erase(it);
  PublishLocked();
  return absl::OkStatus();
}

absl::StatusOr<wire::UpdateResult> SessionStore::UpdatePositions(
    const std::string& tenant, const std::shared_ptr<Session>& session,
    int64_t expected_generation, const std::vector<int32_t>& indices,
    const std::vector<Vec3>& positions) {
  Session& s = *session;
  const std::string& id = s.id();
  if (!records_) {
    return s.UpdatePositions(expected_generation, indices, positions);
  }
  std::lock_guard<std::mutex> update_lock(s.update_mutex());
  // One generation ahead may be this very update, applied before its reply
  // was lost: the record's compare-and-set recognises it.
  const bool maybe_retry = s.generation() == expected_generation + 1;
  if (s.generation() != expected_generation && !maybe_retry) {
    return GenerationMismatch(id, s.generation(), expected_generation,
                              "update");
  }
  // The new positions of every vertex, validated before the record changes.
  std::vector<Vec3> all;
  {
    auto reader = s.Read();
    if (!reader.ok()) return reader.status();
    Mesh moved = reader->evaluator->mesh();
    if (indices.empty()) {
      // Checked here, against this incarnation's mesh: the caller's count
      // check may have seen another incarnation (deleted and re-created in
      // between), and extra points would pass validation as unused
      // vertices, then corrupt the record.
      if (absl::Status c = CheckPointCount(std::ssize(positions),
                                           std::ssize(moved.positions), false);
          !c.ok()) {
        return c;
      }
      moved.positions = positions;
    } else if (absl::Status v =
                   MoveVertices(indices, positions, &moved.positions);
               !v.ok()) {
      return v;
    }
    if (absl::Status v = ValidateMesh(moved); !v.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("position update rejected: ", v.message()));
    }
    all = std::move(moved.positions);
  }
  // The positions were checked against this incarnation's mesh: the record
  // takes them only if it is still that incarnation.
  auto committed = records_->CommitPositions(
      tenant, id, {expected_generation, s.incarnation()}, all,
      IsBvhBase(expected_generation + 1, options_.rebuild_every_updates));
  if (!committed.ok()) return committed.status();
  if (maybe_retry) {
    return wire::UpdateResult{
        .generation = *committed,
        .refit = !IsBvhBase(*committed, options_.rebuild_every_updates)};
  }
  auto outcome = s.UpdatePositions(expected_generation, {}, all);
  if (!outcome.ok()) {
    // The record moved on; this cache entry (if still this one) is stale.
    std::lock_guard<std::mutex> lock(mu_);
    if (auto it = sessions_.find({tenant, id});
        it != sessions_.end() && it->second == session) {
      sessions_.erase(it);
    }
  }
  return outcome;
}

absl::StatusOr<std::vector<SessionSnapshot>> SessionStore::List(
    const std::string& tenant, const std::string& page_token, int page_size,
    std::string* next_token) {
  if (records_) {
    auto listed = records_->List(tenant, page_token, page_size, next_token);
    if (!listed.ok()) return listed.status();
    const double now = clock_->NowSeconds();
    std::vector<SessionSnapshot> out;
    std::lock_guard<std::mutex> lock(mu_);
    for (const RecordSummary& record : *listed) {
      const wire::SessionInfo& info = record.info;
      SessionSnapshot s;
      auto it = sessions_.find({tenant, info.session_id});
      if (it != sessions_.end() &&
          it->second->incarnation() == record.incarnation &&
          it->second->generation() == info.generation) {
        s = it->second->Snapshot();  // with this replica's BVH counts.
      } else {
        s.info = info;
      }
      s.last_used = now - info.idle_seconds;
      out.push_back(std::move(s));
    }
    return out;
  }
  std::vector<std::shared_ptr<Session>> page;
  next_token->clear();
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (auto it = sessions_.upper_bound({tenant, page_token});
         it != sessions_.end() && it->first.first == tenant; ++it) {
      if (std::ssize(page) == page_size) {
        *next_token = page.back()->id();
        break;
      }
      page.push_back(it->second);
    }
  }
  std::vector<SessionSnapshot> out;
  for (const auto& s : page) out.push_back(s->Snapshot());
  return out;
}

void SessionStore::Sweep() {
  std::lock_guard<std::mutex> lock(mu_);
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

ScratchClaim::~ScratchClaim() {
  store_->ReleaseScratch(session_.get(), bytes_);
}

absl::StatusOr<std::unique_ptr<ScratchClaim>> SessionStore::ClaimScratch(
    const std::string& tenant, std::shared_ptr<Session> session,
    int64_t bytes) {
  const int64_t budget =
      std::min(options_.memory_budget_bytes, options_.BudgetPerTenant());
  if (session->memory_bytes() + bytes > budget) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the session and this computation's scratch memory (a private copy "
        "of the mesh and its passes) need about ",
        session->memory_bytes() + bytes,
        " bytes, more than the memory budget of ", budget,
        " bytes (--memory_budget_bytes / --memory_budget_bytes_per_tenant); "
        "use fewer rays"));
  }
  std::lock_guard<std::mutex> lock(mu_);
  if (absl::Status s = CheckBytesLocked(tenant, bytes); !s.ok()) return s;
  session->AddScratchBytes(bytes);
  const bool fits = MakeRoomLocked(session.get(), &tenant);
  if (!fits) session->AddScratchBytes(-bytes);
  PublishLocked();
  if (!fits) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the computation needs about ", bytes,
        " bytes of scratch memory, which the server's memory budget cannot "
        "hold now (other tenants' sessions fill it); retry later"));
  }
  return std::make_unique<ScratchClaim>(this, std::move(session), bytes);
}

void SessionStore::ReleaseScratch(Session* session, int64_t bytes) {
  std::lock_guard<std::mutex> lock(mu_);
  session->AddScratchBytes(-bytes);
  PublishLocked();
}

void SessionStore::EnforceBudget(const Session* keep) {
  std::lock_guard<std::mutex> lock(mu_);
  MakeRoomLocked(keep);
  PublishLocked();
}

bool SessionStore::MakeRoomLocked(const Session* keep,
                                  const std::string* for_tenant) {
  while (TotalBytesLocked() + reserved_total_.arrived >
         options_.memory_budget_bytes) {
    // What each tenant holds: its sessions and its uploads' arrived data.
    std::map<std::string, int64_t> held;
    for (const auto& [key, s] : sessions_) held[key.first] += s->memory_bytes();
    for (const auto& [tenant, r] : reserved_) held[tenant] += r.arrived;
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

int64_t SessionStore::size() const {
  std::lock_guard<std::mutex> lock(mu_);
  return std::ssize(sessions_);
}

int64_t SessionStore::reserved_uploads() const {
  std::lock_guard<std::mutex> lock(mu_);
  return reserved_total_.uploads;
}

void SessionStore::EvictLocked(Map::iterator it, const std::string& reason) {
  sessions_.erase(it);
  // With records only the cache entry goes; the session stays.
  metrics_->RecordEviction(records_ ? "cache_" + reason : reason);
}

int64_t SessionStore::TotalBytesLocked() const {
  int64_t total = 0;
  for (const auto& [key, s] : sessions_) total += s->memory_bytes();
  return total;
}

int64_t SessionStore::TenantBytesLocked(const std::string& tenant) const {
  int64_t total = 0;
  for (auto it = sessions_.lower_bound({tenant, ""});
       it != sessions_.end() && it->first.first == tenant; ++it) {
    total += it->second->memory_bytes();
  }
  return total;
}

int64_t SessionStore::TenantSessionsLocked(const std::string& tenant) const {
  int64_t n = 0;
  for (auto it = sessions_.lower_bound({tenant, ""});
       it != sessions_.end() && it->first.first == tenant; ++it) {
    ++n;
  }
  return n;
}

void SessionStore::PublishLocked() {
  metrics_->SetSessions(
      static_cast<double>(sessions_.size()),
      static_cast<double>(TotalBytesLocked() + reserved_total_.arrived));
}

}  // namespace meshgauge::server
