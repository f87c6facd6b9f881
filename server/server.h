// A running meshgauge gRPC server: the service, the health service
// (SERVING after start-up, NOT_SERVING while draining), optional reflection,
// message size limits and a periodic TTL sweep.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <thread>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "server/auth.h"
#include "server/clock.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/service.h"
#include "server/session_store.h"
#include "server/upload_watch.h"

namespace meshgauge::server {

class MeshGaugeServer {
 public:
  // Validates the options, loads the tokens file and TLS files, binds
  // options.address (port 0: any free port; SO_REUSEPORT off) and starts
  // serving. options, metrics and clock must outlive the server.
  // With options.session_store, sessions are records in that store (the
  // server starts while it is unreachable; calls then fail UNAVAILABLE).
  // Errors: INVALID_ARGUMENT (an option out of range, a bad tokens file),
  // NOT_FOUND (an unreadable file), UNAVAILABLE when the address cannot be
  // bound or reflection cannot be loaded.
  static absl::StatusOr<std::unique_ptr<MeshGaugeServer>> Start(
      const ServerOptions& options, Metrics* metrics, const Clock* clock);
  ~MeshGaugeServer();

  int port() const { return port_; }
  SessionStore& store() { return *store_; }
  MeshGaugeService& service() { return service_; }

  // Graceful drain: health turns NOT_SERVING (calls are still served for
  // options.drain_notice_seconds), then new calls are refused with
  // UNAVAILABLE (clients retry elsewhere), calls in flight may finish within
  // options.shutdown_grace_seconds, and the rest are cancelled. Idempotent;
  // blocks until drained.
  void Shutdown();
  // Blocks until the server has shut down.
  void Wait();
  // Re-reads --auth_tokens_file (SIGHUP): see Authenticator::Reload.
  absl::Status ReloadTokens();

 private:
  MeshGaugeServer(const ServerOptions& options, Authenticator auth,
                  std::unique_ptr<SessionStore> store, Metrics* metrics,
                  const Clock* clock);
  // TTL sweeps and idle-upload aborts until Shutdown.
  void SweepLoop();

  const ServerOptions& options_;
  Authenticator auth_;
  std::unique_ptr<SessionStore> store_;
  UploadWatch uploads_;
  MeshGaugeService service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  absl::Mutex mu_;
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::thread sweeper_;
};

}  // namespace meshgauge::server
