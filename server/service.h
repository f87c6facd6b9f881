// The meshgauge.v1.MeshGauge gRPC service (synchronous API). Geometry lives
// in lib/; this class validates requests, maps sessions, caches ray passes
// and converts to and from the wire types.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>

#include "meshgauge/v1/meshgauge.grpc.pb.h"
#include "server/auth.h"
#include "server/clock.h"
#include "server/compute_slots.h"
#include "server/mesh_upload.h"
#include "server/metrics.h"
#include "server/server_options.h"
#include "server/session_store.h"
#include "server/upload_watch.h"

namespace meshgauge::server {

class MeshGaugeService final : public v1::MeshGauge::Service {
 public:
  // All pointers must outlive the service. Every RPC authenticates through
  // `auth` (open mode: tenant "") and works in its tenant's namespace.
  MeshGaugeService(const ServerOptions& options, SessionStore* store,
                   UploadWatch* uploads, const Authenticator* auth,
                   Metrics* metrics, const Clock* clock);

  // CreateSession is served by BoundedCreateSession: its messages are read
  // as UploadMessage, whose size is checked before they are parsed.
  grpc::Status BoundedCreateSession(grpc::ServerContext* ctx,
                                    grpc::ServerReader<UploadMessage>* reader,
                                    v1::CreateSessionResponse* response);
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
  const ComputeSlots& slots() const { return slots_; }

  // From now on every new call fails UNAVAILABLE ("draining"); returns when
  // the calls in flight have finished or at `deadline`.
  void Drain(std::chrono::system_clock::time_point deadline);

 private:
  struct Pass {
    std::shared_ptr<const CachedPass> pass;
    bool reused = false;
  };
  // Shared front half of the compute calls: a computation slot, session,
  // params, generation.
  struct Prepared {
    ComputeSlots::Slot slot;  // released last, after the session's lock.
    std::shared_ptr<Session> session;
    Session::Reader reader;
    SdfParams params;
  };
  // The session's ray pass for prep's parameters at the reader's
  // generation: cached, or traced now (and cached) under `control`
  // (cancellation and deadlines of ctx; progress). A new pass's memory is
  // claimed for `tenant` before it is traced (RESOURCE_EXHAUSTED when it
  // cannot fit).
  absl::StatusOr<Pass> EnsurePass(grpc::ServerContext* ctx,
                                  const std::string& tenant,
                                  const Prepared& prep,
                                  const ComputeControl& control);
  // A computation slot for `tenant` (ComputeSlots), waiting while ctx
  // lives.
  absl::StatusOr<ComputeSlots::Slot> TakeSlot(const std::string& tenant,
                                              grpc::ServerContext* ctx);
  // A computation slot (TakeSlot), then the session, its parameters and
  // its reader at the expected generation.
  absl::StatusOr<Prepared> Prepare(grpc::ServerContext* ctx,
                                   const std::string& tenant,
                                   const std::string& session_id,
                                   const v1::SdfParameters& params,
                                   bool has_expected_generation,
                                   int64_t expected_generation);
  ComputeControl Control(grpc::ServerContext* ctx) const;
  // A ComputeControl::progress that streams SdfProgress messages (with
  // `rays_total`) to `writer` (report_progress).
  template <typename Response>
  static std::function<void(int64_t, int64_t)> ProgressWriter(
      int64_t rays_total, grpc::ServerWriter<Response>* writer);
  absl::Status Interrupted(grpc::ServerContext* ctx, absl::Status s) const;
  // Authenticates, runs body(tenant), records the RPC's code and latency.
  template <typename Body>
  grpc::Status Instrumented(const char* method, const grpc::ServerContext* ctx,
                            Body body);
  struct UploadProgress {
    int64_t received = 0;  // bytes of the messages read.
    bool ended = false;    // the client's stream was read to its end.
  };
  // The CreateSession stream after its upload slot was taken.
  absl::Status ReceiveUpload(grpc::ServerContext* ctx,
                             grpc::ServerReader<UploadMessage>* reader,
                             const std::string& tenant, int64_t upload,
                             v1::CreateSessionResponse* response,
                             UploadProgress* progress);
  // Reads and drops the rest of an upload refused before its client
  // finished sending, so that the refusal ends a complete request: an
  // HTTP/2 proxy such as HAProxy 2.6 (haproxy issue 1219) loses a reply that
  // closes a stream the client still sends on, together with the
  // RST_STREAM(NO_ERROR) that follows it, and gives the client CANCELLED
  // instead of the status. Bounded by UploadWatch (at most kMaxDiscards at
  // once, kMaxDiscardBytes, kMaxDiscardSeconds; the sweeper cancels a
  // discard past its time, silent or not, within a second): past the bytes
  // the refusal is sent at once, past the time the call is cancelled. A
  // drain waits for discards as for calls.
  void DiscardRest(grpc::ServerContext* ctx,
                   grpc::ServerReader<UploadMessage>* reader);
  // A call (or discard) counted in in_flight_ ended: wakes Drain.
  void LeaveInFlight();
  // The mesh of a received upload (its footer arrived): read or built
  // within the server's limits and `ticket`, repaired and diagnosed.
  absl::StatusOr<RepairedMesh> BuildUploadedMesh(
      grpc::ServerContext* ctx, MeshAssembler& assembler,
      UploadReservation& ticket) const;
  // RESOURCE_EXHAUSTED when a reply of `values` doubles would exceed
  // --max_message_bytes (checked before computing).
  absl::Status CheckReplySize(int64_t values) const;

  const ServerOptions& options_;
  SessionStore* store_;
  UploadWatch* uploads_;
  const Authenticator* auth_;
  Metrics* metrics_;
  const Clock* clock_;
  ComputeSlots slots_;
  std::mutex drain_mu_;
  std::condition_variable drain_cv_;
  bool draining_ = false;
  int64_t in_flight_ = 0;
};

}  // namespace meshgauge::server
