// Session ids and the statuses about sessions that the store, the records,
// the sessions and the service all return, written once so that every path
// (in memory or Redis, another tenant's id or a missing one) says the same.
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/status.h"

namespace meshgauge::server {

// Session ids: [A-Za-z0-9._-]{1,64}.
bool ValidSessionId(const std::string& id);

// A random session id ("s-" and 16 hex digits) for a caller who named none.
std::string RandomSessionId();

// INVALID_ARGUMENT naming a client-chosen id that is not a session id.
absl::Status InvalidSessionId(const std::string& id);

// An id or name for a message: at most 80 characters, control and
// non-ASCII characters escaped, quoted.
std::string QuoteId(const std::string& id);

// NOT_FOUND for a session this tenant does not have (never created,
// deleted, evicted or expired; another tenant's id alike).
absl::Status SessionNotFound(const std::string& id);

// ABORTED: the session is at `generation`, the call (`what`: "update" or
// "request") expected `expected`.
absl::Status GenerationMismatch(const std::string& id, int64_t generation,
                                int64_t expected, const char* what);

// INVALID_ARGUMENT unless an update carries `expected` points: one per index
// (`subset`) or one per vertex of the session.
absl::Status CheckPointCount(int64_t points, int64_t expected, bool subset);

}  // namespace meshgauge::server
