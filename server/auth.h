// Bearer-token authentication of callers into tenants.
//
// The tokens file holds one `TENANT SHA256HEX` per line (the hex SHA-256 of
// the token, never the token itself; `#` comments and blank lines allowed).
// A tenant may have several tokens (a rotation lists the old and the new
// one, then the new one alone); Reload re-reads the file (SIGHUP).
// A call authenticates with the metadata `authorization: Bearer TOKEN`;
// the token is hashed and looked up, and is never logged or echoed.
#pragma once

#include <grpcpp/grpcpp.h>

#include <map>
#include <memory>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"

namespace meshgauge::server {

class Authenticator {
 public:
  // Open mode: every caller is the tenant "" (no authentication).
  Authenticator() = default;
  // Takes `other`'s tokens (which it keeps too).
  Authenticator(Authenticator&& other) noexcept;
  Authenticator& operator=(Authenticator&& other) noexcept;
  // Parses a tokens file. Errors: NotFound (unreadable), InvalidArgument
  // naming the line (bad tenant name, not 64 hex digits, repeated hash), or
  // an empty file.
  static absl::StatusOr<Authenticator> FromFile(const std::string& path);
  // The same from the file's text (tests).
  static absl::StatusOr<Authenticator> FromText(const std::string& text,
                                                const std::string& name);

  // Replaces the tokens with the file's at `path`; calls authenticate with
  // the old or the new tokens, never a mix. Thread-safe. Errors: as
  // FromFile's, and then the current tokens stay; FAILED_PRECONDITION in
  // open mode (a server started without tokens stays open).
  absl::Status Reload(const std::string& path);

  // False in open mode.
  bool has_tokens() const { return Table() != nullptr; }
  // The caller's tenant. Errors: UNAUTHENTICATED (no or malformed
  // authorization metadata, unknown token) without echoing the token.
  absl::StatusOr<std::string> Authenticate(
      const grpc::ServerContextBase& ctx) const;
  // The same from a call's metadata (call_auth.h). A call with more than
  // one authorization entry is UNAUTHENTICATED.
  absl::StatusOr<std::string> AuthenticateMetadata(
      const std::multimap<grpc::string_ref, grpc::string_ref>& md) const;

 private:
  using HashToTenant = std::map<std::string, std::string>;  // hex sha256.
  explicit Authenticator(std::shared_ptr<const HashToTenant> by_hash)
      : by_hash_(std::move(by_hash)) {}
  std::shared_ptr<const HashToTenant> Table() const;

  mutable absl::Mutex mu_;
  // Null: open mode.
  std::shared_ptr<const HashToTenant> by_hash_ ABSL_GUARDED_BY(mu_);
};

// Lower-case hex SHA-256 of `data`.
std::string Sha256Hex(const std::string& data);

// Tenant names: [A-Za-z0-9._-]{1,64} (like session ids).
bool ValidTenantName(const std::string& name);

}  // namespace meshgauge::server
