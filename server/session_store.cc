#include "server/session_store.h"

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
                           const Clock* clock)
    : options_(options), metrics_(metrics), clock_(clock) {}

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
  if (std::ssize(sessions_) + reserved_total_.uploads >=
      options_.max_sessions) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the server holds the maximum of ", options_.max_sessions,
        " sessions and uploads in flight (--max_sessions); delete one first"));
  }
  if (options_.max_sessions_per_tenant > 0 &&
      TenantSessionsLocked(tenant) + mine.uploads >=
          options_.SessionsPerTenant()) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "this tenant holds its maximum of ", options_.SessionsPerTenant(),
        " sessions and uploads in flight (--max_sessions_per_tenant); delete "
        "one first"));
  }
  if (tenant_budget && TenantBytesLocked(tenant) + mine.bytes + bytes >
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
  std::lock_guard<std::mutex> lock(mu_);
  // The reservation becomes the session, under the same lock.
  if (ticket.store_ == this) {
    ReleaseLocked(ticket.tenant_, ticket.bytes_);
    ticket.store_ = nullptr;
  }
  if (id.empty()) {
    static thread_local std::mt19937_64 rng(std::random_device{}());
    do {
      id = absl::StrFormat("s-%016x", rng());
    } while (sessions_.count({tenant, id}));
  } else if (!ValidSessionId(id)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "session id ", QuoteId(id),
        " is invalid: use 1 to 64 characters from [A-Za-z0-9._-]"));
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

absl::Status SessionStore::Delete(const std::string& tenant,
                                  const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = sessions_.find({tenant, id});
  if (it == sessions_.end()) {
    return absl::NotFoundError(absl::StrCat("no session ", QuoteId(id)));
  }
  sessions_.erase(it);
  PublishLocked();
  return absl::OkStatus();
}

std::vector<SessionSnapshot> SessionStore::List(const std::string& tenant,
                                                const std::string& page_token,
                                                int page_size,
                                                std::string* next_token) {
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
  metrics_->RecordEviction(reason);
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
