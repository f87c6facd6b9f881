#include "server/in_memory_session_store.h"

#include "absl/strings/str_cat.h"

namespace meshgauge::server {

InMemorySessionStore::InMemorySessionStore(const ServerOptions& options,
                                           Metrics* metrics, const Clock* clock)
    : SessionCache(options, metrics, clock, /*records_hold_limits=*/false) {}

absl::StatusOr<std::shared_ptr<Session>> InMemorySessionStore::Create(
    const std::string& tenant, std::string id, RepairedMesh mesh,
    UploadReservation ticket) {
  const bool chosen = id.empty();
  if (!chosen && !ValidSessionId(id)) return InvalidSessionId(id);
  absl::MutexLock lock(&mu_);
  // The reservation becomes the session, under the same lock.
  ConsumeLocked(ticket);
  if (chosen) {
    do {
      id = RandomSessionId();
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

absl::StatusOr<std::shared_ptr<Session>> InMemorySessionStore::Get(
    const std::string& tenant, const std::string& id, bool touch) {
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find({tenant, id});
  if (it == sessions_.end()) {
    return SessionNotFound(id);
  }
  if (touch) it->second->Touch(clock_->NowSeconds());
  return it->second;
}

absl::Status InMemorySessionStore::Delete(const std::string& tenant,
                                          const std::string& id) {
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find({tenant, id});
  if (it == sessions_.end()) return SessionNotFound(id);
  sessions_.erase(it);
  PublishLocked();
  return absl::OkStatus();
}

absl::StatusOr<wire::UpdateResult> InMemorySessionStore::UpdatePositions(
    const std::string& /*tenant*/, const std::shared_ptr<Session>& session,
    int64_t expected_generation, const std::vector<int32_t>& indices,
    const std::vector<Vec3>& positions, const UpdateControl& control) {
  return session->UpdatePositions(expected_generation, indices, positions,
                                   control);
}

absl::StatusOr<std::vector<SessionSnapshot>> InMemorySessionStore::List(
    const std::string& tenant, const std::string& page_token, int page_size,
    std::string* next_token) {
  std::vector<std::shared_ptr<Session>> page;
  next_token->clear();
  {
    absl::MutexLock lock(&mu_);
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

}  // namespace meshgauge::server
