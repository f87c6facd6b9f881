#include "server/metrics.h"

#include <prometheus/text_serializer.h>

#include <chrono>

namespace meshgauge::server {
namespace {

const prometheus::Histogram::BucketBoundaries& LatencyBuckets() {
  static const prometheus::Histogram::BucketBoundaries kBuckets = {
      0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1,
      0.25,   0.5,   1,      2.5,   5,    10,    30,   60};
  return kBuckets;
}

}  // namespace

// Over 80 lines, and kept so: one registration per metric, each a few lines
// of name, help and buckets in the order of metrics.h, read as a table.
Metrics::Metrics()
    : registry_(std::make_shared<prometheus::Registry>()),
      rpcs_(prometheus::BuildCounter()
                .Name("meshgauge_rpc_requests_total")
                .Help("Completed RPCs by method and gRPC status code")
                .Register(*registry_)),
      rpc_seconds_(prometheus::BuildHistogram()
                       .Name("meshgauge_rpc_duration_seconds")
                       .Help("RPC latency by method")
                       .Register(*registry_)),
      sessions_active_(prometheus::BuildGauge()
                           .Name("meshgauge_sessions_active")
                           .Help("Sessions held by the server")
                           .Register(*registry_)
                           .Add({})),
      cache_bytes_(prometheus::BuildGauge()
                       .Name("meshgauge_session_cache_bytes")
                       .Help("Memory accounted to sessions (meshes, BVHs, "
                             "cached ray passes)")
                       .Register(*registry_)
                       .Add({})),
      evictions_(
          prometheus::BuildCounter()
              .Name("meshgauge_session_evictions_total")
              .Help("Sessions evicted, by reason (ttl, memory; cache_ttl, "
                    "cache_memory: only a replica's cache entry with "
                    "--session_store)")
              .Register(*registry_)),
      bvh_builds_(prometheus::BuildCounter()
                      .Name("meshgauge_bvh_builds_total")
                      .Help("Full BVH builds")
                      .Register(*registry_)
                      .Add({})),
      bvh_refits_(prometheus::BuildCounter()
                      .Name("meshgauge_bvh_refits_total")
                      .Help("BVH refits after position updates")
                      .Register(*registry_)
                      .Add({})),
      bvh_build_seconds_(prometheus::BuildHistogram()
                             .Name("meshgauge_bvh_build_seconds")
                             .Help("Time of full BVH builds")
                             .Register(*registry_)
                             .Add({}, LatencyBuckets())),
      bvh_refit_seconds_(prometheus::BuildHistogram()
                             .Name("meshgauge_bvh_refit_seconds")
                             .Help("Time of BVH refits (with validation)")
                             .Register(*registry_)
                             .Add({}, LatencyBuckets())),
      rays_(prometheus::BuildCounter()
                .Name("meshgauge_rays_traced_total")
                .Help("Rays traced")
                .Register(*registry_)
                .Add({})),
      hit_cache_(prometheus::BuildCounter()
                     .Name("meshgauge_hit_cache_requests_total")
                     .Help("Sensitivity requests served from a cached ray "
                           "pass (result=reused) or tracing anew (traced)")
                     .Register(*registry_)),
      session_cache_(prometheus::BuildCounter()
                         .Name("meshgauge_session_cache_requests_total")
                         .Help("Calls on a stored session (--session_store) "
                               "that found it cached on this replica "
                               "(result=hit) or loaded it (miss)")
                         .Register(*registry_)),
      session_load_seconds_(
          prometheus::BuildHistogram()
              .Name("meshgauge_session_load_seconds")
              .Help("Cache misses: loading a session's record from the "
                    "store and building its BVH")
              .Register(*registry_)
              .Add({}, LatencyBuckets())),
      retried_attempts_(prometheus::BuildCounter()
                            .Name("meshgauge_rpc_retried_attempts_total")
                            .Help("Calls that were a client's retry of an "
                                  "earlier attempt, by method")
                            .Register(*registry_)),
      session_store_errors_(
          prometheus::BuildCounter()
              .Name("meshgauge_session_store_errors_total")
              .Help("Calls on the session store (--session_store) that "
                    "failed because it was unreachable or refused them")
              .Register(*registry_)
              .Add({})) {
  // The conventional gauge of Prometheus' client libraries: a replica
  // restarting in a loop shows as its changes (deploy/prometheus/alerts.yml).
  prometheus::BuildGauge()
      .Name("process_start_time_seconds")
      .Help("Start time of the process since the Unix epoch, in seconds")
      .Register(*registry_)
      .Add({})
      .Set(std::chrono::duration<double>(
               std::chrono::system_clock::now().time_since_epoch())
               .count());
  // Every method's retry counter exists from the start, so that a rate or
  // increase over a window sees the first retries too.
  for (const char* method :
       {"CreateSession", "GetSession", "ListSessions", "DeleteSession",
        "UpdatePositions", "ComputeSdf", "ComputeVjp", "ComputePenalty",
        "Calibrate", "GetServerInfo", "GetMesh", "GradCheck"}) {
    retried_attempts_.Add({{"method", method}});
  }
}

std::string Metrics::Text() const {
  return prometheus::TextSerializer().Serialize(registry_->Collect());
}

void Metrics::RecordRpc(const std::string& method, const std::string& code,
                        double seconds) {
  rpcs_.Add({{"method", method}, {"code", code}}).Increment();
  prometheus::Histogram* h;
  {
    absl::MutexLock lock(&mu_);
    auto it = rpc_histograms_.find(method);
    if (it == rpc_histograms_.end()) {
      it = rpc_histograms_
               .emplace(method, &rpc_seconds_.Add({{"method", method}},
                                                  LatencyBuckets()))
               .first;
    }
    h = it->second;
  }
  h->Observe(seconds);
}

void Metrics::SetSessions(double active, double bytes) {
  sessions_active_.Set(active);
  cache_bytes_.Set(bytes);
}

void Metrics::RecordEviction(const std::string& reason) {
  evictions_.Add({{"reason", reason}}).Increment();
}

void Metrics::RecordBvhBuild(double seconds) {
  bvh_builds_.Increment();
  bvh_build_seconds_.Observe(seconds);
}

void Metrics::RecordBvhRefit(double seconds) {
  bvh_refits_.Increment();
  bvh_refit_seconds_.Observe(seconds);
}

void Metrics::AddRays(double rays) { rays_.Increment(rays); }

void Metrics::RecordHitCache(bool reused) {
  hit_cache_.Add({{"result", reused ? "reused" : "traced"}}).Increment();
}

void Metrics::RecordSessionCache(bool hit, double seconds) {
  session_cache_.Add({{"result", hit ? "hit" : "miss"}}).Increment();
  if (!hit) session_load_seconds_.Observe(seconds);
}

void Metrics::RecordSessionStoreError() { session_store_errors_.Increment(); }

void Metrics::RecordRetriedAttempt(const std::string& method) {
  retried_attempts_.Add({{"method", method}}).Increment();
}

}  // namespace meshgauge::server
