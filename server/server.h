// A running meshgauge gRPC server: the service, the health service
// (SERVING after start-up, NOT_SERVING while draining), optional reflection,
// message size limits and a periodic TTL sweep.
#pragma once

#include <grpcpp/grpcpp.h>

#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>

#include "absl/status/statusor.h"
#include "server/clock.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/service.h"
#include "server/session_store.h"

namespace meshgauge::server {

class MeshGaugeServer {
 public:
  // Binds options.address (port 0: any free port) and starts serving.
  // options, metrics and clock must outlive the server.
  // Errors: UNAVAILABLE when the address cannot be bound.
  static absl::StatusOr<std::unique_ptr<MeshGaugeServer>> Start(
      const ServerOptions& options, Metrics* metrics, const Clock* clock);
  ~MeshGaugeServer();

  int port() const { return port_; }
  SessionStore& store() { return store_; }

  // Graceful drain: health turns NOT_SERVING (calls are still served for
  // options.drain_notice_seconds), then new calls are refused, calls in
  // flight may finish within options.shutdown_grace_seconds, and the rest
  // are cancelled. Idempotent; blocks until drained.
  void Shutdown();
  // Blocks until the server has shut down.
  void Wait();

 private:
  MeshGaugeServer(const ServerOptions& options, Metrics* metrics,
                  const Clock* clock);
  void SweepLoop();

  const ServerOptions& options_;
  SessionStore store_;
  MeshGaugeService service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::thread sweeper_;
};

}  // namespace meshgauge::server
