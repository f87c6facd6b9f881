#include "server/reflection_guard.h"

#include <string>

#include "absl/strings/match.h"

namespace meshgauge::server {
namespace {

using grpc::experimental::InterceptionHookPoints;

class ReflectionGuard : public grpc::experimental::Interceptor {
 public:
  ReflectionGuard(const Authenticator* auth,
                  grpc::experimental::ServerRpcInfo* info)
      : auth_(auth), info_(info) {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* m) override {
    if (m->QueryInterceptionHookPoint(
            InterceptionHookPoints::POST_RECV_INITIAL_METADATA)) {
      auto tenant = auth_->AuthenticateMetadata(*m->GetRecvInitialMetadata());
      if (!tenant.ok()) {
        refusal_ = std::string(tenant.status().message());
        // gRPC's reflection handler reads until the client half-closes; a
        // client that keeps its stream open would wait for ever, holding a
        // thread: the call is ended now (such a client sees CANCELLED).
        info_->server_context()->TryCancel();
      }
    }
    if (!refusal_.empty()) {
      if (m->QueryInterceptionHookPoint(
              InterceptionHookPoints::PRE_SEND_MESSAGE)) {
        if (grpc::ByteBuffer* b = m->GetSerializedSendMessage()) b->Clear();
      }
      if (m->QueryInterceptionHookPoint(
              InterceptionHookPoints::PRE_SEND_STATUS)) {
        m->ModifySendStatus(
            grpc::Status(grpc::StatusCode::UNAUTHENTICATED, refusal_));
      }
    }
    m->Proceed();
  }

 private:
  const Authenticator* auth_;
  grpc::experimental::ServerRpcInfo* info_;
  std::string refusal_;
};

}  // namespace

grpc::experimental::Interceptor*
ReflectionGuardFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo* info) {
  if (!absl::StartsWith(info->method(), "/grpc.reflection.")) return nullptr;
  return new ReflectionGuard(auth_, info);
}

}  // namespace meshgauge::server
