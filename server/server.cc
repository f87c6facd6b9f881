#include "server/server.h"

#include <dlfcn.h>
#include <grpc/support/log.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/security/server_credentials.h>
#include <openssl/err.h>
#include <openssl/pem.h>

#include <algorithm>
#include <iostream>
#include <mutex>

#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "lib/io/text_file.h"
#include "server/call_auth.h"
#include "server/make_session_store.h"

namespace meshgauge::server {
namespace {

// A PEM file's text, checked to hold what the flag names (certificates, or
// a private key), so that a bad file is named here and not reported later
// as a failure to listen.
absl::StatusOr<std::string> ReadPem(const std::string& path, const char* flag,
                                    bool key) {
  auto text = ReadTextFile(path, absl::StrCat("--", flag, " file"));
  if (!text.ok()) return text.status();
  BIO* bio = BIO_new_mem_buf(text->data(), static_cast<int>(text->size()));
  bool ok = false;
  if (key) {
    // No passphrase prompt: an encrypted key is refused, not asked about.
    pem_password_cb* no_passphrase = [](char*, int, int, void*) { return 0; };
    EVP_PKEY* k = PEM_read_bio_PrivateKey(bio, nullptr, no_passphrase, nullptr);
    ok = k != nullptr;
    EVP_PKEY_free(k);
  } else {
    X509* cert = PEM_read_bio_X509(bio, nullptr, nullptr, nullptr);
    ok = cert != nullptr;
    X509_free(cert);
  }
  BIO_free(bio);
  ERR_clear_error();
  if (!ok) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", flag, " file '", path, "' holds no PEM ",
                     key ? "private key (unencrypted)" : "certificate"));
  }
  return text;
}

// gRPC's own log lines while the server binds: kept, so that a failure is
// reported in one line of ours that names gRPC's cause.
class BindLog {
 public:
  BindLog() {
    std::lock_guard<std::mutex> lock(Mu());
    Lines().clear();
    gpr_set_log_function(&BindLog::Keep);
  }
  ~BindLog() { gpr_set_log_function(nullptr); }  // gRPC's default again.
  // The system's error when gRPC names one (os_error:"..."), else the first
  // line's text before its details.
  std::string Cause() const {
    std::lock_guard<std::mutex> lock(Mu());
    absl::string_view lines = Lines();
    constexpr absl::string_view kOsError = "os_error:\"";
    if (size_t at = lines.find(kOsError); at != absl::string_view::npos) {
      absl::string_view rest = lines.substr(at + kOsError.size());
      return std::string(rest.substr(0, rest.find('"')));
    }
    return std::string(lines.substr(0, lines.find(" {")));
  }

 private:
  static std::mutex& Mu() {
    static std::mutex mu;
    return mu;
  }
  static std::string& Lines() {
    static std::string lines;
    return lines;
  }
  static void Keep(gpr_log_func_args* args) {
    if (args->severity != GPR_LOG_SEVERITY_ERROR) return;
    std::lock_guard<std::mutex> lock(Mu());
    std::string& lines = Lines();
    if (lines.size() < 2000) {
      absl::StrAppend(&lines, lines.empty() ? "" : "; ", args->message);
    }
  }
};

absl::StatusOr<TlsMaterial> ReadTls(const ServerOptions& o) {
  TlsMaterial tls;
  if (o.tls_cert_file.empty()) return tls;
  auto cert = ReadPem(o.tls_cert_file, "tls_cert_file", false);
  if (!cert.ok()) return cert.status();
  auto key = ReadPem(o.tls_key_file, "tls_key_file", true);
  if (!key.ok()) return key.status();
  tls.cert_chain = *std::move(cert);
  tls.private_key = *std::move(key);
  if (!o.tls_client_ca_file.empty()) {
    auto ca = ReadPem(o.tls_client_ca_file, "tls_client_ca_file", false);
    if (!ca.ok()) return ca.status();
    tls.client_ca = *std::move(ca);
  }
  return tls;
}

// gRPC's reflection library registers its plugin for every server when it
// is loaded, so it is not linked: it is loaded here, only on request.
absl::Status LoadReflection() {
  static void* handle =
      dlopen(MESHGAUGE_GRPC_REFLECTION_LIBRARY, RTLD_NOW | RTLD_GLOBAL);
  if (!handle) {
    return absl::UnavailableError(
        absl::StrCat("--reflection: cannot load ",
                     MESHGAUGE_GRPC_REFLECTION_LIBRARY, ": ", dlerror()));
  }
  return absl::OkStatus();
}

}  // namespace

