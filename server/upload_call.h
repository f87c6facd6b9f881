// CreateSession through gRPC's callback API (the generated
// WithRawCallbackMethod_CreateSession): its messages arrive as bytes, so
// that each is checked before it is parsed (ParseUploadMessage), and the
// call's body runs on a thread of its own that reads them one at a time,
// as a synchronous handler would: it authenticates before it reads any
// message, talks to the store and builds meshes for seconds, which gRPC's
// callback threads must not.
#pragma once

#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "meshgauge/v1/meshgauge.pb.h"
#include "server/upload_reception.h"

namespace meshgauge::server {

class UploadCall final : public grpc::ServerReadReactor<grpc::ByteBuffer>,
                         public UploadStream {
 public:
  // Serves the call: its status, and the response when OK.
  using Body = std::function<grpc::Status(UploadCall& call,
                                          v1::CreateSessionResponse* response)>;

  // Starts `body` on the call's thread; the call ends with its status.
  // `done` is called once gRPC is done with the call (the thread then ends
  // at once; join it before deleting the call).
  UploadCall(grpc::CallbackServerContext* ctx, grpc::ByteBuffer* response,
             Body body, std::function<void(UploadCall*)> done);

  // UploadStream, for the body's thread only.
  bool Read(UploadMessage* message) override;
  bool ended() const override { return ended_; }
  bool IsCancelled() const override { return ctx_->IsCancelled(); }
  grpc::ServerContextBase* context() override { return ctx_; }

  // Waits for the call's thread (returns at once after `done`).
  void Join();
  // True when called on the call's thread.
  bool OnOwnThread() const;

 private:
  void Run(const Body& body);
  void OnReadDone(bool ok) override;
  void OnDone() override;

  grpc::CallbackServerContext* const ctx_;
  grpc::ByteBuffer* const response_;
  const std::function<void(UploadCall*)> done_;
  bool ended_ = false;
  absl::Mutex mu_;  // also held while thread_ is assigned.
  bool read_done_ ABSL_GUARDED_BY(mu_) = false;
  bool read_ok_ ABSL_GUARDED_BY(mu_) = false;
  // Assigned in the constructor (under mu_, which the thread takes first),
  // then only read.
  std::thread thread_;
};

// The CreateSession calls of a service: makes them and deletes them once
// done.
class UploadCalls {
 public:
  UploadCalls() = default;
  UploadCalls(const UploadCalls&) = delete;
  UploadCalls& operator=(const UploadCalls&) = delete;
  // Precondition: the server was shut down (every call is done).
  ~UploadCalls();

  // A new call of `ctx` served by `body` (UploadCall).
  grpc::ServerReadReactor<grpc::ByteBuffer>* Start(
      grpc::CallbackServerContext* ctx, grpc::ByteBuffer* response,
      UploadCall::Body body);

 private:
  // Joins and deletes the calls that are done (not the caller's own).
  void Reap();

  absl::Mutex mu_;
  std::vector<std::unique_ptr<UploadCall>> done_ ABSL_GUARDED_BY(mu_);
};

}  // namespace meshgauge::server
