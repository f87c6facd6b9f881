#include "server/session_messages.h"

#include <cctype>
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

std::string RandomSessionId() {
  static thread_local std::mt19937_64 rng(std::random_device{}());
  return absl::StrFormat("s-%016x", rng());
}

absl::Status InvalidSessionId(const std::string& id) {
  return absl::InvalidArgumentError(
      absl::StrCat("session id ", QuoteId(id),
                   " is invalid: use 1 to 64 characters from [A-Za-z0-9._-]"));
}

std::string QuoteId(const std::string& id) {
  std::string s = absl::CHexEscape(id.substr(0, 80));
  if (id.size() > 80) s += "...";
  return absl::StrCat("'", s, "'");
}

absl::Status SessionNotFound(const std::string& id) {
  return absl::NotFoundError(
      absl::StrCat("no session ", QuoteId(id),
                   " (never created, deleted, or evicted or expired after "
                   "idling or for memory)"));
}

absl::Status GenerationMismatch(const std::string& id, int64_t generation,
                                int64_t expected, const char* what) {
  return absl::AbortedError(
      absl::StrCat("session ", QuoteId(id), " is at generation ", generation,
                   ", the ", what, " expected generation ", expected));
}

absl::Status CheckPointCount(int64_t points, int64_t expected, bool subset) {
  if (points == expected) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(
      "positions holds ", points, " points, expected ", expected,
      subset ? " (one per index)" : " (one per vertex of the session)"));
}

}  // namespace meshgauge::server
