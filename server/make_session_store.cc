#include "server/make_session_store.h"

#include "server/in_memory_session_store.h"
#include "server/recorded_session_store.h"
#include "server/redis_records.h"

namespace meshgauge::server {

absl::StatusOr<std::unique_ptr<SessionStore>> MakeSessionStore(
    const ServerOptions& options, Metrics* metrics, const Clock* clock) {
  if (options.session_store.empty()) {
    return std::make_unique<InMemorySessionStore>(options, metrics, clock);
  }
  RedisOptions redis;
  if (absl::Status s = ParseRedisUrl(options.session_store, &redis); !s.ok()) {
    return s;
  }
  redis.ttl_seconds = options.session_ttl_seconds;
  return std::make_unique<RecordedSessionStore>(
      options, metrics, clock, std::make_unique<RedisRecords>(redis, metrics));
}

}  // namespace meshgauge::server
