#include "server/session_store.h"

#include <chrono>
#include <random>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace meshgauge::server {

bool ValidSessionId(const std::string& id) {
  if (id.empty() || id.size() > 64) return false;
  for (char c : id) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' ||
          c == '-')) {
      return false;
    }
  }
  return true;
}

std::string QuoteId(const std::string& id) {
  std::string s = absl::CHexEscape(id.substr(0, 80));
  if (id.size() > 80) s += "...";
  return absl::StrCat("'", s, "'");
}

UploadReservation& UploadReservation::operator=(
    UploadReservation&& o) noexcept {
  if (this != &o) {
    if (store_) store_->Release(tenant_, bytes_);
    store_ = std::exchange(o.store_, nullptr);
    tenant_ = std::move(o.tenant_);
    bytes_ = std::exchange(o.bytes_, 0);
  }
  return *this;
}

UploadReservation::~UploadReservation() {
  if (store_) store_->Release(tenant_, bytes_);
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

absl::StatusOr<UploadReservation> SessionStore::Reserve(
    const std::string& tenant, int64_t bytes) {
  const bool tenant_budget = options_.memory_budget_bytes_per_tenant > 0;
  if (bytes > options_.memory_budget_bytes ||
      bytes > options_.BudgetPerTenant()) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the mesh needs about ", bytes, " bytes, more than the memory budget ",
        "of ",
        std::min(options_.memory_budget_bytes, options_.BudgetPerTenant()),
        " bytes (--memory_budget_bytes / --memory_budget_bytes_per_tenant)"));
  }
  std::lock_guard<std::mutex> lock(mu_);
  Reserved& mine = reserved_[tenant];
  if (absl::Status s = CheckCountLimitsLocked(tenant, mine.uploads); !s.ok()) {
    if (mine.uploads == 0) reserved_.erase(tenant);
    return s;
  }
  if (!records_ && tenant_budget &&
      TenantBytesLocked(tenant) + mine.bytes + bytes >
          options_.BudgetPerTenant()) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "this tenant's sessions and uploads would exceed its memory budget "
        "of ",
        options_.BudgetPerTenant(),
        " bytes (--memory_budget_bytes_per_tenant); delete a session first"));
  }
  // Make room in the server's budget: least recently used first.
  while (TotalBytesLocked() + reserved_total_.bytes + bytes >
             options_.memory_budget_bytes &&
         !sessions_.empty()) {
    auto lru = sessions_.begin();
    for (auto it = sessions_.begin(); it != sessions_.end(); ++it) {
      if (it->second->last_used() < lru->second->last_used()) lru = it;
    }
    EvictLocked(lru, "memory");
  }
  if (reserved_total_.bytes + bytes > options_.memory_budget_bytes) {
    return absl::ResourceExhaustedError(
        "uploads in flight hold the server's memory budget; retry later");
  }
  ++mine.uploads;
  mine.bytes += bytes;
  ++reserved_total_.uploads;
  reserved_total_.bytes += bytes;
  UploadReservation r;
  r.store_ = this;
  r.tenant_ = tenant;
  r.bytes_ = bytes;
  PublishLocked();
  return r;
}

void SessionStore::Release(const std::string& tenant, int64_t bytes) {
  std::lock_guard<std::mutex> lock(mu_);
  ReleaseLocked(tenant, bytes);
  PublishLocked();
}

void SessionStore::ReleaseLocked(const std::string& tenant, int64_t bytes) {
  auto it = reserved_.find(tenant);
  if (it == reserved_.end()) return;
  --it->second.uploads;
  it->second.bytes -= bytes;
  --reserved_total_.uploads;
  reserved_total_.bytes -= bytes;
  if (it->second.uploads == 0) reserved_.erase(it);
}

absl::StatusOr<std::shared_ptr<Session>> SessionStore::Create(
    const std::string& tenant, std::string id, Mesh mesh,
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
    record.mesh = mesh;
    // The BVH is built on first use, after the record was accepted.
    auto session = std::make_shared<Session>(id, std::move(mesh), options_,
                                             metrics_, clock_->NowSeconds());
    record.info = session->Info();
    const RecordLimits limits{options_.max_sessions,
                              options_.SessionsPerTenant(),
                              options_.BudgetPerTenant()};
    absl::Status s = records_->Create(tenant, record, limits);
    for (int retry = 0; chosen && retry < 3 && absl::IsAlreadyExists(s);
         ++retry) {
      record.info.session_id = random_id();
      s = records_->Create(tenant, record, limits);
    }
    if (!s.ok()) return s;
    if (record.info.session_id != id) {
      session = std::make_shared<Session>(record, options_, metrics_,
                                          clock_->NowSeconds());
    }
    std::lock_guard<std::mutex> lock(mu_);
    if (ticket.store_ == this) {
      ReleaseLocked(ticket.tenant_, ticket.bytes_);
      ticket.store_ = nullptr;
    }
    sessions_[Key{tenant, record.info.session_id}] = session;
    PublishLocked();
    return session;
  }
  std::lock_guard<std::mutex> lock(mu_);
  // The reservation becomes the session, under the same lock.
  if (ticket.store_ == this) {
    ReleaseLocked(ticket.tenant_, ticket.bytes_);
    ticket.store_ = nullptr;
  }
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
  PublishLocked();
  return session;
}

