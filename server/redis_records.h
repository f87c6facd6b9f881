// SessionRecords in Redis (hiredis): one hash per session with a sliding
// TTL, a sorted set of ids per tenant (for listing) and one of all sessions
// (for the server-wide limit). Every operation is a Lua script
// (redis_scripts.h), so checks and writes are atomic across replicas (the
// generation compare-and-set, the limits at creation). Thread-safe: a small
// pool of connections, each reconnected after an error.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "server/metrics.h"
#include "server/redis_scripts.h"
#include "server/session_records.h"

struct redisContext;

namespace meshgauge::server {

struct RedisOptions {
  std::string host = "127.0.0.1";
  int port = 6379;
  double ttl_seconds = 3600;   // idle time before a session expires.
  double timeout_seconds = 5;  // connect and per command.
  // Namespace of every key; the records' format follows it ("mg:r2:...").
  std::string key_prefix = "mg:";
};

// Parses "redis://host[:port]" (port 6379 by default) into host and port.
// Errors: INVALID_ARGUMENT naming the expected form.
absl::Status ParseRedisUrl(const std::string& url, RedisOptions* options);

class RedisRecords : public SessionRecords {
 public:
  // Does not connect: the first call does (and every call after an error),
  // so a server starts while Redis is down and recovers when it is back.
  // metrics (may be null) counts the calls Redis could not serve.
  explicit RedisRecords(RedisOptions options, Metrics* metrics = nullptr);
  ~RedisRecords() override;

  std::string Describe() const override;
  absl::Status Reserve(const std::string& tenant, const std::string& token,
                       int64_t bytes, const RecordLimits& limits,
                       double ttl_seconds) override;
  void Renew(const std::string& tenant, const std::string& token,
             double ttl_seconds) override;
  void Unreserve(const std::string& tenant, const std::string& token) override;
  absl::Status Create(const std::string& tenant, const SessionRecord& record,
                      const RecordLimits& limits,
                      const std::string& token) override;
  absl::StatusOr<RecordVersion> Version(const std::string& tenant,
                                        const std::string& id,
                                        bool touch) override;
  absl::StatusOr<SessionRecord> Load(const std::string& tenant,
                                     const std::string& id) override;
  absl::StatusOr<int64_t> CommitPositions(const std::string& tenant,
                                          const std::string& id,
                                          const RecordVersion& expected,
                                          const std::vector<Vec3>& positions,
                                          bool rebase) override;
  absl::Status Delete(const std::string& tenant,
                      const std::string& id) override;
  absl::StatusOr<std::vector<RecordSummary>> List(const std::string& tenant,
                                                  const std::string& after,
                                                  int limit,
                                                  std::string* next) override;

  struct Reply;  // an owned redisReply.

 private:
  absl::StatusOr<std::shared_ptr<Reply>> Eval(
      const redis_scripts::ScriptCall& call);
  absl::StatusOr<std::shared_ptr<Reply>> Command(
      const std::vector<std::string>& argv);
  absl::StatusOr<redisContext*> Acquire();
  void Release(redisContext* c);
  std::string TenantPrefix(const std::string& tenant) const;
  std::string SessionKey(const std::string& tenant,
                         const std::string& id) const;
  // A call of `script` on `tenant`'s keys (`id`: the session created, if
  // any) for the claim `token`, living `ttl_ms`; no limits nor bytes yet.
  redis_scripts::LimitCall Limited(redis_scripts::LimitScript script,
                                   const std::string& tenant,
                                   const std::string& id,
                                   const std::string& token,
                                   int64_t ttl_ms) const;
  int64_t TtlMillis() const;
  double IdleSeconds(int64_t pttl_ms) const;

  const RedisOptions options_;
  const std::string prefix_;  // key_prefix and the records' format.
  Metrics* const metrics_;
  absl::Mutex mu_;
  std::vector<redisContext*> idle_ ABSL_GUARDED_BY(mu_);
};

}  // namespace meshgauge::server
