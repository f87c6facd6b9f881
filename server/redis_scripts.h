// The Lua scripts of RedisRecords: one file each in server/redis_scripts/
// (each names its KEYS and ARGV in its header comment), embedded at build
// time (embed_lua.cmake). The calls below are the one place in C++ where a
// script's KEYS and ARGV are named and put in order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/strings/string_view.h"
#include "server/session_records.h"

namespace meshgauge::server::redis_scripts {

// The text of server/redis_scripts/NAME.lua; empty when there is no such
// file. Defined in the file the build generates.
absl::string_view LuaFile(absl::string_view name);

// One EVAL: a script's text, KEYS and ARGV.
struct ScriptCall {
  absl::string_view script;
  std::vector<std::string> keys, args;
};

// The scripts that begin with limits.lua.
enum class LimitScript { kReserve, kCreate, kRenew, kUnreserve };

// A call of a LimitScript (limits.lua names the fields' KEYS and ARGV).
struct LimitCall {
  LimitScript script;
  // KEYS.
  std::string session;  // the new session's hash (kCreate; else any).
  std::string tenant_ids, all_sessions, all_claims, tenant_claims,
      tenant_claim_bytes;
  // ARGV.
  RecordLimits limits = {};  // kReserve, kCreate.
  int64_t bytes = 0;         // kReserve, kCreate.
  std::string hash_prefix;   // the tenant's session hashes' prefix.
  std::string token;         // the upload's claim.
  int64_t ttl_ms = 0;        // the claim's (the record's for kCreate).
  // kCreate: the record's fields and values, alternating.
  std::vector<std::string> fields = {};
  ScriptCall Call() const;
};

// version.lua.
struct VersionCall {
  std::string session;  // hash.
  int64_t ttl_ms = 0;
  bool touch = false;
  ScriptCall Call() const;
};

// load.lua.
struct LoadCall {
  std::string session;  // hash.
  ScriptCall Call() const;
};

// commit.lua.
struct CommitCall {
  std::string session;  // hash.
  int64_t expected_generation = 0;
  std::string positions;  // encoded.
  bool rebase = false;
  int64_t ttl_ms = 0;
  std::string expected_incarnation;
  ScriptCall Call() const;
};

// delete.lua.
struct DeleteCall {
  std::string session;  // hash.
  std::string tenant_ids, all_sessions;
  std::string id;
  ScriptCall Call() const;
};

// list.lua.
struct ListCall {
  std::string tenant_ids;
  std::string after;  // "" = from the start.
  int limit = 0;
  std::string hash_prefix;  // the tenant's session hashes' prefix.
  ScriptCall Call() const;
};

}  // namespace meshgauge::server::redis_scripts
