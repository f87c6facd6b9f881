// Where the server's backend is chosen: the session store its options name
// (session_store.h).
#pragma once

#include <memory>

#include "absl/status/statusor.h"
#include "server/clock.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/session_store.h"

namespace meshgauge::server {

// Without options.session_store, an InMemorySessionStore; with
// "redis://HOST[:PORT]", a RecordedSessionStore on RedisRecords there
// (records expire after options.session_ttl_seconds idle; no connection is
// made yet). options, metrics and clock must outlive the store. Errors:
// INVALID_ARGUMENT for a malformed --session_store.
absl::StatusOr<std::unique_ptr<SessionStore>> MakeSessionStore(
    const ServerOptions& options, Metrics* metrics, const Clock* clock);

}  // namespace meshgauge::server
