#include "server/redis_scripts.h"

#include <array>

#include "absl/strings/str_cat.h"

namespace meshgauge::server::redis_scripts {
namespace {

// limits.lua and then the script's own file.
absl::string_view LimitScriptText(LimitScript script) {
  static const auto* const texts = new std::array<std::string, 4>{
      absl::StrCat(LuaFile("limits"), LuaFile("reserve")),
      absl::StrCat(LuaFile("limits"), LuaFile("create")),
      absl::StrCat(LuaFile("limits"), LuaFile("renew")),
      absl::StrCat(LuaFile("limits"), LuaFile("unreserve"))};
  return (*texts)[static_cast<int>(script)];
}

}  // namespace

ScriptCall LimitCall::Call() const {
  ScriptCall call{
      .script = LimitScriptText(script),
      .keys = {session, tenant_ids, all_sessions, all_claims, tenant_claims,
               tenant_claim_bytes},
      .args = {absl::StrCat(limits.max_sessions),
               absl::StrCat(limits.max_sessions_per_tenant),
               absl::StrCat(limits.max_bytes_per_tenant), absl::StrCat(bytes),
               hash_prefix, token, absl::StrCat(ttl_ms)}};
  call.args.insert(call.args.end(), fields.begin(), fields.end());
  return call;
}

ScriptCall VersionCall::Call() const {
  return {.script = LuaFile("version"),
          .keys = {session},
          .args = {absl::StrCat(ttl_ms), touch ? "1" : "0"}};
}

ScriptCall LoadCall::Call() const {
  return {.script = LuaFile("load"), .keys = {session}, .args = {}};
}

ScriptCall CommitCall::Call() const {
  return {
      .script = LuaFile("commit"),
      .keys = {session},
      .args = {absl::StrCat(expected_generation), positions, rebase ? "1" : "0",
               absl::StrCat(ttl_ms), expected_incarnation}};
}

ScriptCall DeleteCall::Call() const {
  return {.script = LuaFile("delete"),
          .keys = {session, tenant_ids, all_sessions},
          .args = {id}};
}

ScriptCall ListCall::Call() const {
  return {.script = LuaFile("list"),
          .keys = {tenant_ids},
          .args = {after, absl::StrCat(limit), hash_prefix}};
}

}  // namespace meshgauge::server::redis_scripts
