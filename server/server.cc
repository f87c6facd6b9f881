#include "server/server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include "absl/strings/str_cat.h"

namespace meshgauge::server {

MeshGaugeServer::MeshGaugeServer(const ServerOptions& options, Metrics* metrics,
                                 const Clock* clock)
    : options_(options),
      store_(options, metrics, clock),
      service_(options, &store_, metrics, clock) {}

absl::StatusOr<std::unique_ptr<MeshGaugeServer>> MeshGaugeServer::Start(
    const ServerOptions& options, Metrics* metrics, const Clock* clock) {
  std::unique_ptr<MeshGaugeServer> s(
      new MeshGaugeServer(options, metrics, clock));
  grpc::EnableDefaultHealthCheckService(true);
  if (options.reflection) {
    grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  }
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.address, grpc::InsecureServerCredentials(),
                           &s->port_);
  builder.RegisterService(&s->service_);
  const int max_bytes =
      static_cast<int>(std::min<int64_t>(options.max_message_bytes, INT32_MAX));
  builder.SetMaxReceiveMessageSize(max_bytes);
  builder.SetMaxSendMessageSize(max_bytes);
  s->server_ = builder.BuildAndStart();
  if (!s->server_ || s->port_ == 0) {
    return absl::UnavailableError(
        absl::StrCat("cannot listen on ", options.address));
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
  std::unique_lock<std::mutex> lock(mu_);
  while (!stopping_) {
    cv_.wait_for(
        lock, std::chrono::duration<double>(options_.sweep_interval_seconds));
    if (stopping_) break;
    lock.unlock();
    store_.Sweep();
    lock.lock();
  }
}

void MeshGaugeServer::Shutdown() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (stopping_) return;
    stopping_ = true;
  }
  cv_.notify_all();
  server_->GetHealthCheckService()->SetServingStatus(false);
  std::this_thread::sleep_for(
      std::chrono::duration<double>(options_.drain_notice_seconds));
  const auto deadline =
      std::chrono::system_clock::now() +
      std::chrono::duration_cast<std::chrono::system_clock::duration>(
          std::chrono::duration<double>(options_.shutdown_grace_seconds));
  server_->Shutdown(deadline);
  if (sweeper_.joinable()) sweeper_.join();
}

void MeshGaugeServer::Wait() { server_->Wait(); }

}  // namespace meshgauge::server
