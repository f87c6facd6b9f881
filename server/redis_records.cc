#include "server/redis_records.h"

#include <hiredis/hiredis.h>

#include <charconv>
#include <cmath>

#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "server/record_codec.h"

namespace meshgauge::server {

struct RedisRecords::Reply {
  explicit Reply(redisReply* r) : reply(r) {}
  ~Reply() { freeReplyObject(reply); }
  redisReply* reply;
};

namespace {

// KEYS: session hash, tenant ids, all sessions. ARGV: id, ttl ms, max
// sessions, max per tenant, max bytes per tenant, bytes, hash prefix, then
// field/value pairs. Returns {code, count}: 0 created, 1 exists, 2 server
// limit, 3 tenant limit, 4 tenant bytes.
constexpr char kCreate[] = R"lua(
if redis.call('EXISTS', KEYS[1]) == 1 then return {1, 0} end
local function live(z, prefix)
  local n, bytes = 0, 0
  for _, m in ipairs(redis.call('ZRANGE', z, 0, -1)) do
    local b = redis.call('HGET', prefix .. m, 'bytes')
    if b then n = n + 1; bytes = bytes + tonumber(b)
    else redis.call('ZREM', z, m) end
  end
  return n, bytes
end
local total = live(KEYS[3], '')
if total >= tonumber(ARGV[3]) then return {2, total} end
local n, bytes = live(KEYS[2], ARGV[7])
if n >= tonumber(ARGV[4]) then return {3, n} end
if bytes + tonumber(ARGV[6]) > tonumber(ARGV[5]) then return {4, bytes} end
local fields = {}
for i = 8, #ARGV do fields[#fields + 1] = ARGV[i] end
redis.call('HSET', KEYS[1], unpack(fields))
redis.call('PEXPIRE', KEYS[1], ARGV[2])
redis.call('ZADD', KEYS[2], 0, ARGV[1])
redis.call('ZADD', KEYS[3], 0, KEYS[1])
return {0, 0}
)lua";

// KEYS: hash. ARGV: ttl ms, touch (0/1). The generation or -1.
constexpr char kGeneration[] = R"lua(
local g = redis.call('HGET', KEYS[1], 'gen')
if not g then return -1 end
if ARGV[2] == '1' then redis.call('PEXPIRE', KEYS[1], ARGV[1]) end
return tonumber(g)
)lua";

// KEYS: hash. {info, topo, pos, base, gen, base_gen, pttl}.
constexpr char kLoad[] = R"lua(
local v = redis.call('HMGET', KEYS[1], 'info', 'topo', 'pos', 'base', 'gen',
                     'base_gen')
if not v[1] then return false end
v[7] = redis.call('PTTL', KEYS[1])
return v
)lua";

// KEYS: hash. ARGV: expected, positions, rebase (0/1), ttl ms. {1, gen}
// applied (or already applied), {0, gen} other generation, {-1} missing.
constexpr char kCommit[] = R"lua(
local g = redis.call('HGET', KEYS[1], 'gen')
if not g then return {-1} end
g = tonumber(g)
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
// Up to limit + 1 entries {id, info, gen, pttl}; expired ids are dropped.
constexpr char kList[] = R"lua(
local out = {}
local start = ARGV[1] == '' and '-' or ('(' .. ARGV[1])
local want = tonumber(ARGV[2]) + 1
while #out < want do
  local ids = redis.call('ZRANGEBYLEX', KEYS[1], start, '+', 'LIMIT', 0, want)
  if #ids == 0 then break end
  for _, id in ipairs(ids) do
    local k = ARGV[3] .. id
    local v = redis.call('HMGET', k, 'info', 'gen')
    if v[1] then
      if #out < want then out[#out + 1] = {id, v[1], v[2], redis.call('PTTL', k)} end
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

