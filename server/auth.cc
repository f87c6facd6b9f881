#include "server/auth.h"

#include <openssl/evp.h>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "lib/io/text_file.h"
#include "server/session_messages.h"

namespace meshgauge::server {

std::string Sha256Hex(const std::string& data) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  EVP_Digest(data.data(), data.size(), digest, &size, EVP_sha256(), nullptr);
  static const char kHex[] = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < size; ++i) {
    out.push_back(kHex[digest[i] >> 4]);
    out.push_back(kHex[digest[i] & 15]);
  }
  return out;
}

bool ValidTenantName(const std::string& name) { return ValidSessionId(name); }

absl::StatusOr<Authenticator> Authenticator::FromText(const std::string& text,
                                                      const std::string& name) {
  auto table = std::make_shared<HashToTenant>();
  int line_no = 0;
  for (absl::string_view raw : absl::StrSplit(text, '\n')) {
    ++line_no;
    absl::string_view line = absl::StripAsciiWhitespace(raw);
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields =
        absl::StrSplit(line, absl::ByAnyChar(" \t"), absl::SkipEmpty());
    auto bad = [&](const std::string& why) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": line ", line_no, ": ", why));
    };
    if (fields.size() != 2) return bad("expected 'TENANT SHA256HEX'");
    const std::string hash = absl::AsciiStrToLower(fields[1]);
    if (!ValidTenantName(fields[0])) {
      return bad(
          "the tenant name must be 1 to 64 characters from [A-Za-z0-9._-]");
    }
    if (hash.size() != 64 ||
        hash.find_first_not_of("0123456789abcdef") != std::string::npos) {
      return bad(
          "the token hash must be 64 hex digits (sha256sum of the token)");
    }
    if (!table->emplace(hash, fields[0]).second) {
      return bad("this token hash is already listed");
    }
  }
  if (table->empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": no tenants (one 'TENANT SHA256HEX' per line)"));
  }
  return Authenticator(std::move(table));
}

absl::Status Authenticator::Reload(const std::string& path) {
  if (!has_tokens()) {
    return absl::FailedPreconditionError(
        "open mode (no tokens file at the start) cannot load tokens");
  }
  auto loaded = FromFile(path);
  if (!loaded.ok()) return loaded.status();
  std::shared_ptr<const HashToTenant> table = loaded->Table();
  absl::MutexLock lock(&mu_);
  by_hash_ = std::move(table);
  return absl::OkStatus();
}

Authenticator::Authenticator(Authenticator&& other) noexcept
    : by_hash_(other.Table()) {}

Authenticator& Authenticator::operator=(Authenticator&& other) noexcept {
  std::shared_ptr<const HashToTenant> table = other.Table();
  absl::MutexLock lock(&mu_);
  by_hash_ = std::move(table);
  return *this;
}

std::shared_ptr<const Authenticator::HashToTenant> Authenticator::Table()
    const {
  absl::MutexLock lock(&mu_);
  return by_hash_;
}

absl::StatusOr<Authenticator> Authenticator::FromFile(const std::string& path) {
  auto text = ReadTextFile(path, "tokens file");
  if (!text.ok()) return text.status();
  return FromText(*text, path);
}

absl::StatusOr<std::string> Authenticator::Authenticate(
    const grpc::ServerContextBase& ctx) const {
  return AuthenticateMetadata(ctx.client_metadata());
}

absl::StatusOr<std::string> Authenticator::AuthenticateMetadata(
    const std::multimap<grpc::string_ref, grpc::string_ref>& md) const {
  const std::shared_ptr<const HashToTenant> table = Table();
  if (table == nullptr) return std::string();  // open mode.
  const auto it = md.find("authorization");
  if (it == md.end()) {
    return absl::UnauthenticatedError(
        "missing 'authorization: Bearer <token>' metadata");
  }
  if (md.count("authorization") > 1) {
    return absl::UnauthenticatedError(
        "more than one 'authorization' metadata entry: send exactly one");
  }
  const absl::string_view value(it->second.data(), it->second.size());
  constexpr absl::string_view kBearer = "Bearer ";
  if (!absl::StartsWith(value, kBearer) || value.size() == kBearer.size()) {
    return absl::UnauthenticatedError(
        "the authorization metadata must be 'Bearer <token>'");
  }
  const auto tenant =
      table->find(Sha256Hex(std::string(value.substr(kBearer.size()))));
  if (tenant == table->end()) {
    return absl::UnauthenticatedError("unknown token");
  }
  return tenant->second;
}

}  // namespace meshgauge::server
