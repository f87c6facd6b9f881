#include "server/session_store.h"

#include "server/in_memory_session_store.h"
#include "server/recorded_session_store.h"

namespace meshgauge::server {

std::unique_ptr<SessionStore> MakeSessionStore(const ServerOptions& options,
                                               Metrics* metrics,
                                               const Clock* clock,
                                               SessionRecords* records) {
  if (records != nullptr) {
    return std::make_unique<RecordedSessionStore>(options, metrics, clock,
                                                  records);
  }
  return std::make_unique<InMemorySessionStore>(options, metrics, clock);
}

}  // namespace meshgauge::server
