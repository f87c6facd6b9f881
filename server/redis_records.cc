#include "server/redis_records.h"

#include <hiredis/hiredis.h>

#include <charconv>
#include <cmath>

#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "server/record/record_convert.h"
#include "server/session_messages.h"

namespace meshgauge::server {

struct RedisRecords::Reply {
  explicit Reply(redisReply* r) : reply(r) {}
  ~Reply() { freeReplyObject(reply); }
  redisReply* reply;
};

namespace {

// Shared by kReserve and kCreate: counts of live sessions and live upload
// claims, and the check of the limits. Claims are sorted sets scored by
// their expiry (Redis's clock, milliseconds); expired ones are dropped.
constexpr char kLimits[] = R"lua(
local function live(z, prefix)
  local n, bytes = 0, 0
  for _, m in ipairs(redis.call('ZRANGE', z, 0, -1)) do
    local b = redis.call('HGET', prefix .. m, 'bytes')
    if b then n = n + 1; bytes = bytes + tonumber(b)
    else redis.call('ZREM', z, m) end
  end
  return n, bytes
end
local function now_ms()
  local t = redis.call('TIME')
  return tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
end
local function claims(z, h, skip)
  for _, m in ipairs(redis.call('ZRANGEBYSCORE', z, '-inf', now_ms())) do
    redis.call('ZREM', z, m)
    if h then redis.call('HDEL', h, m) end
  end
  local n, bytes = 0, 0
  for _, m in ipairs(redis.call('ZRANGE', z, 0, -1)) do
    if m ~= skip then
      n = n + 1
      if h then bytes = bytes + tonumber(redis.call('HGET', h, m) or '0') end
    end
  end
  return n, bytes
end
-- KEYS[2..6]: tenant ids, all sessions, all claims, tenant claims, tenant
-- claim bytes. A: max sessions, max per tenant, max bytes, bytes, hash
-- prefix, token. nil when it fits, else {code, count}: 2 server limit,
-- 3 tenant limit, 4 tenant bytes.
local function over(A)
  local token = A[6]
  local total = live(KEYS[3], '')
  local all_claims = claims(KEYS[4], false, KEYS[5] .. '|' .. token)
  if total + all_claims >= tonumber(A[1]) then return {2, total + all_claims} end
  local n, bytes = live(KEYS[2], A[5])
  local cn, cbytes = claims(KEYS[5], KEYS[6], token)
  if n + cn >= tonumber(A[2]) then return {3, n + cn} end
  if bytes + cbytes + tonumber(A[4]) > tonumber(A[3]) then
    return {4, bytes + cbytes}
  end
  return nil
end
local function unclaim(token)
  redis.call('ZREM', KEYS[4], KEYS[5] .. '|' .. token)
  redis.call('ZREM', KEYS[5], token)
  redis.call('HDEL', KEYS[6], token)
end
)lua";

// KEYS: session hash, then kLimits's. ARGV: max sessions, max per tenant,
// max bytes per tenant, bytes, hash prefix, token, ttl ms, then field/value
// pairs (with the incarnation as 'inc'). Returns {code, count}: 0 created
// (or created before by this same call), 1 exists, else as kLimits.
constexpr char kCreateBody[] = R"lua(
if redis.call('EXISTS', KEYS[1]) == 1 then
  -- This very creation, retried after its reply was lost: done.
  for i = 8, #ARGV - 1, 2 do
    if ARGV[i] == 'inc' and redis.call('HGET', KEYS[1], 'inc') == ARGV[i + 1] then
      return {0, 0}
    end
  end
  return {1, 0}
end
local refused = over(ARGV)
if refused then return refused end
unclaim(ARGV[6])
local fields = {}
for i = 8, #ARGV do fields[#fields + 1] = ARGV[i] end
redis.call('HSET', KEYS[1], unpack(fields))
redis.call('PEXPIRE', KEYS[1], ARGV[7])
local id = string.sub(KEYS[1], #ARGV[5] + 1)
redis.call('ZADD', KEYS[2], 0, id)
redis.call('ZADD', KEYS[3], 0, KEYS[1])
return {0, 0}
)lua";

// KEYS: unused, then kLimits's. ARGV: as kCreateBody's first seven (ttl:
// the claim's). Returns {code, count} as kCreateBody's.
constexpr char kReserveBody[] = R"lua(
local refused = over(ARGV)
if refused then return refused end
local expiry = now_ms() + tonumber(ARGV[7])
redis.call('ZADD', KEYS[4], expiry, KEYS[5] .. '|' .. ARGV[6])
redis.call('ZADD', KEYS[5], expiry, ARGV[6])
redis.call('HSET', KEYS[6], ARGV[6], ARGV[4])
return {0, 0}
)lua";

