#include "server/upload_call.h"

#include <utility>

namespace meshgauge::server {

UploadCall::UploadCall(grpc::CallbackServerContext* ctx,
                       grpc::ByteBuffer* response, Body body,
                       std::function<void(UploadCall*)> done)
    : ctx_(ctx), response_(response), done_(std::move(done)) {
  absl::MutexLock lock(&mu_);
  thread_ = std::thread([this, body = std::move(body)] { Run(body); });
}

void UploadCall::Run(const Body& body) {
  { absl::MutexLock lock(&mu_); }  // thread_ is assigned.
  grpc::Status status;
  {
    v1::CreateSessionResponse response;
    status = body(*this, &response);
    if (status.ok()) {
      grpc::Slice slice(response.SerializeAsString());
      *response_ = grpc::ByteBuffer(&slice, 1);
    }
  }
  Finish(status);  // the last use of the call on this thread.
}

bool UploadCall::Read(UploadMessage* message) {
  if (ended_) return false;
  grpc::ByteBuffer buffer;
  StartRead(&buffer);
  bool ok;
  {
    absl::MutexLock lock(&mu_);
    mu_.Await(absl::Condition(&read_done_));
    read_done_ = false;
    ok = read_ok_;
  }
  // Bytes that are no CreateSessionRequest end the stream, as the
  // synchronous API's reader did.
  ended_ = !ok || !ParseUploadMessage(&buffer, message);
  return !ended_;
}

void UploadCall::OnReadDone(bool ok) {
  absl::MutexLock lock(&mu_);
  read_done_ = true;
  read_ok_ = ok;
}

void UploadCall::OnDone() { done_(this); }

void UploadCall::Join() {
  if (thread_.joinable()) thread_.join();
}

bool UploadCall::OnOwnThread() const {
  return thread_.get_id() == std::this_thread::get_id();
}

UploadCalls::~UploadCalls() {
  for (auto& call : done_) call->Join();
}

grpc::ServerReadReactor<grpc::ByteBuffer>* UploadCalls::Start(
    grpc::CallbackServerContext* ctx, grpc::ByteBuffer* response,
    UploadCall::Body body) {
  Reap();
  return new UploadCall(ctx, response, std::move(body),
                        [this](UploadCall* call) {
                          absl::MutexLock lock(&mu_);
                          done_.emplace_back(call);
                        });
}

void UploadCalls::Reap() {
  std::vector<std::unique_ptr<UploadCall>> reaped;
  {
    absl::MutexLock lock(&mu_);
    for (auto& call : done_) {
      if (!call->OnOwnThread()) reaped.push_back(std::move(call));
    }
    std::erase(done_, nullptr);
  }
  for (auto& call : reaped) call->Join();
}

}  // namespace meshgauge::server
