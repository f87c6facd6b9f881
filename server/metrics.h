// The server's Prometheus metrics: one object, injected where needed (no
// singleton). Names follow Prometheus conventions (base units, _total for
// counters); labels are bounded (RPC method, status code, eviction reason),
// never a session id.
#pragma once

#include <prometheus/counter.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>

#include <map>
#include <memory>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"

namespace meshgauge::server {

class Metrics {
 public:
  Metrics();

  std::shared_ptr<prometheus::Registry> registry() const { return registry_; }
  // The text exposition format of everything registered (for tests and
  // debugging; the Exposer serves the same).
  std::string Text() const;

  void RecordRpc(const std::string& method, const std::string& code,
                 double seconds);
  void SetSessions(double active, double bytes);
  void RecordEviction(const std::string& reason);  // ttl, memory.
  void RecordBvhBuild(double seconds);
  void RecordBvhRefit(double seconds);
  void AddRays(double rays);
  void RecordHitCache(bool reused);
  // With a session store: a call found the session's cache on this replica
  // (hit) or loaded the record and built the BVH (miss, taking seconds).
  void RecordSessionCache(bool hit, double seconds);
  // A call that is a client's retry (grpc-previous-rpc-attempts was sent).
  void RecordRetriedAttempt(const std::string& method);
  // A call on the session store failed because it was unreachable.
  void RecordSessionStoreError();

 private:
  std::shared_ptr<prometheus::Registry> registry_;
  prometheus::Family<prometheus::Counter>& rpcs_;
  prometheus::Family<prometheus::Histogram>& rpc_seconds_;
  prometheus::Gauge& sessions_active_;
  prometheus::Gauge& cache_bytes_;
  prometheus::Family<prometheus::Counter>& evictions_;
  prometheus::Counter& bvh_builds_;
  prometheus::Counter& bvh_refits_;
  prometheus::Histogram& bvh_build_seconds_;
  prometheus::Histogram& bvh_refit_seconds_;
  prometheus::Counter& rays_;
  prometheus::Family<prometheus::Counter>& hit_cache_;
  prometheus::Family<prometheus::Counter>& session_cache_;
  prometheus::Histogram& session_load_seconds_;
  prometheus::Family<prometheus::Counter>& retried_attempts_;
  prometheus::Counter& session_store_errors_;
  absl::Mutex mu_;  // guards lazily created labelled children.
  std::map<std::string, prometheus::Histogram*> rpc_histograms_
      ABSL_GUARDED_BY(mu_);
};

}  // namespace meshgauge::server