// KEYS: as kReserveBody's. ARGV: token at 6, ttl ms at 7.
constexpr char kRenewBody[] = R"lua(
local expiry = now_ms() + tonumber(ARGV[7])
redis.call('ZADD', KEYS[4], 'XX', expiry, KEYS[5] .. '|' .. ARGV[6])
redis.call('ZADD', KEYS[5], 'XX', expiry, ARGV[6])
return 0
)lua";

// KEYS: as kReserveBody's. ARGV: token at 6.
constexpr char kUnreserveBody[] = R"lua(
unclaim(ARGV[6])
return 0
)lua";

// KEYS: hash. ARGV: ttl ms, touch (0/1). {generation, incarnation}, or
// {-1} when there is no record.
constexpr char kVersion[] = R"lua(
local v = redis.call('HMGET', KEYS[1], 'gen', 'inc')
if not v[1] then return {-1} end
if ARGV[2] == '1' then redis.call('PEXPIRE', KEYS[1], ARGV[1]) end
return {tonumber(v[1]), v[2] or ''}
)lua";

// KEYS: hash. {info, topo, pos, base, gen, base_gen, inc, pttl}.
constexpr char kLoad[] = R"lua(
local v = redis.call('HMGET', KEYS[1], 'info', 'topo', 'pos', 'base', 'gen',
                     'base_gen', 'inc')
if not v[1] then return false end
v[7] = v[7] or ''
v[8] = redis.call('PTTL', KEYS[1])
return v
)lua";

// KEYS: hash. ARGV: expected generation, positions, rebase (0/1), ttl ms,
// expected incarnation. {1, gen} applied (or already applied), {0, gen}
// other generation, {-1} missing, {-2} another incarnation.
constexpr char kCommit[] = R"lua(
local v = redis.call('HMGET', KEYS[1], 'gen', 'inc')
if not v[1] then return {-1} end
if (v[2] or '') ~= ARGV[5] then return {-2} end
local g = tonumber(v[1])
local e = tonumber(ARGV[1])
if g == e + 1 and redis.call('HGET', KEYS[1], 'pos') == ARGV[2] then
  redis.call('PEXPIRE', KEYS[1], ARGV[4])
  return {1, g}
end
if g ~= e then return {0, g} end
if ARGV[3] == '1' then
  redis.call('HSET', KEYS[1], 'base', '', 'base_gen', e + 1)
elseif redis.call('HGET', KEYS[1], 'base') == '' then
  redis.call('HSET', KEYS[1], 'base', redis.call('HGET', KEYS[1], 'pos'))
end
redis.call('HSET', KEYS[1], 'pos', ARGV[2], 'gen', e + 1)
redis.call('PEXPIRE', KEYS[1], ARGV[4])
return {1, e + 1}
)lua";

// KEYS: hash, tenant ids, all sessions. ARGV: id. Deleted count.
constexpr char kDelete[] = R"lua(
local n = redis.call('DEL', KEYS[1])
redis.call('ZREM', KEYS[2], ARGV[1])
redis.call('ZREM', KEYS[3], KEYS[1])
return n
)lua";