MeshGaugeServer::MeshGaugeServer(const ServerOptions& options,
                                 Authenticator auth,
                                 std::unique_ptr<SessionStore> store,
                                 Metrics* metrics, const Clock* clock)
    : options_(options),
      auth_(std::move(auth)),
      store_(std::move(store)),
      uploads_(options, clock),
      service_(options, store_.get(), &uploads_, &auth_, metrics, clock) {}

absl::StatusOr<std::unique_ptr<MeshGaugeServer>> MeshGaugeServer::Start(
    const ServerOptions& options, Metrics* metrics, const Clock* clock) {
  if (absl::Status s = ValidateServerOptions(options); !s.ok()) return s;
  if (absl::Status s = CheckListenAddress(options.address); !s.ok()) return s;
  Authenticator auth;
  if (!options.auth_tokens_file.empty()) {
    auto loaded = Authenticator::FromFile(options.auth_tokens_file);
    if (!loaded.ok()) return loaded.status();
    auth = std::move(*loaded);
  }
  auto tls = ReadTls(options);
  if (!tls.ok()) return tls.status();
  if (options.reflection) {
    if (absl::Status s = LoadReflection(); !s.ok()) return s;
  }
  auto store = MakeSessionStore(options, metrics, clock);
  if (!store.ok()) return store.status();
  std::unique_ptr<MeshGaugeServer> s(new MeshGaugeServer(
      options, std::move(auth), *std::move(store), metrics, clock));
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.address,
                           CallAuthCredentials(*tls, &s->auth_), &s->port_);
  // A second server on a taken port must fail, not split the clients.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.RegisterService(&s->service_);
  const int max_bytes =
      static_cast<int>(std::min<int64_t>(options.max_message_bytes, INT32_MAX));
  builder.SetMaxReceiveMessageSize(max_bytes);
  builder.SetMaxSendMessageSize(max_bytes);
  std::string cause;
  {
    BindLog log;
    s->server_ = builder.BuildAndStart();
    cause = log.Cause();
  }
  if (!s->server_ || s->port_ == 0) {
    return absl::UnavailableError(absl::StrCat(
        "cannot listen on ", options.address, ": ",
        cause.empty() ? "the port is taken or the host is not local" : cause));
  }
  s->server_->GetHealthCheckService()->SetServingStatus(true);
  s->sweeper_ = std::thread([raw = s.get()] { raw->SweepLoop(); });
  return s;
}

MeshGaugeServer::~MeshGaugeServer() {
  Shutdown();
  Wait();
}

void MeshGaugeServer::SweepLoop() {
  // Idle uploads are checked four times per allowed idle time, and
  // discards (kMaxDiscardSeconds) at least once a second.
  const double period = std::min(
      {options_.sweep_interval_seconds, options_.upload_idle_seconds / 4, 1.0});
  double since_sweep = 0;
  for (;;) {
    {
      absl::MutexLock lock(&mu_);
      mu_.AwaitWithTimeout(absl::Condition(&stopping_), absl::Seconds(period));
      if (stopping_) return;
    }
    for (const std::string& line : uploads_.AbortIdle()) {
      std::cerr << "meshgauge-server: CreateSession: " << line << std::endl;
    }
    // Cancelled only after their lines are logged, so that a call ends after
    // its line.
    uploads_.CancelAborted();
    since_sweep += period;
    if (since_sweep >= options_.sweep_interval_seconds) {
      store_->Sweep();
      since_sweep = 0;
    }
  }
}

absl::Status MeshGaugeServer::ReloadTokens() {
  return auth_.Reload(options_.auth_tokens_file);
}

void MeshGaugeServer::Shutdown() {
  {
    absl::MutexLock lock(&mu_);
    if (stopping_) return;
    stopping_ = true;
  }
  if (sweeper_.joinable()) sweeper_.join();
  if (!server_) return;  // never started.
  server_->GetHealthCheckService()->SetServingStatus(false);
  std::this_thread::sleep_for(
      std::chrono::duration<double>(options_.drain_notice_seconds));
  // New calls get UNAVAILABLE from here on (gRPC's own shutdown would
  // cancel them, which retry policies do not retry); calls in flight
  // finish within the grace time.
  const auto deadline =
      std::chrono::system_clock::now() +
      std::chrono::duration_cast<std::chrono::system_clock::duration>(
          std::chrono::duration<double>(options_.shutdown_grace_seconds));
  service_.Drain(deadline);
  server_->Shutdown(std::chrono::system_clock::now() +
                    std::chrono::milliseconds(100));
}

void MeshGaugeServer::Wait() {
  if (server_) server_->Wait();
}

}  // namespace meshgauge::server
