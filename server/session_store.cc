#include "server/session_store.h"

#include <random>

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

SessionStore::SessionStore(const ServerOptions& options, Metrics* metrics,
                           const Clock* clock)
    : options_(options), metrics_(metrics), clock_(clock) {}

absl::StatusOr<std::shared_ptr<Session>> SessionStore::Create(std::string id,
                                                              Mesh mesh) {
  const int64_t bytes = Session::EstimateBaseBytes(mesh);
  if (bytes > options_.memory_budget_bytes) {
    return absl::ResourceExhaustedError(
        absl::StrCat("mesh needs about ", bytes,
                     " bytes, more than the server's memory "
                     "budget of ",
                     options_.memory_budget_bytes, " bytes"));
  }
  std::lock_guard<std::mutex> lock(mu_);
  if (id.empty()) {
    static thread_local std::mt19937_64 rng(std::random_device{}());
    do {
      id = absl::StrFormat("s-%016x", rng());
    } while (sessions_.count(id));
  } else if (!ValidSessionId(id)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "session id '", id.substr(0, 80),
        "' is invalid: use 1 to 64 characters from [A-Za-z0-9._-]"));
  } else if (sessions_.count(id)) {
    return absl::AlreadyExistsError(
        absl::StrCat("session '", id, "' already exists"));
  }
  if (std::ssize(sessions_) >= options_.max_sessions) {
    return absl::ResourceExhaustedError(
        absl::StrCat("the server holds the maximum of ", options_.max_sessions,
                     " sessions (--max_sessions); delete one first"));
  }
  // Make room: least recently used first.
  while (TotalBytesLocked() + bytes > options_.memory_budget_bytes &&
         !sessions_.empty()) {
    auto lru = sessions_.begin();
    for (auto it = sessions_.begin(); it != sessions_.end(); ++it) {
      if (it->second->last_used() < lru->second->last_used()) lru = it;
    }
    EvictLocked(lru, "memory");
  }
  auto session = std::make_shared<Session>(id, std::move(mesh), options_,
                                           metrics_, clock_->NowSeconds());
  sessions_.emplace(id, session);
  PublishLocked();
  return session;
}

absl::StatusOr<std::shared_ptr<Session>> SessionStore::Get(
    const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) {
    return absl::NotFoundError(absl::StrCat(
        "no session '", id.substr(0, 80),
        "' (never created, deleted, or evicted after idling or for memory)"));
  }
  it->second->Touch(clock_->NowSeconds());
  return it->second;
}

absl::Status SessionStore::Delete(const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) {
    return absl::NotFoundError(
        absl::StrCat("no session '", id.substr(0, 80), "'"));
  }
  sessions_.erase(it);
  PublishLocked();
  return absl::OkStatus();
}

std::vector<SessionSnapshot> SessionStore::List(const std::string& page_token,
                                                int page_size,
                                                std::string* next_token) {
  std::vector<std::shared_ptr<Session>> page;
  next_token->clear();
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (auto it = sessions_.upper_bound(page_token); it != sessions_.end();
         ++it) {
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
  while (TotalBytesLocked() > options_.memory_budget_bytes) {
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

void SessionStore::EvictLocked(
    std::map<std::string, std::shared_ptr<Session>>::iterator it,
    const std::string& reason) {
  sessions_.erase(it);
  metrics_->RecordEviction(reason);
}

int64_t SessionStore::TotalBytesLocked() const {
  int64_t total = 0;
  for (const auto& [id, s] : sessions_) total += s->memory_bytes();
  return total;
}

void SessionStore::PublishLocked() {
  metrics_->SetSessions(static_cast<double>(sessions_.size()),
                        static_cast<double>(TotalBytesLocked()));
}

}  // namespace meshgauge::server
