#include "server/server_options.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"

namespace meshgauge::server {
namespace {

template <typename T>
absl::Status InRange(const char* flag, T value, T lo, T hi) {
  if (value >= lo && value <= hi) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(
      "--", flag, " must be in [", lo, ", ", hi, "], got ", value));
}

}  // namespace

absl::Status CheckListenAddress(const std::string& address) {
  const auto bad = [&address](const char* why) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--address '", address, "' ", why,
        ": use HOST:PORT, [IPV6]:PORT (PORT in [0, 65535], 0: any free "
        "port), unix:PATH, unix-abstract:NAME or vsock:CID:PORT"));
  };
  absl::string_view a = address;
  for (absl::string_view scheme : {"unix:", "unix-abstract:", "vsock:"}) {
    if (absl::ConsumePrefix(&a, scheme)) {
      return a.empty() ? bad("has nothing after its scheme") : absl::OkStatus();
    }
  }
  const size_t colon = a.rfind(':');
  if (colon == absl::string_view::npos) return bad("has no port");
  absl::string_view host = a.substr(0, colon), port = a.substr(colon + 1);
  if (absl::ConsumePrefix(&host, "[") && !absl::ConsumeSuffix(&host, "]")) {
    return bad("has an unclosed '['");
  }
  if (host.empty()) return bad("has no host");
  if (host.find_first_of(" \t[]") != absl::string_view::npos ||
      (host.find(':') != absl::string_view::npos && a[0] != '[')) {
    return bad("has a malformed host");
  }
  int value = 0;
  if (port.empty() || port.size() > 5 ||
      port.find_first_not_of("0123456789") != absl::string_view::npos ||
      !absl::SimpleAtoi(port, &value) || value > 65535) {
    return bad("has no port in [0, 65535]");
  }
  return absl::OkStatus();
}

int ServerOptions::ComputationsPerTenant() const {
  if (max_computations_per_tenant > 0) return max_computations_per_tenant;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

int ServerOptions::ConcurrentComputations() const {
  if (max_concurrent_computations > 0) return max_concurrent_computations;
  return 4 * std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

absl::Status ValidateServerOptions(const ServerOptions& o) {
  constexpr int64_t kInt32 = 2147483647;
  const absl::Status checks[] = {
      InRange<int64_t>("max_message_bytes", o.max_message_bytes, 4096, kInt32),
      InRange<int64_t>("max_upload_message_bytes", o.max_upload_message_bytes,
                       4096, kInt32),
      InRange<int64_t>("max_upload_file_bytes", o.max_upload_file_bytes, 1,
                       int64_t{4} << 30),
      InRange<int64_t>("max_sessions", o.max_sessions, 1, 1'000'000),
      InRange<int64_t>("max_vertices", o.max_vertices, 1, kInt32),
      InRange<int64_t>("max_faces", o.max_faces, 1, kInt32 / 2),
      InRange<int>("max_rays", o.max_rays, 1, 4096),
      InRange<int64_t>("memory_budget_bytes", o.memory_budget_bytes, 1 << 20,
                       int64_t{1} << 50),
      InRange<int64_t>("max_sessions_per_tenant", o.max_sessions_per_tenant, 0,
                       1'000'000),
      InRange<int64_t>("memory_budget_bytes_per_tenant",
                       o.memory_budget_bytes_per_tenant, 0, int64_t{1} << 50),
      InRange<int64_t>("max_concurrent_uploads", o.max_concurrent_uploads, 1,
                       1024),
      InRange<double>("upload_idle_seconds", o.upload_idle_seconds, 0.01,
                      86400),
      InRange<double>("upload_deadline_seconds", o.upload_deadline_seconds,
                      0.01, 86400),
      InRange<double>("upload_min_bytes_per_second",
                      o.upload_min_bytes_per_second, 0, 1e12),
      InRange<double>("session_ttl_seconds", o.session_ttl_seconds, 0.001, 1e9),
      InRange<int>("rebuild_every_updates", o.rebuild_every_updates, 1,
                   1'000'000),
      InRange<int>("compute_threads", o.compute_threads, 0, 1024),
      InRange<int>("max_computations_per_tenant",
                   o.max_computations_per_tenant, 0, 4096),
      InRange<int>("max_concurrent_computations",
                   o.max_concurrent_computations, 0, 4096),
      InRange<double>("drain_notice_seconds", o.drain_notice_seconds, 0, 3600),
      InRange<double>("shutdown_grace_seconds", o.shutdown_grace_seconds, 0,
                      3600),
      InRange<double>("sweep_interval_seconds", o.sweep_interval_seconds, 0.001,
                      3600),
  };
  for (const absl::Status& s : checks) {
    if (!s.ok()) return s;
  }
  if (o.tls_cert_file.empty() != o.tls_key_file.empty()) {
    return absl::InvalidArgumentError(
        "--tls_cert_file and --tls_key_file go together");
  }
  if (!o.tls_client_ca_file.empty() && o.tls_cert_file.empty()) {
    return absl::InvalidArgumentError(
        "--tls_client_ca_file needs --tls_cert_file and --tls_key_file");
  }
  return absl::OkStatus();
}

}  // namespace meshgauge::server
