// The meshgauge.v1.MeshGauge gRPC service: a thin adapter. Each handler
// authenticates (Instrumented), converts its request (proto/wire), calls
// SessionCalls (computations and reads of sessions), the store or
// UploadReception (CreateSession) and converts the result back. The
// service counts its calls, so that Drain can wait for them.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"

#include "meshgauge/v1/meshgauge.grpc.pb.h"
#include "server/auth.h"
#include "server/clock.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/session_calls.h"
#include "server/session_store.h"
#include "server/upload_call.h"
#include "server/upload_reception.h"
#include "server/upload_watch.h"

namespace meshgauge::server {

// CreateSession is served through the callback API (upload_call.h), the
// other methods synchronously.
class MeshGaugeService final
    : public v1::MeshGauge::WithRawCallbackMethod_CreateSession<
          v1::MeshGauge::Service> {
 public:
  // All pointers must outlive the service. Every RPC authenticates through
  // `auth` (open mode: tenant "") and works in its tenant's namespace.
  MeshGaugeService(const ServerOptions& options, SessionStore* store,
                   UploadWatch* uploads, const Authenticator* auth,
                   Metrics* metrics, const Clock* clock);

  grpc::ServerReadReactor<grpc::ByteBuffer>* CreateSession(
      grpc::CallbackServerContext* ctx, grpc::ByteBuffer* response) override;
  grpc::Status GetSession(grpc::ServerContext* ctx,
                          const v1::GetSessionRequest* request,
                          v1::GetSessionResponse* response) override;
  grpc::Status ListSessions(grpc::ServerContext* ctx,
                            const v1::ListSessionsRequest* request,
                            v1::ListSessionsResponse* response) override;
  grpc::Status DeleteSession(grpc::ServerContext* ctx,
                             const v1::DeleteSessionRequest* request,
                             v1::DeleteSessionResponse* response) override;
  grpc::Status UpdatePositions(grpc::ServerContext* ctx,
                               const v1::UpdatePositionsRequest* request,
                               v1::UpdatePositionsResponse* response) override;
  grpc::Status ComputeSdf(
      grpc::ServerContext* ctx, const v1::ComputeSdfRequest* request,
      grpc::ServerWriter<v1::ComputeSdfResponse>* writer) override;
  grpc::Status ComputeVjp(grpc::ServerContext* ctx,
                          const v1::ComputeVjpRequest* request,
                          v1::ComputeVjpResponse* response) override;
  grpc::Status ComputePenalty(grpc::ServerContext* ctx,
                              const v1::ComputePenaltyRequest* request,
                              v1::ComputePenaltyResponse* response) override;
  grpc::Status Calibrate(grpc::ServerContext* ctx,
                         const v1::CalibrateRequest* request,
                         v1::CalibrateResponse* response) override;
  grpc::Status GetServerInfo(grpc::ServerContext* ctx,
                             const v1::GetServerInfoRequest* request,
                             v1::GetServerInfoResponse* response) override;
  grpc::Status GetMesh(grpc::ServerContext* ctx,
                       const v1::GetMeshRequest* request,
                       v1::GetMeshResponse* response) override;
  grpc::Status GradCheck(
      grpc::ServerContext* ctx, const v1::GradCheckRequest* request,
      grpc::ServerWriter<v1::GradCheckResponse>* writer) override;

  // The computation slots (for tests and diagnostics).
  const ComputeSlots& slots() const { return calls_.slots(); }

  // From now on every new call fails UNAVAILABLE ("draining"); returns when
  // the calls in flight have finished or at `deadline`.
  void Drain(std::chrono::system_clock::time_point deadline);

 private:
  // CreateSession's body, on its call's thread: the upload, then (refused
  // before the client finished sending) the rest of it read and dropped
  // (UploadReception::DiscardRest), which a drain waits for as for calls.
  grpc::Status ServeUpload(UploadCall& call,
                           v1::CreateSessionResponse* response);
  // Authenticates, runs body(tenant), records the RPC's code and latency.
  template <typename Body>
  grpc::Status Instrumented(const char* method,
                            const grpc::ServerContextBase* ctx, Body body);
  // A call (or discard) enters or leaves in_flight_ (leaving wakes Drain).
  void EnterInFlight();
  void LeaveInFlight();
  bool Drained() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(drain_mu_) {
    return in_flight_ == 0;
  }

  const ServerOptions& options_;
  SessionStore* store_;
  const Authenticator* auth_;
  Metrics* metrics_;
  const Clock* clock_;
  SessionCalls calls_;
  UploadReception reception_;
  absl::Mutex drain_mu_;
  bool draining_ ABSL_GUARDED_BY(drain_mu_) = false;
  int64_t in_flight_ ABSL_GUARDED_BY(drain_mu_) = 0;
  // Declared last, so destroyed first: joins the upload calls' threads
  // before what they use goes.
  UploadCalls upload_calls_;
};

}  // namespace meshgauge::server
