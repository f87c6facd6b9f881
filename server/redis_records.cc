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
#include "server/redis_scripts.h"
#include "server/session_messages.h"

namespace meshgauge::server {

struct RedisRecords::Reply {
  explicit Reply(redisReply* r) : reply(r) {}
  ~Reply() { freeReplyObject(reply); }
  redisReply* reply;
};

namespace {

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
    absl::MutexLock lock(&mu_);
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
  absl::MutexLock lock(&mu_);
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
  // fresh one (the scripts are safe to repeat: commit.lua and create.lua
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
    const redis_scripts::ScriptCall& call) {
  std::vector<std::string> argv = {"EVAL", std::string(call.script),
                                   absl::StrCat(call.keys.size())};
  argv.insert(argv.end(), call.keys.begin(), call.keys.end());
  argv.insert(argv.end(), call.args.begin(), call.args.end());
  return Command(argv);
}

redis_scripts::LimitCall RedisRecords::Limited(
    redis_scripts::LimitScript script, const std::string& tenant,
    const std::string& id, const std::string& token, int64_t ttl_ms) const {
  const std::string prefix = TenantPrefix(tenant);
  return {.script = script,
          .session = SessionKey(tenant, id),
          .tenant_ids = absl::StrCat(prefix, "ids"),
          .all_sessions = absl::StrCat(prefix_, "all"),
          .all_claims = absl::StrCat(prefix_, "claims"),
          .tenant_claims = absl::StrCat(prefix, "claims"),
          .tenant_claim_bytes = absl::StrCat(prefix, "claim_bytes"),
          .hash_prefix = absl::StrCat(prefix, "s:"),
          .token = token,
          .ttl_ms = ttl_ms};
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
  redis_scripts::LimitCall call =
      Limited(redis_scripts::LimitScript::kReserve, tenant, "", token, ttl_ms);
  call.limits = limits;
  call.bytes = bytes;
  auto r = Eval(call.Call());
  if (!r.ok()) return r.status();
  return LimitStatus((*r)->reply, limits, bytes, "");
}

void RedisRecords::Renew(const std::string& tenant, const std::string& token,
                         double ttl_seconds) {
  const auto ttl_ms = static_cast<int64_t>(std::ceil(ttl_seconds * 1000));
  (void)Eval(
      Limited(redis_scripts::LimitScript::kRenew, tenant, "", token, ttl_ms)
          .Call());
}

void RedisRecords::Unreserve(const std::string& tenant,
                             const std::string& token) {
  (void)Eval(
      Limited(redis_scripts::LimitScript::kUnreserve, tenant, "", token, 0)
          .Call());
}

absl::Status RedisRecords::Create(const std::string& tenant,
                                  const SessionRecord& record,
                                  const RecordLimits& limits,
                                  const std::string& token) {
  const wire::SessionInfo& info = record.info;
  redis_scripts::LimitCall call =
      Limited(redis_scripts::LimitScript::kCreate, tenant, info.session_id,
              token, TtlMillis());
  call.limits = limits;
  call.bytes = info.memory_bytes;
  call.fields = {"info",     EncodeInfo(info),
                 "topo",     EncodeTopology(record.mesh),
                 "pos",      EncodePositions(record.mesh.positions),
                 "base",     "",
                 "gen",      "0",
                 "base_gen", "0",
                 "inc",      record.incarnation,
                 "bytes",    absl::StrCat(info.memory_bytes)};
  auto r = Eval(call.Call());
  if (!r.ok()) return r.status();
  return LimitStatus((*r)->reply, limits, info.memory_bytes, info.session_id);
}

absl::StatusOr<RecordVersion> RedisRecords::Version(const std::string& tenant,
                                                    const std::string& id,
                                                    bool touch) {
  auto r = Eval(redis_scripts::VersionCall{
      .session = SessionKey(tenant, id), .ttl_ms = TtlMillis(), .touch = touch}
                    .Call());
  if (!r.ok()) return r.status();
  const redisReply* v = (*r)->reply;
  const int64_t g = Int(At(v, 0));
  if (g < 0) return SessionNotFound(id);
  return RecordVersion{g, Str(At(v, 1))};
}

absl::StatusOr<SessionRecord> RedisRecords::Load(const std::string& tenant,
                                                 const std::string& id) {
  auto r =
      Eval(redis_scripts::LoadCall{.session = SessionKey(tenant, id)}.Call());
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
      redis_scripts::CommitCall{.session = SessionKey(tenant, id),
                                .expected_generation = expected.generation,
                                .positions = EncodePositions(positions),
                                .rebase = rebase,
                                .ttl_ms = TtlMillis(),
                                .expected_incarnation = expected.incarnation}
          .Call());
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
  auto r = Eval(
      redis_scripts::DeleteCall{.session = SessionKey(tenant, id),
                                .tenant_ids = absl::StrCat(prefix, "ids"),
                                .all_sessions = absl::StrCat(prefix_, "all"),
                                .id = id}
          .Call());
  if (!r.ok()) return r.status();
  return Int((*r)->reply) > 0 ? absl::OkStatus() : SessionNotFound(id);
}

absl::StatusOr<std::vector<RecordSummary>> RedisRecords::List(
    const std::string& tenant, const std::string& after, int limit,
    std::string* next) {
  const std::string prefix = TenantPrefix(tenant);
  auto r =
      Eval(redis_scripts::ListCall{.tenant_ids = absl::StrCat(prefix, "ids"),
                                   .after = after,
                                   .limit = limit,
                                   .hash_prefix = absl::StrCat(prefix, "s:")}
               .Call());
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
