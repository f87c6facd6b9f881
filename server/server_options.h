// Configuration of the meshgauge gRPC server. Built from flags in main.cc
// only; tests construct it directly.
#pragma once

#include <cstdint>
#include <string>

namespace meshgauge::server {

struct ServerOptions {
  std::string address = "127.0.0.1:50051";         // gRPC listen address.
  std::string metrics_address = "127.0.0.1:9464";  // Prometheus; "" = off.
  bool reflection = false;                         // gRPC server reflection.
  int64_t max_message_bytes = 256ll << 20;  // per gRPC message, both ways.
  int64_t max_sessions = 64;
  int64_t max_vertices = 5'000'000;         // per session.
  int64_t max_faces = 10'000'000;           // per session.
  int max_rays = 1024;                      // per vertex, <= 4096.
  int64_t memory_budget_bytes = 8ll << 30;  // all sessions, LRU eviction.
  double session_ttl_seconds = 3600;        // idle sessions are evicted.
  int rebuild_every_updates = 32;           // BVH refits between full rebuilds.
  int compute_threads = 0;                  // per computation; 0 = all cores.
  // On shutdown, health reports NOT_SERVING for this long while calls are
  // still accepted (so balancers stop routing), then the server drains.
  double drain_notice_seconds = 1;
  double shutdown_grace_seconds = 20;  // in-flight calls may finish.
  double sweep_interval_seconds = 5;   // TTL sweep period.
};

}  // namespace meshgauge::server