// KEYS: tenant ids. ARGV: after ('' = from the start), limit, hash prefix.
// Up to limit + 1 entries {id, info, gen, pttl, inc}; expired ids are
// dropped.
constexpr char kList[] = R"lua(
local out = {}
local start = ARGV[1] == '' and '-' or ('(' .. ARGV[1])
local want = tonumber(ARGV[2]) + 1
while #out < want do
  local ids = redis.call('ZRANGEBYLEX', KEYS[1], start, '+', 'LIMIT', 0, want)
  if #ids == 0 then break end
  for _, id in ipairs(ids) do
    local k = ARGV[3] .. id
    local v = redis.call('HMGET', k, 'info', 'gen', 'inc')
    if v[1] then
      if #out < want then
        out[#out + 1] = {id, v[1], v[2], redis.call('PTTL', k), v[3] or ''}
      end
    else
      redis.call('ZREM', KEYS[1], id)
    end
    start = '(' .. id
  end
end
return out
)lua";

std::string Str(const redisReply* r) {
  return r && r->type == REDIS_REPLY_STRING ? std::string(r->str, r->len)
                                            : std::string();
}

int64_t Int(const redisReply* r) {
  if (!r) return 0;
  if (r->type == REDIS_REPLY_INTEGER) return r->integer;
  int64_t v = 0;
  if (r->type == REDIS_REPLY_STRING) {
    (void)absl::SimpleAtoi(absl::string_view(r->str, r->len), &v);
  }
  return v;
}

const redisReply* At(const redisReply* r, size_t i) {
  return r && r->type == REDIS_REPLY_ARRAY && i < r->elements ? r->element[i]
                                                              : nullptr;
}

}  // namespace

absl::Status ParseRedisUrl(const std::string& url, RedisOptions* options) {
  absl::string_view rest = url;
  const auto bad = [&url] {
    return absl::InvalidArgumentError(absl::StrCat(
        "--session_store must be redis://HOST[:PORT], got '", url, "'"));
  };
  if (!absl::ConsumePrefix(&rest, "redis://") || rest.empty()) return bad();
  absl::ConsumeSuffix(&rest, "/");
  const size_t colon = rest.rfind(':');
  int port = 6379;
  if (colon != absl::string_view::npos) {
    if (!absl::SimpleAtoi(rest.substr(colon + 1), &port) || port < 1 ||
        port > 65535) {
      return bad();
    }
    rest = rest.substr(0, colon);
  }
  if (rest.empty()) return bad();
  options->host = std::string(rest);
  options->port = port;
  return absl::OkStatus();
}

RedisRecords::RedisRecords(RedisOptions options, Metrics* metrics)
    : options_(std::move(options)),
      prefix_(absl::StrCat(options_.key_prefix, "r", kRecordFormat, ":")),
      metrics_(metrics) {}

RedisRecords::~RedisRecords() {
  for (redisContext* c : idle_) redisFree(c);
}

std::string RedisRecords::Describe() const {
  return absl::StrCat("redis://", options_.host, ":", options_.port);
}

int64_t RedisRecords::TtlMillis() const {
  return static_cast<int64_t>(std::ceil(options_.ttl_seconds * 1000));
}

double RedisRecords::IdleSeconds(int64_t pttl_ms) const {
  return pttl_ms < 0 ? 0
                     : std::max(0.0, options_.ttl_seconds - pttl_ms / 1000.0);
}

std::string RedisRecords::TenantPrefix(const std::string& tenant) const {
  // Hex keeps any tenant name out of the key syntax.
  return absl::StrCat(prefix_, "t", absl::BytesToHexString(tenant), ":");
}

std::string RedisRecords::SessionKey(const std::string& tenant,
                                     const std::string& id) const {
  return absl::StrCat(TenantPrefix(tenant), "s:", id);
}

absl::StatusOr<redisContext*> RedisRecords::Acquire() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (!idle_.empty()) {
      redisContext* c = idle_.back();
      idle_.pop_back();
      return c;
    }
  }
  timeval tv;
  tv.tv_sec = static_cast<time_t>(options_.timeout_seconds);
  tv.tv_usec =
      static_cast<suseconds_t>((options_.timeout_seconds - tv.tv_sec) * 1e6);
  redisContext* c =
      redisConnectWithTimeout(options_.host.c_str(), options_.port, tv);
  if (c == nullptr || c->err) {
    const std::string cause = c ? c->errstr : "out of memory";
    if (c) redisFree(c);
    return absl::UnavailableError(absl::StrCat("the session store ", Describe(),
                                               " is unreachable: ", cause));
  }
  redisSetTimeout(c, tv);
  return c;
}

