// meshgauge-server: flags are parsed here only, into ServerOptions.
#include <prometheus/exposer.h>
#include <signal.h>

#include <csignal>
#include <fstream>
#include <iostream>
#include <thread>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/reflection.h"
#include "absl/flags/usage.h"
#include "absl/flags/usage_config.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "server/flags_help.h"
#include "server/server.h"

ABSL_FLAG(std::string, address, "127.0.0.1:50051",
          "gRPC listen address host:port (port 0 = any free port)");
ABSL_FLAG(std::string, metrics_address, "127.0.0.1:9464",
          "Prometheus /metrics listen address; empty disables it");
ABSL_FLAG(bool, reflection, false, "enable gRPC server reflection");
ABSL_FLAG(std::string, tls_cert_file, "",
          "PEM certificate chain: serve TLS (with --tls_key_file)");
ABSL_FLAG(std::string, tls_key_file, "", "PEM private key of --tls_cert_file");
ABSL_FLAG(std::string, tls_client_ca_file, "",
          "PEM CA: require client certificates signed by it (mutual TLS)");
ABSL_FLAG(std::string, auth_tokens_file, "",
          "lines 'TENANT SHA256HEX': every RPC but health needs "
          "'authorization: Bearer TOKEN' (a tenant may have several); "
          "SIGHUP re-reads the file; empty: open mode");
ABSL_FLAG(std::string, session_store, "",
          "redis://HOST[:PORT]: sessions live in Redis and any replica "
          "serves any session; empty: in this process's memory");
ABSL_FLAG(int64_t, max_sessions_per_tenant, 0,
          "sessions (and uploads in flight) per tenant; 0: --max_sessions");
ABSL_FLAG(int64_t, memory_budget_bytes_per_tenant, 0,
          "memory per tenant; 0: --memory_budget_bytes");
ABSL_FLAG(int64_t, max_concurrent_uploads, 16, "CreateSession calls at once");
ABSL_FLAG(double, upload_idle_seconds, 30,
          "an upload silent this long is aborted");
ABSL_FLAG(double, upload_deadline_seconds, 600,
          "an upload still running after this long is aborted");
ABSL_FLAG(double, upload_min_bytes_per_second, 65536,
          "after its first --upload_idle_seconds, an upload averaging fewer "
          "bytes per second is aborted (0: no minimum)");
ABSL_FLAG(int64_t, max_message_bytes, 256ll << 20,
          "largest gRPC message accepted or sent");
ABSL_FLAG(int64_t, max_upload_message_bytes, 16ll << 20,
          "largest CreateSession message, checked before it is parsed "
          "(--max_message_bytes applies first)");
ABSL_FLAG(int64_t, max_upload_file_bytes, 256ll << 20,
          "largest mesh file a CreateSession may send for the server's "
          "readers");
ABSL_FLAG(int64_t, max_sessions, 64, "sessions held at once");
ABSL_FLAG(int64_t, max_vertices, 5'000'000, "vertices per session");
ABSL_FLAG(int64_t, max_faces, 10'000'000, "faces per session");
ABSL_FLAG(int, max_rays, 1024, "rays per vertex a request may ask for");
ABSL_FLAG(int64_t, memory_budget_bytes, 8ll << 30,
          "memory for all sessions; least recently used are evicted");
ABSL_FLAG(double, session_ttl_seconds, 3600, "idle time before eviction");
ABSL_FLAG(int, rebuild_every_updates, 32,
          "position updates refit the BVH; every Nth rebuilds it");
ABSL_FLAG(int, compute_threads, 0, "threads per computation (0 = all cores)");
ABSL_FLAG(int, max_computations_per_tenant, 0,
          "computations (ray passes, sensitivities, checks) one tenant runs at "
          "once; more wait their turn (0: the number of cores)");
ABSL_FLAG(int, max_concurrent_computations, 0,
          "computations running at once in all; waiting calls get freed slots "
          "tenant by tenant in turn (0: 4 x the number of cores)");
ABSL_FLAG(double, drain_notice_seconds, 1,
          "on SIGTERM, health says NOT_SERVING this long before draining");
ABSL_FLAG(double, shutdown_grace_seconds, 20,
          "on SIGTERM/SIGINT, time in-flight calls get to finish");
ABSL_FLAG(std::string, port_file, "",
          "write the bound gRPC port to this file once serving (for tests)");

