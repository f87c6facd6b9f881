// gRPC server reflection is gRPC's own service, outside MeshGaugeService
// and its authentication. With tokens on, this interceptor lets only
// authenticated callers read the schema: for any other caller the call is
// cancelled at once, every reply it may still send is emptied, and its
// status (when the client half-closed first) is UNAUTHENTICATED.
#pragma once

#include <grpcpp/support/server_interceptor.h>

#include "server/auth.h"

namespace meshgauge::server {

class ReflectionGuardFactory
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  // auth must outlive the server.
  explicit ReflectionGuardFactory(const Authenticator* auth) : auth_(auth) {}
  // Null (no interceptor) for every method but reflection's.
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override;

 private:
  const Authenticator* auth_;
};

}  // namespace meshgauge::server