void RedisRecords::Release(redisContext* c) {
  std::lock_guard<std::mutex> lock(mu_);
  idle_.push_back(c);
}

absl::StatusOr<std::shared_ptr<RedisRecords::Reply>> RedisRecords::Command(
    const std::vector<std::string>& argv) {
  std::vector<const char*> args;
  std::vector<size_t> lens;
  for (const std::string& a : argv) {
    args.push_back(a.data());
    lens.push_back(a.size());
  }
  std::string cause;
  // A pooled connection may have died with a Redis restart: one retry on a
  // fresh one (the scripts are safe to repeat: kCommit and kCreateBody
  // recognise their own earlier run, claims are keyed by token).
  auto unavailable = [this](absl::Status s) {
    if (metrics_) metrics_->RecordSessionStoreError();
    return s;
  };
  for (int attempt = 0; attempt < 2; ++attempt) {
    auto c = Acquire();
    if (!c.ok()) return unavailable(c.status());
    auto* r = static_cast<redisReply*>(redisCommandArgv(
        *c, static_cast<int>(args.size()), args.data(), lens.data()));
    if (r == nullptr) {
      cause = (*c)->errstr;
      redisFree(*c);
      continue;
    }
    Release(*c);
    auto reply = std::make_shared<Reply>(r);
    if (r->type == REDIS_REPLY_ERROR) {
      const std::string msg(r->str, r->len);
      // Redis loading its AOF, read-only or out of memory: try later.
      if (absl::StartsWith(msg, "LOADING") || absl::StartsWith(msg, "BUSY") ||
          absl::StartsWith(msg, "MISCONF") || absl::StartsWith(msg, "OOM") ||
          absl::StartsWith(msg, "READONLY")) {
        return unavailable(absl::UnavailableError(absl::StrCat(
            "the session store ", Describe(), " refused the call: ", msg)));
      }
      return absl::InternalError(
          absl::StrCat("the session store ", Describe(), ": ", msg));
    }
    return reply;
  }
  return unavailable(absl::UnavailableError(absl::StrCat(
      "the session store ", Describe(), " is unreachable: ", cause)));
}

absl::StatusOr<std::shared_ptr<RedisRecords::Reply>> RedisRecords::Eval(
    const std::string& script, const std::vector<std::string>& keys,
    const std::vector<std::string>& args) {
  std::vector<std::string> argv = {"EVAL", script, absl::StrCat(keys.size())};
  argv.insert(argv.end(), keys.begin(), keys.end());
  argv.insert(argv.end(), args.begin(), args.end());
  return Command(argv);
}

std::vector<std::string> RedisRecords::LimitKeys(const std::string& tenant,
                                                 const std::string& id) const {
  const std::string prefix = TenantPrefix(tenant);
  return {SessionKey(tenant, id),         absl::StrCat(prefix, "ids"),
          absl::StrCat(prefix_, "all"),   absl::StrCat(prefix_, "claims"),
          absl::StrCat(prefix, "claims"), absl::StrCat(prefix, "claim_bytes")};
}

std::vector<std::string> RedisRecords::LimitArgs(const std::string& tenant,
                                                 const RecordLimits& limits,
                                                 int64_t bytes,
                                                 const std::string& token,
                                                 int64_t ttl_ms) const {
  return {absl::StrCat(limits.max_sessions),
          absl::StrCat(limits.max_sessions_per_tenant),
          absl::StrCat(limits.max_bytes_per_tenant),
          absl::StrCat(bytes),
          absl::StrCat(TenantPrefix(tenant), "s:"),
          token,
          absl::StrCat(ttl_ms)};
}

