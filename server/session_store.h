// All sessions of a server: creation with limits, lookup, listing, deletion,
// idle-TTL and memory-budget (LRU) eviction.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/clock.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/session.h"

namespace meshgauge::server {

class SessionStore {
 public:
  // options, metrics and clock must outlive the store.
  SessionStore(const ServerOptions& options, Metrics* metrics,
               const Clock* clock);

  // Adds a session for a validated mesh. Empty id: a random one is chosen.
  // Errors: INVALID_ARGUMENT (bad id), ALREADY_EXISTS, RESOURCE_EXHAUSTED
  // (session count limit, or the mesh alone exceeds the memory budget).
  // Least recently used sessions are evicted to make room in the budget.
  absl::StatusOr<std::shared_ptr<Session>> Create(std::string id, Mesh mesh);

  // NOT_FOUND names the id (and says it may have been evicted).
  absl::StatusOr<std::shared_ptr<Session>> Get(const std::string& id);
  absl::Status Delete(const std::string& id);

  // Sessions with id > page_token, in id order, at most page_size.
  std::vector<SessionSnapshot> List(const std::string& page_token,
                                    int page_size, std::string* next_token);

  // Evicts sessions idle longer than the TTL.
  void Sweep();
  // Evicts least recently used sessions (never `keep`) while the accounted
  // memory exceeds the budget; call after a session's cache grew.
  void EnforceBudget(const Session* keep);
  int64_t size() const;

 private:
  void EvictLocked(std::map<std::string, std::shared_ptr<Session>>::iterator,
                   const std::string& reason);
  int64_t TotalBytesLocked() const;
  void PublishLocked();

  const ServerOptions& options_;
  Metrics* metrics_;
  const Clock* clock_;
  mutable std::mutex mu_;
  std::map<std::string, std::shared_ptr<Session>> sessions_;
};

// Session ids: [A-Za-z0-9._-]{1,64}.
bool ValidSessionId(const std::string& id);

}  // namespace meshgauge::server