absl::StatusOr<std::shared_ptr<Session>> SessionStore::Get(
    const std::string& tenant, const std::string& id, bool touch) {
  if (records_) return GetRecorded(tenant, id, touch);
  std::lock_guard<std::mutex> lock(mu_);
  auto it = sessions_.find({tenant, id});
  if (it == sessions_.end()) {
    return absl::NotFoundError(absl::StrCat(
        "no session ", QuoteId(id),
        " (never created, deleted, or evicted after idling or for memory)"));
  }
  if (touch) it->second->Touch(clock_->NowSeconds());
  return it->second;
}

absl::StatusOr<std::shared_ptr<Session>> SessionStore::GetRecorded(
    const std::string& tenant, const std::string& id, bool touch) {
  if (!ValidSessionId(id)) {
    return absl::NotFoundError(absl::StrCat("no session ", QuoteId(id)));
  }
  auto generation = records_->Generation(tenant, id, touch);
  if (!generation.ok()) {
    if (absl::IsNotFound(generation.status())) {
      std::lock_guard<std::mutex> lock(mu_);
      sessions_.erase({tenant, id});  // deleted or expired elsewhere.
    }
    return generation.status();
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = sessions_.find({tenant, id});
    if (it != sessions_.end() && it->second->generation() == *generation) {
      if (touch) it->second->Touch(clock_->NowSeconds());
      metrics_->RecordSessionCache(true, 0);
      return it->second;
    }
  }
  // A miss: first use on this replica, evicted, or updated elsewhere.
  const double start = clock_->NowSeconds();
  const auto wall = std::chrono::steady_clock::now();
  auto record = records_->Load(tenant, id);
  if (!record.ok()) return record.status();
  auto session =
      std::make_shared<Session>(std::move(*record), options_, metrics_, start);
  if (auto reader = session->Read(); !reader.ok()) return reader.status();
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
        ValidSessionId(id)
            ? records_->Delete(tenant, id)
            : absl::NotFoundError(absl::StrCat("no session ", QuoteId(id)));
    std::lock_guard<std::mutex> lock(mu_);
    if (s.ok() || absl::IsNotFound(s)) sessions_.erase({tenant, id});
    PublishLocked();
    return s;
  }
  std::lock_guard<std::mutex> lock(mu_);
  auto it = sessions_.find({tenant, id});
  if (it == sessions_.end()) {
    return absl::NotFoundError(absl::StrCat("no session ", QuoteId(id)));
  }
  sessions_.erase(it);
  PublishLocked();
  return absl::OkStatus();
}

absl::StatusOr<UpdateOutcome> SessionStore::UpdatePositions(
    const std::string& tenant, const std::string& id,
    int64_t expected_generation, const std::vector<int32_t>& indices,
    const std::vector<Vec3>& positions) {
  auto session = Get(tenant, id);
  if (!session.ok()) return session.status();
  Session& s = **session;
  if (!records_) {
    return s.UpdatePositions(expected_generation, indices, positions);
  }
  std::lock_guard<std::mutex> update_lock(s.update_mutex());
  // One generation ahead may be this very update, applied before its reply
  // was lost: the record's compare-and-set recognises it.
  const bool maybe_retry = s.generation() == expected_generation + 1;
  if (s.generation() != expected_generation && !maybe_retry) {
    return absl::AbortedError(absl::StrCat(
        "session ", QuoteId(id), " is at generation ", s.generation(),
        ", the update expected generation ", expected_generation));
  }
  // The new positions of every vertex, validated before the record changes.
  std::vector<Vec3> all;
  {
    auto reader = s.Read();
    if (!reader.ok()) return reader.status();
    Mesh moved = reader->evaluator->mesh();
    if (indices.empty()) {
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
  auto committed =
      records_->CommitPositions(tenant, id, expected_generation, all,
                                IsBvhBase(expected_generation + 1, options_));
  if (!committed.ok()) return committed.status();
  if (maybe_retry) {
    return UpdateOutcome{.generation = *committed,
                         .refit = !IsBvhBase(*committed, options_)};
  }
  auto outcome = s.UpdatePositions(expected_generation, {}, all);
  if (!outcome.ok()) {
    // The record moved on; this cache entry is stale.
    std::lock_guard<std::mutex> lock(mu_);
    sessions_.erase({tenant, id});
  }
  return outcome;
}

absl::StatusOr<std::vector<SessionSnapshot>> SessionStore::List(
    const std::string& tenant, const std::string& page_token, int page_size,
    std::string* next_token) {
  if (records_) {
    auto infos = records_->List(tenant, page_token, page_size, next_token);
    if (!infos.ok()) return infos.status();
    const double now = clock_->NowSeconds();
    std::vector<SessionSnapshot> out;
    std::lock_guard<std::mutex> lock(mu_);
    for (const wire::SessionInfo& info : *infos) {
      SessionSnapshot s;
      auto it = sessions_.find({tenant, info.session_id});
      if (it != sessions_.end() &&
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

void SessionStore::EnforceBudget(const Session* keep) {
  std::lock_guard<std::mutex> lock(mu_);
  while (TotalBytesLocked() + reserved_total_.bytes >
         options_.memory_budget_bytes) {
    auto lru = sessions_.end();
    for (auto it = sessions_.begin(); it != sessions_.end(); ++it) {
      if (it->second.get() == keep) continue;
      if (lru == sessions_.end() ||
          it->second->last_used() < lru->second->last_used()) {
        lru = it;
      }
    }
    if (lru == sessions_.end()) break;
    EvictLocked(lru, "memory");
  }
  PublishLocked();
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
      static_cast<double>(TotalBytesLocked() + reserved_total_.bytes));
}

}  // namespace meshgauge::server
