// Configuration of the meshgauge gRPC server. Built from flags in main.cc
// only (the field names are the flag names); tests construct it directly.
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/status.h"

namespace meshgauge::server {

struct ServerOptions {
  std::string address = "127.0.0.1:50051";         // gRPC listen address.
  std::string metrics_address = "127.0.0.1:9464";  // Prometheus; "" = off.
  bool reflection = false;                         // gRPC server reflection.
  // TLS: PEM files; both or neither. With tls_client_ca_file, clients must
  // present a certificate signed by that CA (mutual TLS).
  std::string tls_cert_file, tls_key_file, tls_client_ca_file;
  // `TENANT SHA256HEX` lines; empty: open mode (no authentication).
  std::string auth_tokens_file;
  // Where sessions live: "" keeps them in this process's memory;
  // "redis://HOST[:PORT]" keeps them in Redis, shared by every replica.
  std::string session_store;
  int64_t max_message_bytes = 256ll << 20;  // per gRPC message, both ways.
  // Per CreateSession message, checked before it is parsed (gRPC refuses
  // anything over max_message_bytes before that).
  int64_t max_upload_message_bytes = 16ll << 20;
  // A mesh file sent for the server's readers (CreateSession file_format).
  int64_t max_upload_file_bytes = 256ll << 20;
  int64_t max_sessions = 64;                // sessions and uploads in flight.
  int64_t max_vertices = 5'000'000;         // per session.
  int64_t max_faces = 10'000'000;           // per session.
  int max_rays = 1024;                      // per vertex, <= 4096.
  int64_t memory_budget_bytes = 8ll << 30;  // all sessions, LRU eviction.
  // Per tenant (0: the server-wide value).
  int64_t max_sessions_per_tenant = 0;
  int64_t memory_budget_bytes_per_tenant = 0;
  int64_t max_concurrent_uploads = 16;
  double upload_idle_seconds = 30;  // an upload silent this long is aborted.
  // An upload is aborted when it has run this long in all, or when, after
  // its first upload_idle_seconds, it averages fewer bytes per second than
  // upload_min_bytes_per_second (0: no minimum).
  double upload_deadline_seconds = 600;
  double upload_min_bytes_per_second = 65536;
  double session_ttl_seconds = 3600;  // idle sessions are evicted.
  int rebuild_every_updates = 32;     // BVH refits between full rebuilds.
  int compute_threads = 0;            // per computation; 0 = all cores.
  // Computations (ray passes, sensitivities, checks) running at once per
  // tenant and in all; more wait in a queue served round robin across
  // tenants (ComputeSlots). 0: the cores, and 4 x the cores.
  int max_computations_per_tenant = 0;
  int max_concurrent_computations = 0;
  // On shutdown, health reports NOT_SERVING for this long while calls are
  // still accepted (so balancers stop routing), then the server drains.
  double drain_notice_seconds = 1;
  double shutdown_grace_seconds = 20;  // in-flight calls may finish.
  double sweep_interval_seconds = 5;   // TTL sweep period.

  int ComputationsPerTenant() const;
  int ConcurrentComputations() const;
  int64_t SessionsPerTenant() const {
    return max_sessions_per_tenant > 0 ? max_sessions_per_tenant : max_sessions;
  }
  int64_t BudgetPerTenant() const {
    return memory_budget_bytes_per_tenant > 0 ? memory_budget_bytes_per_tenant
                                              : memory_budget_bytes;
  }
};

// Checks every limit against its range; InvalidArgument names the flag
// (--field) and the range.
absl::Status ValidateServerOptions(const ServerOptions& options);

// A listen address: HOST:PORT or [IPV6]:PORT with a host and a decimal
// port in [0, 65535] (0: any free port), or one of gRPC's unix:PATH,
// unix-abstract:NAME, vsock:CID:PORT. InvalidArgument naming --address and
// the expected form.
absl::Status CheckListenAddress(const std::string& address);

}  // namespace meshgauge::server