absl::Status NoSession(const std::string& id) {
  return absl::NotFoundError(
      absl::StrCat("no session '", absl::CHexEscape(id.substr(0, 80)),
                   "' (never created, deleted, or expired after idling)"));
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
    : options_(std::move(options)), metrics_(metrics) {}

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
  return absl::StrCat(options_.key_prefix, "t", absl::BytesToHexString(tenant),
                      ":");
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
  // fresh one (every script is safe to repeat; see kCommit).
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

absl::Status RedisRecords::Ping() {
  auto r = Command({"PING"});
  return r.ok() ? absl::OkStatus() : r.status();
}

absl::Status RedisRecords::Create(const std::string& tenant,
                                  const SessionRecord& record,
                                  const RecordLimits& limits) {
  const wire::SessionInfo& info = record.info;
  const std::string prefix = TenantPrefix(tenant);
  std::vector<std::string> args = {info.session_id,
                                   absl::StrCat(TtlMillis()),
                                   absl::StrCat(limits.max_sessions),
                                   absl::StrCat(limits.max_sessions_per_tenant),
                                   absl::StrCat(limits.max_bytes_per_tenant),
                                   absl::StrCat(info.memory_bytes),
                                   absl::StrCat(prefix, "s:"),
                                   "info",
                                   EncodeInfo(info),
                                   "topo",
                                   EncodeTopology(record.mesh),
                                   "pos",
                                   EncodePositions(record.mesh.positions),
                                   "base",
                                   "",
                                   "gen",
                                   "0",
                                   "base_gen",
                                   "0",
                                   "bytes",
                                   absl::StrCat(info.memory_bytes)};
  auto r =
      Eval(kCreate,
           {SessionKey(tenant, info.session_id), absl::StrCat(prefix, "ids"),
            absl::StrCat(options_.key_prefix, "all")},
           args);
  if (!r.ok()) return r.status();
  const redisReply* reply = (*r)->reply;
  const int64_t count = Int(At(reply, 1));
  switch (Int(At(reply, 0))) {
    case 0:
      return absl::OkStatus();
    case 1:
      return absl::AlreadyExistsError(
          absl::StrCat("session '", info.session_id, "' already exists"));
    case 2:
      return absl::ResourceExhaustedError(absl::StrCat(
          "the service holds the maximum of ", limits.max_sessions,
          " sessions (--max_sessions, over all replicas); delete one first"));
    case 3:
      return absl::ResourceExhaustedError(absl::StrCat(
          "this tenant holds its maximum of ", limits.max_sessions_per_tenant,
          " sessions (--max_sessions_per_tenant); delete one first"));
    default:
      return absl::ResourceExhaustedError(absl::StrCat(
          "this tenant's sessions hold ", count, " bytes; this one (",
          info.memory_bytes, ") would exceed its budget of ",
          limits.max_bytes_per_tenant,
          " bytes (--memory_budget_bytes_per_tenant); delete a session "
          "first"));
  }
}

absl::StatusOr<int64_t> RedisRecords::Generation(const std::string& tenant,
                                                 const std::string& id,
                                                 bool touch) {
  auto r = Eval(kGeneration, {SessionKey(tenant, id)},
                {absl::StrCat(TtlMillis()), touch ? "1" : "0"});
  if (!r.ok()) return r.status();
  const int64_t g = Int((*r)->reply);
  if (g < 0) return NoSession(id);
  return g;
}

absl::StatusOr<SessionRecord> RedisRecords::Load(const std::string& tenant,
                                                 const std::string& id) {
  auto r = Eval(kLoad, {SessionKey(tenant, id)}, {});
  if (!r.ok()) return r.status();
  const redisReply* v = (*r)->reply;
  if (v->type != REDIS_REPLY_ARRAY || v->elements < 7) return NoSession(id);
  SessionRecord rec;
  rec.info.session_id = id;
  if (absl::Status s = DecodeInfo(Str(At(v, 0)), &rec.info); !s.ok()) return s;
  if (absl::Status s = DecodeTopology(Str(At(v, 1)), &rec.mesh); !s.ok()) {
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
  rec.info.idle_seconds = IdleSeconds(Int(At(v, 6)));
  if (rec.mesh.num_faces() != rec.info.num_faces) {
    return absl::DataLossError("the session store holds a corrupt record");
  }
  return rec;
}

absl::StatusOr<int64_t> RedisRecords::CommitPositions(
    const std::string& tenant, const std::string& id,
    int64_t expected_generation, const std::vector<Vec3>& positions,
    bool rebase) {
  auto r = Eval(kCommit, {SessionKey(tenant, id)},
                {absl::StrCat(expected_generation), EncodePositions(positions),
                 rebase ? "1" : "0", absl::StrCat(TtlMillis())});
  if (!r.ok()) return r.status();
  const redisReply* v = (*r)->reply;
  const int64_t code = Int(At(v, 0)), gen = Int(At(v, 1));
  if (code < 0) return NoSession(id);
  if (code == 0) {
    return absl::AbortedError(
        absl::StrCat("session '", id, "' is at generation ", gen,
                     ", the update expected generation ", expected_generation));
  }
  return gen;
}

absl::Status RedisRecords::Delete(const std::string& tenant,
                                  const std::string& id) {
  const std::string prefix = TenantPrefix(tenant);
  auto r = Eval(kDelete,
                {SessionKey(tenant, id), absl::StrCat(prefix, "ids"),
                 absl::StrCat(options_.key_prefix, "all")},
                {id});
  if (!r.ok()) return r.status();
  return Int((*r)->reply) > 0 ? absl::OkStatus() : NoSession(id);
}

absl::StatusOr<std::vector<wire::SessionInfo>> RedisRecords::List(
    const std::string& tenant, const std::string& after, int limit,
    std::string* next) {
  const std::string prefix = TenantPrefix(tenant);
  auto r = Eval(kList, {absl::StrCat(prefix, "ids")},
                {after, absl::StrCat(limit), absl::StrCat(prefix, "s:")});
  if (!r.ok()) return r.status();
  const redisReply* v = (*r)->reply;
  std::vector<wire::SessionInfo> out;
  next->clear();
  for (size_t i = 0; v->type == REDIS_REPLY_ARRAY && i < v->elements; ++i) {
    if (std::ssize(out) == limit) {
      *next = out.back().session_id;
      break;
    }
    const redisReply* e = v->element[i];
    wire::SessionInfo info;
    info.session_id = Str(At(e, 0));
    if (absl::Status s = DecodeInfo(Str(At(e, 1)), &info); !s.ok()) return s;
    info.generation = Int(At(e, 2));
    info.idle_seconds = IdleSeconds(Int(At(e, 3)));
    out.push_back(std::move(info));
  }
  return out;
}

}  // namespace meshgauge::server