namespace {

// absl's parser exits 1 on a malformed flag value; like a value out of
// range, it is a usage error here: exit 2. Numeric flags are checked before
// absl parses the command line (bool and string values cannot be malformed
// this way; unknown flags are absl's to report).
bool NumericFlagsParse(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    absl::string_view arg = argv[i];
    if (arg == "--") break;
    if (!absl::ConsumePrefix(&arg, "--") && !absl::ConsumePrefix(&arg, "-")) {
      continue;
    }
    const size_t eq = arg.find('=');
    absl::CommandLineFlag* flag = absl::FindCommandLineFlag(arg.substr(0, eq));
    if (flag == nullptr ||
        !(flag->IsOfType<int>() || flag->IsOfType<int64_t>() ||
          flag->IsOfType<double>())) {
      continue;
    }
    std::string value;
    if (eq != absl::string_view::npos) {
      value = std::string(arg.substr(eq + 1));
    } else if (i + 1 < argc) {
      value = argv[++i];
    } else {
      continue;  // absl reports the missing value.
    }
    std::string error;
    if (!flag->ParseFrom(value, &error)) {
      std::cerr << "meshgauge-server: --" << flag->Name() << ": " << error
                << "\n";
      return false;
    }
  }
  return true;
}

meshgauge::server::ServerOptions OptionsFromFlags() {
  meshgauge::server::ServerOptions o;
  o.address = absl::GetFlag(FLAGS_address);
  o.metrics_address = absl::GetFlag(FLAGS_metrics_address);
  o.reflection = absl::GetFlag(FLAGS_reflection);
  o.tls_cert_file = absl::GetFlag(FLAGS_tls_cert_file);
  o.tls_key_file = absl::GetFlag(FLAGS_tls_key_file);
  o.tls_client_ca_file = absl::GetFlag(FLAGS_tls_client_ca_file);
  o.auth_tokens_file = absl::GetFlag(FLAGS_auth_tokens_file);
  o.session_store = absl::GetFlag(FLAGS_session_store);
  o.max_sessions_per_tenant = absl::GetFlag(FLAGS_max_sessions_per_tenant);
  o.memory_budget_bytes_per_tenant =
      absl::GetFlag(FLAGS_memory_budget_bytes_per_tenant);
  o.max_concurrent_uploads = absl::GetFlag(FLAGS_max_concurrent_uploads);
  o.upload_idle_seconds = absl::GetFlag(FLAGS_upload_idle_seconds);
  o.upload_deadline_seconds = absl::GetFlag(FLAGS_upload_deadline_seconds);
  o.upload_min_bytes_per_second =
      absl::GetFlag(FLAGS_upload_min_bytes_per_second);
  o.max_message_bytes = absl::GetFlag(FLAGS_max_message_bytes);
  o.max_upload_message_bytes = absl::GetFlag(FLAGS_max_upload_message_bytes);
  o.max_upload_file_bytes = absl::GetFlag(FLAGS_max_upload_file_bytes);
  o.max_sessions = absl::GetFlag(FLAGS_max_sessions);
  o.max_vertices = absl::GetFlag(FLAGS_max_vertices);
  o.max_faces = absl::GetFlag(FLAGS_max_faces);
  o.max_rays = absl::GetFlag(FLAGS_max_rays);
  o.memory_budget_bytes = absl::GetFlag(FLAGS_memory_budget_bytes);
  o.session_ttl_seconds = absl::GetFlag(FLAGS_session_ttl_seconds);
  o.rebuild_every_updates = absl::GetFlag(FLAGS_rebuild_every_updates);
  o.compute_threads = absl::GetFlag(FLAGS_compute_threads);
  o.max_computations_per_tenant =
      absl::GetFlag(FLAGS_max_computations_per_tenant);
  o.max_concurrent_computations =
      absl::GetFlag(FLAGS_max_concurrent_computations);
  o.shutdown_grace_seconds = absl::GetFlag(FLAGS_shutdown_grace_seconds);
  o.drain_notice_seconds = absl::GetFlag(FLAGS_drain_notice_seconds);
  return o;
}