namespace {

absl::Status LimitStatus(const redisReply* reply, const RecordLimits& limits,
                         int64_t bytes, const std::string& id) {
  const int64_t count = Int(At(reply, 1));
  switch (Int(At(reply, 0))) {
    case 0:
      return absl::OkStatus();
    case 1:
      return absl::AlreadyExistsError(
          absl::StrCat("session '", id, "' already exists"));
    case 2:
      return absl::ResourceExhaustedError(absl::StrCat(
          "the service holds the maximum of ", limits.max_sessions,
          " sessions and uploads in flight (--max_sessions, over all "
          "replicas); delete one first"));
    case 3:
      return absl::ResourceExhaustedError(absl::StrCat(
          "this tenant holds its maximum of ", limits.max_sessions_per_tenant,
          " sessions and uploads in flight (--max_sessions_per_tenant, over "
          "all replicas); delete one first"));
    default:
      return absl::ResourceExhaustedError(absl::StrCat(
          "this tenant's sessions and uploads in flight hold ", count,
          " bytes; this one (", bytes, ") would exceed its budget of ",
          limits.max_bytes_per_tenant,
          " bytes (--memory_budget_bytes_per_tenant); delete a session "
          "first"));
  }
}

}  // namespace

absl::Status RedisRecords::Reserve(const std::string& tenant,
                                   const std::string& token, int64_t bytes,
                                   const RecordLimits& limits,
                                   double ttl_seconds) {
  const auto ttl_ms = static_cast<int64_t>(std::ceil(ttl_seconds * 1000));
  auto r = Eval(absl::StrCat(kLimits, kReserveBody), LimitKeys(tenant, ""),
                LimitArgs(tenant, limits, bytes, token, ttl_ms));
  if (!r.ok()) return r.status();
  return LimitStatus((*r)->reply, limits, bytes, "");
}

void RedisRecords::Renew(const std::string& tenant, const std::string& token,
                         double ttl_seconds) {
  const auto ttl_ms = static_cast<int64_t>(std::ceil(ttl_seconds * 1000));
  (void)Eval(absl::StrCat(kLimits, kRenewBody), LimitKeys(tenant, ""),
             LimitArgs(tenant, {}, 0, token, ttl_ms));
}

void RedisRecords::Unreserve(const std::string& tenant,
                             const std::string& token) {
  (void)Eval(absl::StrCat(kLimits, kUnreserveBody), LimitKeys(tenant, ""),
             LimitArgs(tenant, {}, 0, token, 0));
}

absl::Status RedisRecords::Create(const std::string& tenant,
                                  const SessionRecord& record,
                                  const RecordLimits& limits,
                                  const std::string& token) {
  const wire::SessionInfo& info = record.info;
  std::vector<std::string> args =
      LimitArgs(tenant, limits, info.memory_bytes, token, TtlMillis());
  const std::string fields[] = {
      "info",     EncodeInfo(info),
      "topo",     EncodeTopology(record.mesh),
      "pos",      EncodePositions(record.mesh.positions),
      "base",     "",
      "gen",      "0",
      "base_gen", "0",
      "inc",      record.incarnation,
      "bytes",    absl::StrCat(info.memory_bytes)};
  args.insert(args.end(), std::begin(fields), std::end(fields));
  auto r = Eval(absl::StrCat(kLimits, kCreateBody),
                LimitKeys(tenant, info.session_id), args);
  if (!r.ok()) return r.status();
  return LimitStatus((*r)->reply, limits, info.memory_bytes, info.session_id);
}

absl::StatusOr<RecordVersion> RedisRecords::Version(const std::string& tenant,
                                                    const std::string& id,
                                                    bool touch) {
  auto r = Eval(kVersion, {SessionKey(tenant, id)},
                {absl::StrCat(TtlMillis()), touch ? "1" : "0"});
  if (!r.ok()) return r.status();
  const redisReply* v = (*r)->reply;
  const int64_t g = Int(At(v, 0));
  if (g < 0) return SessionNotFound(id);
  return RecordVersion{g, Str(At(v, 1))};
}

