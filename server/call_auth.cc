#include "server/call_auth.h"

#include <grpc/grpc_security.h>

#include <map>
#include <string>

#include "absl/strings/match.h"
#include "absl/strings/string_view.h"

namespace meshgauge::server {
namespace {

constexpr absl::string_view kOpenPrefix = "/grpc.health.v1.Health/";
// The streamed upload: its handler authenticates before it reads a message.
constexpr absl::string_view kHandlerChecked =
    "/meshgauge.v1.MeshGauge/CreateSession";

// gRPC core calls this for each call's initial metadata (":path" among it)
// on the transport's thread; the answer is synchronous (a hash and a map
// look-up).
void Process(void* state, grpc_auth_context* /*context*/,
             const grpc_metadata* md, size_t num_md,
             grpc_process_auth_metadata_done_cb done, void* user_data) {
  const auto* auth = static_cast<const Authenticator*>(state);
  std::multimap<grpc::string_ref, grpc::string_ref> entries;
  bool open = false;
  for (size_t i = 0; i < num_md; ++i) {
    const grpc::string_ref key(
        reinterpret_cast<const char*>(GRPC_SLICE_START_PTR(md[i].key)),
        GRPC_SLICE_LENGTH(md[i].key));
    const grpc::string_ref value(
        reinterpret_cast<const char*>(GRPC_SLICE_START_PTR(md[i].value)),
        GRPC_SLICE_LENGTH(md[i].value));
    const absl::string_view path(value.data(), value.size());
    if (key == ":path" &&
        (absl::StartsWith(path, kOpenPrefix) || path == kHandlerChecked)) {
      open = true;
    }
    entries.emplace(key, value);
  }
  if (open) {
    done(user_data, nullptr, 0, nullptr, 0, GRPC_STATUS_OK, nullptr);
    return;
  }
  const absl::StatusOr<std::string> tenant = auth->AuthenticateMetadata(entries);
  if (tenant.ok()) {
    done(user_data, nullptr, 0, nullptr, 0, GRPC_STATUS_OK, nullptr);
  } else {
    const std::string message(tenant.status().message());
    done(user_data, nullptr, 0, nullptr, 0, GRPC_STATUS_UNAUTHENTICATED,
         message.c_str());
  }
}

// A grpc::ServerCredentials over gRPC core credentials (the C++ wrapper of
// insecure credentials cannot take a processor in gRPC 1.51).
class CoreCredentials final : public grpc::ServerCredentials {
 public:
  explicit CoreCredentials(grpc_server_credentials* core) : core_(core) {}
  ~CoreCredentials() override { grpc_server_credentials_release(core_); }
  CoreCredentials(const CoreCredentials&) = delete;
  CoreCredentials& operator=(const CoreCredentials&) = delete;

  void SetAuthMetadataProcessor(
      const std::shared_ptr<grpc::AuthMetadataProcessor>& /*p*/) override {}

 private:
  int AddPortToServer(const std::string& addr, grpc_server* server) override {
    return grpc_server_add_http2_port(server, addr.c_str(), core_);
  }

  grpc_server_credentials* core_;
};

grpc_server_credentials* CoreTls(const TlsMaterial& tls) {
  grpc_ssl_pem_key_cert_pair pair = {tls.private_key.c_str(),
                                     tls.cert_chain.c_str()};
  return grpc_ssl_server_credentials_create_ex(
      tls.client_ca.empty() ? nullptr : tls.client_ca.c_str(), &pair, 1,
      tls.client_ca.empty()
          ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
          : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY,
      nullptr);
}

}  // namespace

std::shared_ptr<grpc::ServerCredentials> CallAuthCredentials(
    const TlsMaterial& tls, const Authenticator* auth) {
  grpc_server_credentials* core = tls.cert_chain.empty()
                                      ? grpc_insecure_server_credentials_create()
                                      : CoreTls(tls);
  if (auth->has_tokens()) {
    grpc_server_credentials_set_auth_metadata_processor(
        core, {&Process, nullptr, const_cast<Authenticator*>(auth)});
  }
  return std::make_shared<CoreCredentials>(core);
}

}  // namespace meshgauge::server