std::string Describe(const meshgauge::server::ServerOptions& o, int port) {
  return absl::StrCat(
      "meshgauge-server listening on ", o.address, " (port ", port,
      "), metrics on ", o.metrics_address.empty() ? "(off)" : o.metrics_address,
      ", reflection ", o.reflection ? "on" : "off", ", TLS ",
      o.tls_cert_file.empty()
          ? "off"
          : (o.tls_client_ca_file.empty() ? "on" : "on, mutual"),
      ", ",
      o.auth_tokens_file.empty()
          ? "UNAUTHENTICATED (open mode: no --auth_tokens_file)"
          : "tokens required",
      ", sessions ",
      o.session_store.empty() ? "in memory" : "in " + o.session_store,
      "; max_message_bytes=", o.max_message_bytes,
      " max_upload_message_bytes=", o.max_upload_message_bytes,
      " max_upload_file_bytes=", o.max_upload_file_bytes,
      " max_sessions=", o.max_sessions, " max_vertices=", o.max_vertices,
      " max_faces=", o.max_faces, " max_rays=", o.max_rays,
      " memory_budget_bytes=", o.memory_budget_bytes,
      " session_ttl_seconds=", o.session_ttl_seconds,
      " rebuild_every_updates=", o.rebuild_every_updates,
      " compute_threads=", o.compute_threads,
      " max_computations_per_tenant=", o.ComputationsPerTenant(),
      " max_concurrent_computations=", o.ConcurrentComputations(),
      " max_sessions_per_tenant=", o.max_sessions_per_tenant,
      " memory_budget_bytes_per_tenant=", o.memory_budget_bytes_per_tenant,
      " max_concurrent_uploads=", o.max_concurrent_uploads,
      " upload_idle_seconds=", o.upload_idle_seconds,
      " upload_deadline_seconds=", o.upload_deadline_seconds,
      " upload_min_bytes_per_second=", o.upload_min_bytes_per_second,
      " drain_notice_seconds=", o.drain_notice_seconds,
      " shutdown_grace_seconds=", o.shutdown_grace_seconds);
}

}  // namespace

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage("meshgauge-server [flags]");
  meshgauge::ListOwnFlagsInHelp(argc, argv, "server/main.cc", [] {
    return std::string("meshgauge-server ") + MESHGAUGE_VERSION + "\n";
  });
  if (!NumericFlagsParse(argc, argv)) return 2;
  absl::ParseCommandLine(argc, argv);
  const meshgauge::server::ServerOptions options = OptionsFromFlags();
  if (absl::Status s = meshgauge::server::ValidateServerOptions(options);
      !s.ok()) {
    std::cerr << "meshgauge-server: " << s.message() << "\n";
    return 2;
  }
  // Block the signals in every thread; one thread waits for them: SIGHUP
  // re-reads the tokens file, SIGTERM and SIGINT drain and stop.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  meshgauge::server::Metrics metrics;
  std::unique_ptr<prometheus::Exposer> exposer;
  if (!options.metrics_address.empty()) {
    try {
      exposer = std::make_unique<prometheus::Exposer>(options.metrics_address);
      exposer->RegisterCollectable(metrics.registry());
    } catch (const std::exception& e) {
      std::cerr << "meshgauge-server: cannot serve metrics on "
                << options.metrics_address << ": " << e.what() << "\n";
      return 1;
    }
  }
  meshgauge::server::SteadyClock clock;
  auto server =
      meshgauge::server::MeshGaugeServer::Start(options, &metrics, &clock);
  if (!server.ok()) {
    std::cerr << "meshgauge-server: " << server.status().message() << "\n";
    return 1;
  }
  std::cerr << Describe(options, (*server)->port()) << std::endl;
  if (const std::string f = absl::GetFlag(FLAGS_port_file); !f.empty()) {
    std::ofstream(f) << (*server)->port() << "\n";
  }
  std::thread signal_waiter([&] {
    int sig = 0;
    while (sigwait(&signals, &sig) == 0 && sig == SIGHUP) {
      const absl::Status s = (*server)->ReloadTokens();
      std::cerr << "meshgauge-server: SIGHUP: "
                << (s.ok() ? "tokens file re-read"
                           : absl::StrCat("tokens kept: ", s.message()))
                << std::endl;
    }
    std::cerr << "meshgauge-server: signal " << sig << ", draining (grace "
              << options.shutdown_grace_seconds << " s)" << std::endl;
    (*server)->Shutdown();
  });
  (*server)->Wait();
  signal_waiter.join();
  std::cerr << "meshgauge-server: stopped" << std::endl;
  return 0;
}