absl::StatusOr<SessionRecord> RedisRecords::Load(const std::string& tenant,
                                                 const std::string& id) {
  auto r = Eval(kLoad, {SessionKey(tenant, id)}, {});
  if (!r.ok()) return r.status();
  const redisReply* v = (*r)->reply;
  if (v->type != REDIS_REPLY_ARRAY || v->elements < 8)
    return SessionNotFound(id);
  SessionRecord rec;
  auto info = DecodeInfo(Str(At(v, 0)));
  if (!info.ok()) return info.status();
  rec.info = std::move(*info);
  rec.info.session_id = id;
  if (absl::Status s =
          DecodeTopology(Str(At(v, 1)), rec.info.num_vertices, &rec.mesh);
      !s.ok()) {
    return s;
  }
  auto pos = DecodePositions(Str(At(v, 2)), rec.info.num_vertices);
  if (!pos.ok()) return pos.status();
  rec.mesh.positions = std::move(*pos);
  if (const std::string base = Str(At(v, 3)); !base.empty()) {
    auto b = DecodePositions(base, rec.info.num_vertices);
    if (!b.ok()) return b.status();
    rec.base_positions = std::move(*b);
  }
  rec.info.generation = Int(At(v, 4));
  rec.base_generation = Int(At(v, 5));
  rec.incarnation = Str(At(v, 6));
  rec.info.idle_seconds = IdleSeconds(Int(At(v, 7)));
  if (rec.mesh.num_faces() != rec.info.num_faces ||
      rec.mesh.dimension != rec.info.dimension) {
    return absl::DataLossError("the session store holds a corrupt record");
  }
  return rec;
}

absl::StatusOr<int64_t> RedisRecords::CommitPositions(
    const std::string& tenant, const std::string& id,
    const RecordVersion& expected, const std::vector<Vec3>& positions,
    bool rebase) {
  auto r = Eval(
      kCommit, {SessionKey(tenant, id)},
      {absl::StrCat(expected.generation), EncodePositions(positions),
       rebase ? "1" : "0", absl::StrCat(TtlMillis()), expected.incarnation});
  if (!r.ok()) return r.status();
  const redisReply* v = (*r)->reply;
  const int64_t code = Int(At(v, 0)), gen = Int(At(v, 1));
  if (code == -1) return SessionNotFound(id);
  if (code == -2) {
    return absl::AbortedError(absl::StrCat(
        "session ", QuoteId(id),
        " was deleted and created again while the update was checked; "
        "read it again and retry"));
  }
  if (code == 0) {
    return GenerationMismatch(id, gen, expected.generation, "update");
  }
  return gen;
}

absl::Status RedisRecords::Delete(const std::string& tenant,
                                  const std::string& id) {
  const std::string prefix = TenantPrefix(tenant);
  auto r = Eval(kDelete,
                {SessionKey(tenant, id), absl::StrCat(prefix, "ids"),
                 absl::StrCat(prefix_, "all")},
                {id});
  if (!r.ok()) return r.status();
  return Int((*r)->reply) > 0 ? absl::OkStatus() : SessionNotFound(id);
}

absl::StatusOr<std::vector<RecordSummary>> RedisRecords::List(
    const std::string& tenant, const std::string& after, int limit,
    std::string* next) {
  const std::string prefix = TenantPrefix(tenant);
  auto r = Eval(kList, {absl::StrCat(prefix, "ids")},
                {after, absl::StrCat(limit), absl::StrCat(prefix, "s:")});
  if (!r.ok()) return r.status();
  const redisReply* v = (*r)->reply;
  std::vector<RecordSummary> out;
  next->clear();
  for (size_t i = 0; v->type == REDIS_REPLY_ARRAY && i < v->elements; ++i) {
    if (std::ssize(out) == limit) {
      *next = out.back().info.session_id;
      break;
    }
    const redisReply* e = v->element[i];
    RecordSummary listed;
    auto decoded = DecodeInfo(Str(At(e, 1)));
    if (!decoded.ok()) return decoded.status();
    wire::SessionInfo& info = listed.info = std::move(*decoded);
    info.session_id = Str(At(e, 0));
    info.generation = Int(At(e, 2));
    info.idle_seconds = IdleSeconds(Int(At(e, 3)));
    listed.incarnation = Str(At(e, 4));
    out.push_back(std::move(listed));
  }
  return out;
}

}  // namespace meshgauge::server
